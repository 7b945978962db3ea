// Theory beside the live network (see analysis/operating_point.hpp).
#include "netkf/analysis/operating_point.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "netkf/analysis/markov.hpp"
#include "netkf/analysis/riccati.hpp"

namespace netkf::analysis {
namespace {

OperatingPointAssessment assess(const Scenario& scenario, const std::vector<SensorSpec>& sensors,
                                const std::vector<double>& rates) {
  OperatingPointAssessment out;
  const Matrix& A = scenario.plant.A;
  const Matrix& Q = scenario.plant.Q;
  // i.i.d. bounds at these rates (cheap: capped iterations, the live caller runs once a second).
  const auto patterns = independent_arrival_patterns(sensors, rates);
  if (auto S = lyapunov_lower_bound(A, Q, all_lost_probability(rates))) out.lower_trace = S->trace();
  UpperBoundOptions ub;
  ub.max_iterations = 2000;
  const UpperBound V = expected_covariance_upper_bound(A, Q, patterns, ub);
  if (V.status == BoundStatus::bounded) out.upper_trace = V.V.trace();

  const MarkovCriterion markov = markov_stability_criterion(A, sensors);
  std::ostringstream why;
  why.precision(4);
  if (markov.applies) {
    out.markov_criterion = markov.value;
    out.stable = markov.stable() ? Verdict::yes : Verdict::no;
    why << "Markov criterion " << markov.value << (markov.stable() ? " < 1 (stable)" : " >= 1 (below the critical boundary)");
  } else if (V.status == BoundStatus::bounded) {
    out.stable = Verdict::yes;
    why << "V-bar exists (Sinopoli Thm 3/5): stable";
  } else if (!out.lower_trace) {
    out.stable = Verdict::no;
    why << "S-bar unbounded (all-lost probability * alpha^2 >= 1): below the critical rate";
  } else {
    out.stable = Verdict::unknown;
    why << "between the bounds; " << (markov.reasons.empty() ? std::string() : markov.reasons.front());
  }
  out.reason = why.str();
  return out;
}

}  // namespace

std::vector<double> configured_arrival_rates(const Scenario& scenario) {
  std::vector<double> rates;
  for (const auto& s : scenario.sensors) rates.push_back(effective_arrival_rate(s.link, scenario.deadline_ms()));
  return rates;
}

OperatingPointAssessment assess_operating_point(const Scenario& scenario, const std::vector<double>& arrival_rates) {
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
  return assess(scenario, sensors, rates);
}

OperatingPointAssessment assess_configured_links(const Scenario& scenario) {
  const Scenario effective = with_effective_links(scenario);  // what reaches the estimator in time
  return assess(effective, effective.sensors, configured_arrival_rates(scenario));
}

}  // namespace netkf::analysis
