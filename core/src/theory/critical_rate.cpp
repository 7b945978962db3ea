// Critical arrival rates and stability regions (see theory/critical_rate.hpp).
#include "netkf/theory/critical_rate.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "netkf/theory/arrival_groups.hpp"
#include "lmi.hpp"
#include "netkf/theory/markov.hpp"
#include "netkf/theory/riccati.hpp"

namespace netkf::theory {

double critical_rate_lower_bound(double alpha, int links) {
  if (alpha <= 1.0) return 0.0;
  if (links < 1) throw std::invalid_argument("critical rate: need at least one link");
  // (1 − λ)^d α² < 1  ⇔  λ > 1 − α^{−2/d}
  return 1.0 - std::pow(alpha, -2.0 / links);
}

std::optional<double> infimum_stable_rate(const std::function<bool(double)>& stable, double lo, double hi,
                                          double tolerance) {
  if (!stable(hi)) return std::nullopt;
  if (stable(lo)) return lo;
  while (hi - lo > tolerance) {
    const double mid = 0.5 * (lo + hi);
    (stable(mid) ? hi : lo) = mid;
  }
  return 0.5 * (lo + hi);
}

RateFamily shared_rate(std::size_t sensors) {
  return [sensors](double rate) { return std::vector<double>(sensors, rate); };
}

std::optional<double> upper_rate_lmi(const Matrix& A, std::span<const SensorSpec> sensors, const RateFamily& rates,
                                     double lo, double tolerance) {
  auto feasible = [&](double rate) {
    const auto r = rates(rate);
    const auto patterns = independent_arrival_patterns(sensors, r);
    return solve_stability_lmi(A, patterns).feasible();
  };
  return infimum_stable_rate(feasible, lo, 1.0, tolerance);
}

std::optional<double> upper_rate_iteration(const Matrix& A, const Matrix& Q, std::span<const SensorSpec> sensors,
                                           const RateFamily& rates, double lo, double tolerance) {
  // Near λ̄ both convergence and divergence are slow; an undecided point counts as "not yet
  // stable", which biases the result upward by far less than the 1e-3 the tests allow.
  UpperBoundOptions options;
  options.max_iterations = 1500;
  // Exact sums only (enumerated or grouped by count); a sampled map would make the bisection noisy.
  bool exact = true;
  auto bounded = [&](double rate) {
    const auto r = rates(rate);
    const PatternSets patterns = grouped_arrival_patterns(sensors, r);
    if (patterns.method == BoundMethod::sampled) {
      exact = false;
      return true;
    }
    return expected_covariance_upper_bound(A, Q, patterns, options).bound.status == BoundStatus::bounded;
  };
  const auto rate = infimum_stable_rate(bounded, lo, 1.0, tolerance);
  if (!exact) return std::nullopt;
  return rate;
}

std::optional<double> exact_rate_markov(const Matrix& A, std::span<const SensorSpec> sensors, const RateFamily& rates,
                                        double lo, double tolerance) {
  std::vector<SensorSpec> bernoulli(sensors.begin(), sensors.end());
  bool applies = true;
  auto stable = [&](double rate) {
    const auto r = rates(rate);
    for (std::size_t i = 0; i < bernoulli.size(); ++i) bernoulli[i].link = BernoulliLink{1.0 - r[i]};
    const auto c = markov_stability_criterion(A, bernoulli);
    if (!c.applies) applies = false;
    return c.stable();
  };
  stable(1.0);
  if (!applies) return std::nullopt;
  return infimum_stable_rate(stable, lo, 1.0, tolerance);
}

std::vector<RegionPoint> stability_region(const Matrix& A, const Matrix& Q, std::span<const SensorSpec> sensors,
                                          const RegionOptions& options) {
  if (sensors.size() != 2) throw std::invalid_argument("stability region: needs exactly two sensors");
  const double alpha = spectral_radius(A);
  std::vector<RegionPoint> out;
  const int points = std::max(2, options.points);
  ProgressReporter progress(options.progress, points);
  for (int k = 0; k < points; ++k) {
    RegionPoint p;
    p.lambda1 = static_cast<double>(k) / (points - 1);
    // Liu-Goldsmith Thm 3: λ2_lower = max(0, 1 − 1/(α²(1 − λ1))).
    const double open = (1.0 - p.lambda1) * alpha * alpha;
    p.lambda2_lower = open <= 1.0 ? 0.0 : 1.0 - 1.0 / open;
    const double l1 = p.lambda1;
    RateFamily family = [l1](double l2) { return std::vector<double>{l1, l2}; };
    if (options.use_lmi) p.lambda2_upper = upper_rate_lmi(A, sensors, family, p.lambda2_lower, options.tolerance);
    p.lambda2_upper_iteration = upper_rate_iteration(A, Q, sensors, family, p.lambda2_lower, options.tolerance);
    if (!options.use_lmi) p.lambda2_upper = p.lambda2_upper_iteration;
    p.lambda2_exact = exact_rate_markov(A, sensors, family, p.lambda2_lower, options.tolerance);
    out.push_back(p);
    progress.add(1);
  }
  return out;
}

}  // namespace netkf::theory
