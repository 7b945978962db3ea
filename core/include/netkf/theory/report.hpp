#pragma once
// `netkf analyze`: everything the papers say about a scenario, in one report
// (docs/architecture.md, "netkf analyze FILE --json" lists the keys).
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "netkf/model/scenario.hpp"
#include "netkf/theory/actuation.hpp"
#include "netkf/theory/critical_rate.hpp"
#include "netkf/theory/stability.hpp"  // Verdict

namespace netkf::theory {

struct CriticalRates {
  double lower = 0.0;                       // Sinopoli Thm 3 closed form (1 − α^{−2/d})
  std::optional<double> upper;              // LMI bisection (CSDP), Sinopoli Cor. 1
  std::optional<double> upper_iteration;    // cross-check: bisection on the g_λ iteration
  std::optional<double> exact;              // Markov criterion where it applies
};

struct CriticalRateOptions {
  bool use_lmi = true;
  int lmi_max_block = 48;   // AnalyzeOptions::lmi_max_block
  /// Bisect on the Markov criterion for `exact` (analyze() does when the criterion at the
  /// configured links applied and was computed exactly).
  bool exact = true;
};

/// The critical arrival rates of `sensors` when every link is Bernoulli with one shared arrival
/// rate λ (the links' configured models are not read). What analyze() reports as
/// `critical_rate`; `notes` (optional) gets what it says about how they were found.
CriticalRates shared_critical_rates(const Matrix& A, const Matrix& Q, std::span<const SensorSpec> sensors,
                                    const CriticalRateOptions& options, std::vector<std::string>* notes = nullptr);

/// Tr S̄ and Tr V̄ (Sinopoli Thm 4; Liu-Goldsmith Thm 4) with each sensor's link i.i.d. at the
/// given arrival rate; nullopt: unbounded (or, for V̄, undecided).
struct TraceBounds {
  std::optional<double> lower_trace;
  std::optional<double> upper_trace;
};
/// `seed` seeds the patterns sampled when there are too many to sum (theory/arrival_groups.hpp).
/// Throws std::invalid_argument unless there is one rate in [0, 1] per sensor.
TraceBounds iid_trace_bounds(const Matrix& A, const Matrix& Q, std::span<const SensorSpec> sensors,
                             std::span<const double> arrival_rates, std::uint64_t seed);

struct SweepPoint {
  double lambda = 0.0;
  std::optional<double> lower_trace;  // Tr S̄ (nullopt: unbounded)
  std::optional<double> upper_trace;  // Tr V̄ (nullopt: unbounded or undecided)
};

/// What the estimator receives of one link: the loss model's stationary loss, the share of
/// delivered samples in time for the deadline, and their product.
struct LinkArrival {
  int sensor_id = 0;
  double loss = 0.0;               // stationary loss of the configured model
  double in_time = 1.0;            // P(delay <= deadline)
  double effective_arrival_rate = 1.0;  // (1 − loss) · in_time
};

/// late_policy fuse_within: the final estimate (after every revision) of period k fuses the
/// samples delayed at most deadline + D periods, so it is the intermittent filter with the
/// arrival rates (1 − loss)·P(delay ≤ deadline + D·period) (same reasoning as the deadline's
/// effective arrival rate, with a longer horizon). The in-time estimate keeps the report's
/// top-level verdict and bounds.
struct FinalEstimateReport {
  int max_delay_periods = 0;             // D
  double horizon_ms = 0.0;               // deadline + D·period
  Verdict stable = Verdict::unknown;
  std::string stable_reason;
  std::optional<double> lower_trace;     // Tr S̄ at the final arrival rates
  std::optional<double> upper_trace;     // Tr V̄
  bool iid_bounds = false;
  BoundMethod upper_method = BoundMethod::enumerated;
  std::optional<double> upper_trace_standard_error;
  std::optional<double> markov_criterion;
  std::vector<LinkArrival> links;        // in_time = P(delay <= horizon)
};

struct AnalysisReport {
  double spectral_radius = 0.0;
  /// decide_stability() for the configured links; with an actuation link the closed loop's
  /// (closed_loop_verdict: the estimator's and the actuation link's).
  Verdict stable = Verdict::unknown;
  std::string stable_reason;           // its one line, as the live status says it (also in `notes`)
  Verdict estimator_stable = Verdict::unknown;  // decide_stability() alone (= stable without an actuation link)
  std::string estimator_stable_reason;
  std::optional<ActuationReport> actuation;     // with plant.control.link only
  std::optional<ActuationRegion> actuation_region;  // AnalyzeOptions::region with an actuation link
  std::optional<double> lower_trace;   // Tr S̄ for the configured links
  std::optional<double> upper_trace;   // Tr V̄
  bool iid_bounds = false;             // S̄/V̄ were computed (every link Bernoulli); else not reported
  BoundMethod upper_method = BoundMethod::enumerated;  // how V̄ was summed; sampled: an estimate, not a bound
  std::optional<double> upper_trace_standard_error;    // sampled only
  /// Links with memory (no i.i.d. bound applies) and a stable verdict: lim E[Tr P_{k|k-1}]
  /// estimated by simulation over the links' own loss sequences (core/src/theory/sampled_covariance.hpp),
  /// with its standard error. An estimate, not a bound; nullopt otherwise.
  std::optional<double> sampled_trace;
  std::optional<double> sampled_trace_standard_error;
  std::optional<CriticalRates> critical_rate;  // all links Bernoulli with one shared rate
  std::optional<double> markov_criterion;      // max_i α_i² limsup P(R_N(i))^{1/N}
  std::optional<double> second_order_criterion;  // Thm 12 closed form (cross-check), when it applies
  std::vector<LinkArrival> links;      // per link, in the scenario's order
  std::vector<std::string> notes;
  std::vector<RegionPoint> region;     // filled with AnalyzeOptions::region (two sensors)
  std::vector<SweepPoint> sweep;       // filled with AnalyzeOptions::sweep
  std::optional<FinalEstimateReport> final_estimate;  // late_policy fuse_within only
};

struct AnalyzeOptions {
  bool region = false;
  int region_points = 21;
  bool sweep = false;
  int sweep_points = 101;
  bool use_lmi = true;
  /// The LMI's first block has n(1 + #patterns) rows; CSDP takes ~1.5 s per solve at ~100
  /// (6 states, 4 sensors), so above this size the bisection uses the g iteration only (it
  /// computes the same λ̄ = inf{λ : ∃X > g_λ(X)}) and says so in the notes. 0: no limit.
  int lmi_max_block = 48;
  /// With `region`: the region's grid points done (netkf/support/progress.hpp).
  ProgressCallback progress;
  /// With `region` and an actuation link: the sensor of the (γ̄, ν̄) region; by default the
  /// only sensor of a one-sensor scenario.
  std::optional<int> region_sensor;
};

/// Analyse a validated scenario. Never throws for a valid scenario; what does not apply
/// is said in `notes`.
AnalysisReport analyze(const Scenario& scenario, const AnalyzeOptions& options = {});

}  // namespace netkf::theory
