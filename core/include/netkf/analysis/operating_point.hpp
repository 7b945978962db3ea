#pragma once
// Theory next to the running network: is the current operating point stable, and what
// do the bounds predict for the mean prediction covariance?
//
// Intended callers: the estimator's published status and `netkf launch` status, about
// once per second. Cost: one expected-Riccati fixed point (≤ 2000 iterations, then a
// few linear solves) and the Markov criterion: measured 0.01-1 ms for most shipped
// scenarios, 21 ms for liu-goldsmith-fig5 and 28 ms for a 6-state, 4-sensor system (an
// aperiodic eigen-block makes the Markov chain search run to its cap) on a loaded 2-core
// machine. No caches, no threads, no logging: safe to call from any thread.
//
// Typical use (estimator, once per second):
//   std::vector<double> rates = observed_arrival_rates();   // delivered / expected, per sensor
//   auto now = netkf::analysis::assess_operating_point(scenario, rates);
//   status.theory_stable = to_string(now.stable);           // "yes" | "no" | "unknown"
//   if (now.upper_trace) status.predicted_trace_upper = *now.upper_trace;
//   if (was.stable == Verdict::yes && now.stable == Verdict::no) warn(now.reason);
#include <optional>
#include <string>
#include <vector>

#include "netkf/analysis/report.hpp"
#include "netkf/scenario.hpp"

namespace netkf::analysis {

struct OperatingPointAssessment {
  Verdict stable = Verdict::unknown;
  std::optional<double> lower_trace;   // Tr S̄ at these rates (nullopt: unbounded)
  std::optional<double> upper_trace;   // Tr V̄ at these rates (nullopt: unbounded / undecided)
  std::optional<double> markov_criterion;  // < 1 stable (when it applies)
  std::string reason;                  // one line: which result decided, or why none did
};

/// Assess the scenario's plant and sensors with each sensor's samples arriving i.i.d. at
/// the given rate (observed or configured), in the scenario's sensor order.
/// Rates are clamped to [0, 1]; a wrong count or a NaN gives Verdict::unknown with the reason.
OperatingPointAssessment assess_operating_point(const Scenario& scenario, const std::vector<double>& arrival_rates);

/// The same for the links as configured (Gilbert-Elliott links keep their memory: decided
/// by the Markov criterion; the i.i.d. bounds are then evaluated at the stationary rates).
OperatingPointAssessment assess_configured_links(const Scenario& scenario);

/// Per-sensor stationary arrival rates 1 − stationary_loss(link).
std::vector<double> configured_arrival_rates(const Scenario& scenario);

}  // namespace netkf::analysis
