#pragma once
// One typed snapshot of the running network: what the terminal status, the dashboard and
// /metrics all read (built by LiveModel from the records of the live bus). Plain data.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "netkf/cli/live/observed_rate.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/link_status.hpp"
#include "netkf/theory/critical_rate.hpp"
#include "netkf/theory/operating_point.hpp"

namespace netkf::cli {

/// The newest estimate, joined with the truth of the same period when it is known.
struct PeriodView {
  Estimate estimate;
  std::vector<double> truth;  // x_k (empty until the plant's sample for k arrived)
};

/// One link as the channel last reported it (the scenario's link until then), with what the
/// estimator side adds: its late count, and the observed arrival rate over its two windows
/// (observed_rate.hpp defines them; null until the link's first sample since the change).
struct LinkView : LinkStatus {
  bool reported = false;                          // a status from the channel has arrived
  std::uint64_t late_total = 0;                   // delivered but after the estimator fused their period (the estimator's count)
  std::optional<double> observed_rate_since_change;
  std::optional<double> observed_rate_window;
  std::uint64_t observed_window_samples = 0;      // the window's span
};

/// The theory for one set of arrival rates.
struct AssessmentView {
  std::vector<double> arrival_rates;  // per sensor, scenario order
  theory::OperatingPointAssessment result;
};

struct TheoryView {
  bool ready = false;                        // false until the first assessment is computed
  std::int64_t k = -1;                       // newest period when it was requested
  AssessmentView configured;                 // the links as configured (Markov criterion for GE links)
  std::optional<AssessmentView> observed;    // i.i.d. at the observed rates since change, once every link has one
  /// late_policy fuse_within: the final estimates' assessment, the links as configured at the
  /// horizon deadline + D periods (netkf/theory/report.hpp, FinalEstimateReport); `configured`
  /// stays the in-time one.
  std::optional<AssessmentView> final_estimate;
  std::vector<theory::RegionPoint> region; // two-sensor scenarios: Liu-Goldsmith (λ1, λ2) region
};

/// A process of the launch, for the views.
struct ProcessView {
  std::string name;
  int pid = -1;
  bool running = false;
  int restarts = 0;
  std::string host;  // the host it runs on (presence; this launch's host for its children)
};

struct LiveSnapshot {
  std::optional<PeriodView> period;  // nullopt until the first estimate
  std::uint64_t estimates = 0;
  double mean_trace_P = 0.0;
  double mean_trace_P_pred = 0.0;
  std::optional<double> error_norm;  // |x_k − x̂_{k|k}| of the newest period scored
  std::optional<double> rms_error;   // over every period scored
  std::uint64_t late_total = 0;
  std::uint64_t rejected_total = 0;
  std::uint64_t invalid_samples = 0;  // failed validation at the bus (never used)
  std::uint32_t estimator_restarts = 0;  // restarts the estimates report (resumed from a checkpoint)
  std::uint64_t restart_gap_periods = 0;  // periods fused with nothing after the restarts, in all
  std::optional<double> mean_cost;   // closed loop: mean x'Qx x + u'Ru u so far (stage_cost.hpp)
  std::uint64_t periods_costed = 0;  // the periods in that mean
  std::vector<LinkView> links;        // scenario order
  TheoryView theory;
  std::vector<ProcessView> processes;
};

/// Something the views show in their event log.
struct LiveEvent {
  enum class Level { info = 0, warning = 1, error = 2 } level = Level::info;
  std::string text;
  /// Raised by a record (an estimate, a link's status or change), not by the theory: a
  /// recording keeps only these ("the events the records raise", record_mcap.hpp).
  bool from_records = true;
  /// A link change this process asked for, as a reader that did not ask for it words it
  /// ("from netkf ctl or another client"): the recording's text. Empty: as `text`.
  std::string unattributed_text{};
};

}  // namespace netkf::cli
