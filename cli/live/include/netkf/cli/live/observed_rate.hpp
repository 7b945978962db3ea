#pragma once
// The observed arrival rate of a link, defined here once for every view: the page, `netkf
// ctl status`, the terminal status, /metrics, the run summary and the theory's observed
// operating point. It is the share of the samples that entered the link which reached the
// estimator in time: delivered, and not delayed beyond the estimator's deadline (the
// channel's past_deadline), by the channel's counts. The same ratio over two windows:
//
//   since change  over every sample since the link's current model was set: the channel's
//                 (delivered − past_deadline) / samples_in of one report. `netkf ctl status`
//                 can show it from a single report, and the theory's observed operating point
//                 uses it (the most samples of the model the theory assesses).
//   window        over the latest reports since the change that together hold at least
//                 kWindowSamples samples. The channel counts per report (about once a second),
//                 not per sample, so the window spans whole reports: kWindowSamples up to one
//                 report more, and its span is shown with it. Until kWindowSamples samples have
//                 entered since the change it is the since-change rate. It follows what the
//                 since-change rate averages away: a timeline's ramp (which does not reset the
//                 counts) or a recent stretch of bursts.
#include <cstdint>
#include <deque>
#include <optional>

#include "netkf/records/link_status.hpp"

namespace netkf::cli {

/// The window's least span, in samples (10 s of a 100 Hz link).
inline constexpr std::uint64_t kWindowSamples = 1000;

/// Samples delivered and not delayed beyond the deadline, since the model was set.
std::uint64_t delivered_in_time(const LinkStatus& status);
/// delivered_in_time / samples_in; nullopt before the first sample since the change.
std::optional<double> observed_rate_since_change(const LinkStatus& status);

/// The window rate of one link, fed the link's reports in the order the channel sent them.
class ObservedRateWindow {
 public:
  void add(const LinkStatus& status);
  /// In time / samples over the window; nullopt before the first sample since the change.
  std::optional<double> rate() const;
  /// Samples the window spans (0 without a rate).
  std::uint64_t samples() const;

 private:
  struct Counts {
    std::uint64_t samples = 0, in_time = 0;  // since the change
  };
  bool seen_ = false;
  std::uint64_t samples_total_ = 0;  // the last report's lifetime count, to see a reset
  std::deque<Counts> reports_;       // since the change, oldest first: the change itself {0, 0}, then reports
};

}  // namespace netkf::cli
