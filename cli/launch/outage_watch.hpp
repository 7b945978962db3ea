#pragma once
// Which part of the loop stopped serving during a run, so that a closed loop that diverged is
// explained by the process that stalled rather than blamed on the links. Two kinds of evidence,
// both without DDS:
//  - this launch's children as the kernel sees them (/proc/PID/stat: stopped by a signal, or dead
//    and waiting for its restart), sampled by the serve loop;
//  - the data the launch receives, which also covers processes on other hosts and hangs: periods
//    whose truth came late (the plant stalled), periods without an estimate (the estimator), and
//    estimates that fused nothing for many periods in a row (no sample reached the estimator: the
//    channel, or every sensor).
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace netkf::cli {

/// The state of a process as /proc/PID/stat says: 'R', 'S', 'D', 'T' (stopped), 't', 'Z'...;
/// nullopt when it cannot be read (no such process).
std::optional<char> process_state(int pid);

class OutageWatch {
 public:
  using Clock = std::chrono::steady_clock;

  struct Outage {
    std::string what;  // "estimator_node was stopped (SIGSTOP)", "no estimate arrived"
    Clock::time_point from;
    Clock::time_point to;  // == from while it lasts
    bool ongoing = false;
    std::optional<std::int64_t> first_period;  // the periods it spans, where the data says
    std::optional<std::int64_t> last_period;
    double seconds() const { return std::chrono::duration<double>(to - from).count(); }
    std::string describe() const;
  };

  /// `period`: the scenario's period; a gap of data counts from `min_gap_periods` periods on.
  explicit OutageWatch(std::chrono::milliseconds period, int min_gap_periods = 10);

  /// A child of this launch as the serve loop samples it: running (then its /proc state says
  /// whether it is stopped), dead and waiting for its restart, or ended for good.
  enum class ChildState { running, restarting, ended };
  void child(const std::string& name, int pid, ChildState state, Clock::time_point now);
  /// The plant's truth of period k arrived.
  void truth(std::int64_t k, Clock::time_point now);
  /// The (in-time) estimate of period k arrived, having fused `fused_count` samples.
  void estimate(std::int64_t k, std::size_t fused_count, Clock::time_point now);
  /// Close what still lasts (at the end of the run).
  void finish(Clock::time_point now);

  /// Every outage seen, oldest first.
  const std::vector<Outage>& outages() const { return outages_; }
  /// The outages that overlap [from, to], oldest first, as one sentence ("" when none).
  std::string describe_between(Clock::time_point from, Clock::time_point to) const;

 private:
  void open(const std::string& key, const std::string& what, Clock::time_point from,
            std::optional<std::int64_t> first_period = std::nullopt);
  void close(const std::string& key, Clock::time_point to, std::optional<std::int64_t> last_period = std::nullopt);

  Clock::duration min_gap_;
  std::int64_t min_gap_periods_;
  std::vector<Outage> outages_;
  std::map<std::string, std::size_t> open_;  // key -> index in outages_ of the one that lasts
  std::optional<std::pair<std::int64_t, Clock::time_point>> last_truth_;
  std::optional<std::pair<std::int64_t, Clock::time_point>> last_estimate_;
  std::int64_t nothing_fused_since_ = -1;  // first period of the current run of empty estimates
  Clock::time_point nothing_fused_from_{};
};

}  // namespace netkf::cli
