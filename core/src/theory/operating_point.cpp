// Theory beside the live network (see theory/operating_point.hpp).
#include "netkf/theory/operating_point.hpp"

#include <algorithm>
#include <cmath>

#include "netkf/links/link_statistics.hpp"
#include "netkf/theory/arrival_groups.hpp"
#include "netkf/theory/riccati.hpp"
#include "netkf/theory/stability.hpp"

namespace netkf::theory {
namespace {

// With an actuation link the verdict becomes the closed loop's, as analyze's does.
OperatingPointAssessment with_actuation(OperatingPointAssessment out, std::optional<ActuationReport> actuation) {
  out.estimator_stable = out.stable;
  if (!actuation) return out;
  const ClosedLoopVerdict loop = closed_loop_verdict(out.stable, out.reason, *actuation);
  out.stable = loop.stable;
  out.reason = loop.reason;
  out.actuation = std::move(actuation);
  return out;
}

// The live status is recomputed about once a second: the verdict, its radius and the
// critical rate; no LMI, no cost.
ActuationOptions live_actuation_options() {
  ActuationOptions o;
  o.optimal = false;
  o.use_lmi = false;
  o.cost = false;
  return o;
}

OperatingPointAssessment assess(const Scenario& scenario, const std::vector<SensorSpec>& sensors,
                                const std::vector<double>& rates) {
  OperatingPointAssessment out;
  const Matrix& A = scenario.plant.A;
  const Matrix& Q = scenario.plant.Q;
  // The verdict `netkf analyze` gives for these links (theory/stability.hpp).
  const StabilityDecision decision = decide_stability(A, Q, sensors, scenario.seed);
  out.stable = decision.stable;
  out.reason = decision.reason;
  if (decision.markov.applies) out.markov_criterion = decision.markov.value;
  if (decision.iid_bounds) {
    if (decision.lower) out.lower_trace = decision.lower->trace();
    if (decision.upper.status == BoundStatus::bounded) out.upper_trace = decision.upper.V.trace();
    out.upper_method = decision.upper_method;
    out.upper_standard_error = decision.upper_standard_error;
    return out;
  }
  // Links with memory: the status still shows the i.i.d. bounds at the stationary rates
  // (operating_point.hpp); they bound nothing for such links, so they did not decide.
  if (auto S = lyapunov_lower_bound(A, Q, all_lost_probability(rates))) out.lower_trace = S->trace();
  UpperBoundOptions ub;
  ub.max_iterations = stability_upper_bound_iterations;
  SamplingOptions sampling;
  sampling.seed = scenario.seed;
  const UpperBoundEstimate V =
      expected_covariance_upper_bound(A, Q, grouped_arrival_patterns(sensors, rates, sampling), ub);
  if (V.bound.status == BoundStatus::bounded) out.upper_trace = V.bound.V.trace();
  out.upper_method = V.method;
  out.upper_standard_error = V.trace_standard_error;
  return out;
}

}  // namespace

std::vector<double> configured_arrival_rates(const Scenario& scenario) {
  std::vector<double> rates;
  for (const auto& s : scenario.sensors) rates.push_back(effective_arrival_rate(s.link, scenario.deadline_ms()));
  return rates;
}

OperatingPointAssessment assess_operating_point(const Scenario& scenario, const std::vector<double>& arrival_rates,
                                                std::optional<double> actuation_arrival_rate) {
  if (arrival_rates.size() != scenario.sensors.size()) {
    OperatingPointAssessment out;
    out.reason = "expected " + std::to_string(scenario.sensors.size()) + " arrival rates, got " +
                 std::to_string(arrival_rates.size());
    return out;
  }
  std::vector<double> rates;
  for (double r : arrival_rates) {
    if (!std::isfinite(r)) {
      OperatingPointAssessment out;
      out.reason = "arrival rate is not a number";
      return out;
    }
    rates.push_back(std::clamp(r, 0.0, 1.0));
  }
  std::vector<SensorSpec> sensors = scenario.sensors;
  for (std::size_t i = 0; i < sensors.size(); ++i) sensors[i].link = BernoulliLink{1.0 - rates[i]};
  return with_actuation(assess(scenario, sensors, rates),
                        actuation_arrival_rate
                            ? analyze_actuation_at(scenario, *actuation_arrival_rate, live_actuation_options())
                            : analyze_actuation(scenario, live_actuation_options()));
}

OperatingPointAssessment assess_configured_links(const Scenario& scenario) {
  const Scenario effective = with_effective_links(scenario);  // what reaches the estimator in time
  return with_actuation(assess(effective, effective.sensors, configured_arrival_rates(scenario)),
                        analyze_actuation(scenario, live_actuation_options()));
}

}  // namespace netkf::theory
