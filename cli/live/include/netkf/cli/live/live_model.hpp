#pragma once
// The live model of `netkf launch`: fed the bus's records, it keeps the one snapshot that
// every view reads (LiveSnapshot) and raises events (link changes, boundary crossings). A
// launch owns one, fed once per record before its readers see the record: the console (the
// terminal, the dashboard, /metrics), the MCAP recorder (its link views and events) and the
// run summary (the period join's scores) all read it; each reader of the events subscribes
// and takes them at its own pace.
// Pure bookkeeping: no DDS, no threads, no theory computation (the caller computes the
// theory off its loop, see TheoryWorker, and hands the result back with set_theory).
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "netkf/cli/live/live_snapshot.hpp"
#include "netkf/cli/live/observed_rate.hpp"
#include "netkf/cli/live/period_join.hpp"
#include "netkf/cli/live/stage_cost.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/link_change.hpp"
#include "netkf/records/link_status.hpp"
#include "netkf/records/truth.hpp"

namespace netkf::cli {

class LiveModel {
 public:
  /// After this many estimates, a sensor the channel never heard from is reported.
  static constexpr std::uint64_t kSilentSensorCheck = 200;
  /// Every this many estimates, the share of samples that arrived after their period was fused
  /// is compared with the share the links' delays explain; more than kLateExcess above it (and
  /// at least 10 samples) raises a warning: the network cannot keep up (e.g. 768 sensors at
  /// 100 ms on two cores, BENCHMARKS.md "Sensor count limit"), or the deadline is too short.
  static constexpr std::uint64_t kLateWindow = 100;
  static constexpr double kLateExcess = 0.1;

  explicit LiveModel(Scenario scenario);

  void add_truth(const Truth& truth);
  void add_estimate(const Estimate& estimate);
  /// True when the link's model moved: its first report, or another link than last reported.
  bool add_link_status(const LinkStatus& status);
  /// A journaled link change (the timeline's show up in the event log).
  void add_link_change(const LinkChange& change);
  void count_invalid() { ++snapshot_.invalid_samples; }

  /// Request ids that this process sent itself, so that a change can name its source.
  void note_own_request(std::uint64_t request_id, std::string source);

  /// The scenario with each link as the channel last reported it.
  Scenario configured_scenario() const;
  /// The theory's observed operating point: each link's observed arrival rate since change
  /// (observed_rate.hpp), scenario order, once every link has one.
  std::optional<std::vector<double>> observed_rates_since_change() const;
  /// The actuation link's observed arrival rate since its change (nullopt: none, or not yet).
  std::optional<double> observed_actuation_rate_since_change() const;

  /// A finished theory computation; raises a warning when the configured verdict crosses
  /// the critical boundary.
  void set_theory(TheoryView theory);
  void set_processes(std::vector<ProcessView> processes) { snapshot_.processes = std::move(processes); }

  const LiveSnapshot& snapshot() const { return snapshot_; }
  /// The link of a sensor id (kControlLinkId: the actuation link); nullptr when not in the scenario.
  const LinkView* find_link(int sensor_id) const;
  const Scenario& scenario() const { return scenario_; }
  /// A reader of the events: each takes every event raised after it subscribed, once.
  using Subscriber = std::size_t;
  /// The reader made with the model (a model with one reader needs no subscribe()).
  static constexpr Subscriber kFirstReader = 0;
  Subscriber subscribe();
  /// The reader reads no more: the events it did not take are not kept for it.
  void unsubscribe(Subscriber reader);
  /// Events raised since the reader's last call.
  std::vector<LiveEvent> take_events(Subscriber reader = kFirstReader);
  void raise(LiveEvent::Level level, std::string text) { raise(LiveEvent{level, std::move(text)}); }

  /// The join of truths and in-time estimates, and its running score (the snapshot's
  /// rms_error): Σ |x_k − x̂_{k|k}|² over the periods scored, in the order they were scored.
  const PeriodJoin& join() const { return join_; }
  double sum_squared_error() const { return sum_sq_error_; }
  std::uint64_t periods_scored() const { return scored_; }

  bool saw_non_finite() const { return saw_non_finite_; }

 private:
  void score(std::optional<double> squared_error);
  void check_late_share();
  LinkView* link(int sensor_id);
  void raise(LiveEvent event);
  void forget_taken_events();

  Scenario scenario_;
  LiveSnapshot snapshot_;
  // sensor id -> index in snapshot_.links (fixed at construction): every link reports once a
  // second, and a search of 4096 links per report is quadratic.
  std::map<int, std::size_t> link_index_;
  PeriodJoin join_;
  RunningCost cost_;  // the snapshot's mean_cost (the summary's `cost` over the periods seen so far)
  double sum_trace_ = 0.0;
  double sum_trace_pred_ = 0.0;
  double sum_sq_error_ = 0.0;
  std::uint64_t scored_ = 0;
  bool saw_non_finite_ = false;
  std::optional<std::uint64_t> restart_gap_from_;  // first period after a restart, until fusion resumes
  // The current late-share window (kLateWindow estimates) and whether the last one warned.
  std::uint64_t window_estimates_ = 0, window_fused_ = 0, window_late_ = 0;
  bool late_warned_ = false;
  std::map<std::uint64_t, std::string> own_requests_;  // request id -> source ("dashboard")
  std::map<int, ObservedRateWindow> windows_;           // per sensor id
  // The events not yet taken by every reader; events_.front() is event number first_event_.
  std::deque<LiveEvent> events_;
  std::uint64_t first_event_ = 0;
  std::vector<std::optional<std::uint64_t>> next_event_;  // per reader; nullopt: unsubscribed
};

}  // namespace netkf::cli
