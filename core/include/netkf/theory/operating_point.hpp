#pragma once
// Theory next to the running network: is the current operating point stable, and what
// do the bounds predict for the mean prediction covariance?
//
// The verdict and its reason are decide_stability()'s (theory/stability.hpp), the same
// as `netkf analyze` gives for the same links.
//
// Intended callers: the estimator's published status and `netkf launch` status, about
// once per second. Cost: the Markov criterion and one expected-Riccati fixed point (at
// most stability_upper_bound_iterations iterations, then a few linear solves); dearest
// where an aperiodic eigen-block runs the Markov chain search to its cap or an operating
// point near the boundary runs V̄ to the iteration cap. Any number of sensors: the
// criterion groups them and V̄ is summed over counts or sampled (theory/arrival_groups.hpp).
// Measured: BENCHMARKS.md, "Operating-point assessment" and "Theory beyond 16 sensors".
// No caches, no threads, no logging: safe to call from any thread.
//
// Typical use (estimator, once per second):
//   std::vector<double> rates = observed_arrival_rates();   // delivered / expected, per sensor
//   auto now = netkf::theory::assess_operating_point(scenario, rates);
//   status.theory_stable = to_string(now.stable);           // "yes" | "no" | "unknown"
//   if (now.upper_trace) status.predicted_trace_upper = *now.upper_trace;
//   if (was.stable == Verdict::yes && now.stable == Verdict::no) warn(now.reason);
#include <optional>
#include <string>
#include <vector>

#include "netkf/model/scenario.hpp"
#include "netkf/theory/report.hpp"

namespace netkf::theory {

struct OperatingPointAssessment {
  Verdict stable = Verdict::unknown;
  std::optional<double> lower_trace;   // Tr S̄ at these rates (nullopt: unbounded)
  std::optional<double> upper_trace;   // Tr V̄ at these rates (nullopt: unbounded / undecided)
  BoundMethod upper_method = BoundMethod::enumerated;  // sampled: upper_trace is an estimate ± its standard error
  double upper_standard_error = 0.0;
  std::optional<double> markov_criterion;  // < 1 stable (when it applies)
  std::string reason;                  // decide_stability()'s line (which result decided, or why none
                                       // did), or what is wrong with the rates; with an actuation link
                                       // the closed loop's (theory/actuation.hpp, closed_loop_verdict)
  Verdict estimator_stable = Verdict::unknown;  // decide_stability()'s verdict alone
  std::optional<ActuationReport> actuation;     // with plant.control.link (no LMI, no cost)
};

/// Assess the scenario's plant and sensors with each sensor's samples arriving i.i.d. at
/// the given rate (observed or configured), in the scenario's sensor order.
/// Rates are clamped to [0, 1]; a wrong count or a NaN gives Verdict::unknown with the reason.
/// With an actuation link: the closed loop's verdict, the inputs arriving i.i.d. at
/// `actuation_arrival_rate` when given (an observed rate), else the link as configured.
OperatingPointAssessment assess_operating_point(const Scenario& scenario, const std::vector<double>& arrival_rates,
                                                std::optional<double> actuation_arrival_rate = std::nullopt);

/// The same for the links as configured, delays folded in: `stable` and `reason` are those of
/// analyze(scenario). Gilbert-Elliott links keep their memory: decided by the Markov criterion
/// alone (unknown where it does not apply); the traces are then the i.i.d. bounds at the
/// stationary rates, which did not decide.
OperatingPointAssessment assess_configured_links(const Scenario& scenario);

/// Per-sensor stationary arrival rates 1 − stationary_loss(link).
std::vector<double> configured_arrival_rates(const Scenario& scenario);

}  // namespace netkf::theory
