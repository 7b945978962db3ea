#pragma once
// The summary of a `netkf launch` run and its pass/fail checks (`--summary FILE.json`,
// `--check 'rms_error<0.8'`): what a user's CI asks of a run, measured from the records the
// launch already gathers (truth, estimates, link status). No DDS, no clock: the tests feed it
// hand-made records.
//
// The quantities (also docs/experiments.md, "Pass/fail checks in your CI"); a check names one of them,
// per link as `link.ID.NAME`, and the summary's JSON uses the same names:
//   periods              estimates received, one per period the estimator fused
//   rms_error            sqrt(mean over periods with both truth and estimate of |x_k − x̂_{k|k}|²),
//                        x̂ the in-time estimate (revision 0) the control loop used
//   rms_error_final      the same with each period's final estimate (its last revision; with
//                        late_policy drop there is none and it equals rms_error)
//   mean_trace_P         mean over periods of Tr P_{k|k}
//   mean_trace_P_pred    mean over periods of Tr P_{k|k-1}: what the theory's S̄, V̄ bound (Sinopoli Thm 4)
//   late_fraction        late samples (Σ over estimates of `late`) / samples the channel delivered
//                        (Σ over links of `delivered`)
//   fused_fraction       Σ over periods of the number of sensors fused / (periods × sensors)
//   periods_diverging    periods whose filter state is `diverging`
//   pipeline_latency_p50_ms, pipeline_latency_p99_ms
//                        nearest-rank percentiles, over periods with a fused sample, of the time
//                        from the publication of the newest sample fused for the period to the
//                        publication of its estimate (one steady clock), in ms
//   link.ID.samples, link.ID.delivered, link.ID.dropped
//                        the channel's lifetime counters of link ID as it last reported them
//                        (never reset by a link change; summed over restarts of the channel)
//   link.ID.observed_loss  link.ID.dropped / link.ID.samples
//   link.ID.observed_arrival_rate_since_change, link.ID.observed_arrival_rate_window,
//   link.ID.observed_window_samples
//                        the observed arrival rate (observed_rate.hpp) as the channel last reported
//                        it: since the link's model was last set, and over the window of at least
//                        1000 samples, with the window's span
//   link.ID.late         late samples of sensor ID (its entries in the estimates' late_sensors)
//   link.ID.fused        periods in which sensor ID was fused
// A quantity with nothing to measure (no estimate received, a link the channel never
// reported, ...) has no value: null in the JSON, and a check on it fails, saying why.
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "netkf/cli/live/observed_rate.hpp"
#include "netkf/cli/live/period_join.hpp"
#include "netkf/cli/live/stage_cost.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/link_status.hpp"
#include "netkf/records/truth.hpp"
#include "netkf/support/types.hpp"

namespace netkf::cli {

/// One link of the run. Counts are exact integers.
struct LinkSummary {
  int id = 0;
  bool reported = false;       // the channel reported this link at least once
  std::uint64_t samples = 0;   // lifetime counters of the channel
  std::uint64_t delivered = 0;
  std::uint64_t dropped = 0;
  std::uint64_t late = 0;      // from the estimates' late_sensors
  std::uint64_t fused = 0;     // periods with this sensor fused
  std::optional<double> observed_rate_since_change;  // at the last report (observed_rate.hpp)
  std::optional<double> observed_rate_window;
  std::uint64_t observed_window_samples = 0;
};

struct RunSummary {
  std::uint64_t periods = 0;
  std::uint64_t periods_scored = 0;   // with both truth and estimate (rms_error's periods)
  double sum_squared_error = 0.0;     // Σ |x_k − x̂_{k|k}|² over the scored periods
  std::uint64_t periods_scored_final = 0;  // the same with each period's final estimate
  double sum_squared_error_final = 0.0;
  std::uint64_t revisions = 0;        // revised estimates received (late_policy fuse_within)
  double sum_trace_P = 0.0;           // Σ Tr P_{k|k} over the periods
  double sum_trace_P_pred = 0.0;      // Σ Tr P_{k|k-1} over the periods
  std::uint64_t fused = 0;            // Σ over periods of the sensors fused
  std::uint64_t late = 0;             // Σ over estimates of `late`
  std::uint64_t periods_diverging = 0;
  std::vector<double> latencies_ms;   // one per period with a fused sample
  RunningCost cost;                   // closed loop: the mean stage cost over the periods with a truth
  int sensors = 0;
  std::vector<LinkSummary> links;     // scenario order
};

/// A quantity of the summary, or why it has none (then `value` is NaN).
struct Measured {
  double value = std::numeric_limits<double>::quiet_NaN();
  std::string missing;  // empty when measured
  bool count = false;   // an integer count (written as one in the JSON)
  bool measured() const { return missing.empty(); }
};

/// Every name a check may use, for the scenario's link ids: the run's quantities, then
/// `link.ID.NAME` per link.
std::vector<std::string> summary_names(const std::vector<int>& link_ids);
/// The value of `name` (one of summary_names for the summary's links); throws
/// std::invalid_argument for any other name.
Measured measure(const RunSummary& summary, const std::string& name);

/// The p-th percentile (0 < p <= 100) by nearest rank: the smallest value with at least p % of
/// the values at or below it, i.e. the ceil(p/100 × N)-th smallest. NaN when empty.
double nearest_rank_percentile(std::vector<double> values, double p);

class LiveModel;

/// Builds the summary from the launch's records, in any order of arrival.
class RunSummaryBuilder {
 public:
  /// With a period join of its own, fed by add_truth and add_estimate.
  explicit RunSummaryBuilder(const Scenario& scenario);
  /// Reading the join of `model` (the launch's one live model) and its score: the model's
  /// owner feeds it each record before the summary gets it; `model` must outlive the builder.
  /// The live model scores the in-time estimates as the summary does (and drops a non-finite
  /// one, which the bus's validation never lets through).
  explicit RunSummaryBuilder(const LiveModel& model);

  void add_truth(const Truth& truth);
  void add_estimate(const Estimate& estimate);
  void add_link_status(const LinkStatus& status);

  const RunSummary& summary() const { return summary_; }

 private:
  LinkSummary* link(int sensor_id);

  /// The channel's lifetime counters of one link; a total that goes back means the channel
  /// restarted, and its counts start again from zero on top of what it had counted.
  struct Counters {
    std::uint64_t samples = 0, delivered = 0, dropped = 0;
  };
  std::map<int, Counters> before_restarts_;
  std::map<int, Counters> last_;
  std::map<int, ObservedRateWindow> windows_;
  RunSummary summary_;
  const LiveModel* model_ = nullptr;  // its join, when given
  PeriodJoin own_join_;               // without a model
  const PeriodJoin& join() const;
  /// rms_error's terms: scored by its own join, or as the model scored them.
  void score(std::optional<double> squared_error);
  void take_model_score();
  /// rms_error_final: the newest estimate of each recent period, and its term in the sum.
  struct Final {
    std::uint32_t revision = 0;
    Vector x_hat;
    std::optional<double> squared_error;  // in sum_squared_error_final
  };
  std::map<std::int64_t, Final> finals_;
  void score_final(std::int64_t k);
};

// ---------------------------------------------------------------- checks

enum class CheckOp { less, less_equal, greater, greater_equal };
const char* to_string(CheckOp op);

/// `NAME OP NUMBER` as the user wrote it, parsed.
struct Check {
  std::string text;
  std::string name;
  CheckOp op = CheckOp::less;
  double threshold = 0.0;
};

/// `NAME OP NUMBER` parsed, whatever the name (the relay's checks, relay_summary.hpp, name topics):
/// throws std::invalid_argument for no or another operator, no name, not a finite number.
Check parse_check_syntax(const std::string& text, const std::string& example = "rms_error<0.8");

/// Parses `NAME<VALUE`, `NAME<=VALUE`, `NAME>VALUE`, `NAME>=VALUE` (whitespace allowed around
/// the operator; VALUE a finite number) for a scenario with `link_ids`. Throws
/// std::invalid_argument saying what is wrong: no or another operator, no name, not a finite
/// number, an unknown name (with the names there are), a link id not in the scenario.
Check parse_check(const std::string& text, const std::vector<int>& link_ids);

struct CheckResult {
  Check check;
  Measured measured;
  bool passed = false;
  /// "PASS", "FAIL", or "FAIL (not measured: why)".
  std::string verdict() const;
};

/// Each check against the summary: it passes only when its value was measured and satisfies
/// the comparison (NaN never passes).
std::vector<CheckResult> evaluate_checks(const std::vector<Check>& checks, const RunSummary& summary);
/// The same against any summary: `measure` gives a check's name its value.
std::vector<CheckResult> evaluate_checks(const std::vector<Check>& checks,
                                         const std::function<Measured(const std::string&)>& measure);
bool all_passed(const std::vector<CheckResult>& results);

/// The table printed at the end of a run: check, measured value, verdict; then a count.
std::string render_check_table(const std::vector<CheckResult>& results);

/// The summary as JSON: every quantity under its name (links under "link": {"ID": {...}}, so a
/// check's name is its path), null when not measured; "checks" with value and verdict;
/// "passed" (every check passed). Keys in the order of the definitions above.
nlohmann::ordered_json summary_json(const RunSummary& summary, const std::vector<CheckResult>& results);
/// A quantity as the summary's JSON writes it: a number, an integer for a count, null when not measured.
nlohmann::ordered_json measured_json(const Measured& m);
/// The summary JSON's "checks": each check with its value and verdict.
nlohmann::ordered_json checks_json(const std::vector<CheckResult>& results);

}  // namespace netkf::cli
