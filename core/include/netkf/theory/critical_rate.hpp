#pragma once
// Critical arrival rates and the two-sensor stability region.
//  * lower bound λ_ = 1 − 1/α² (Sinopoli Thm 3, eq. 20); with d links sharing the rate λ
//    the same argument (nothing arrives with probability (1−λ)^d, Liu-Goldsmith Thm 3)
//    gives 1 − α^{−2/d}.
//  * upper bound λ̄ = inf{λ : ∃X > g_λ(X)} (Sinopoli Thm 3 eq. 21, Thm 5, Cor. 1):
//    by bisection on the LMI (CSDP), and independently by bisection on whether the
//    g_λ iteration has a fixed point (expected_covariance_upper_bound).
//  * exact λ_c from the necessary-and-sufficient Markov criterion where it applies.
//  * Liu-Goldsmith Thm 3 region: for each λ1, λ2c lies in [λ2_lower, λ2_upper].
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "netkf/model/scenario.hpp"
#include "netkf/support/progress.hpp"
#include "netkf/support/types.hpp"

namespace netkf::theory {

/// 1 − α^{−2/d} (0 when α ≤ 1). d = 1 is Sinopoli's 1 − 1/α².
double critical_rate_lower_bound(double alpha, int links = 1);

/// Infimum of the λ in [lo, hi] for which `stable(λ)` holds, for a predicate monotone in λ
/// (Liu-Goldsmith Lemma 3: more arrivals never hurt). nullopt when even `hi` is not stable.
std::optional<double> infimum_stable_rate(const std::function<bool(double)>& stable, double lo, double hi,
                                          double tolerance);

/// Arrival rates of each sensor as a function of the swept parameter.
using RateFamily = std::function<std::vector<double>(double)>;

/// Every sensor at the same rate λ.
RateFamily shared_rate(std::size_t sensors);

/// λ̄ by bisection on LMI feasibility (CSDP).
std::optional<double> upper_rate_lmi(const Matrix& A, std::span<const SensorSpec> sensors, const RateFamily& rates,
                                     double lo, double tolerance = 1e-5);
/// λ̄ by bisection on whether the expected Riccati iteration has a fixed point, summed
/// exactly (theory/arrival_groups.hpp); nullopt when the patterns would be sampled.
std::optional<double> upper_rate_iteration(const Matrix& A, const Matrix& Q, std::span<const SensorSpec> sensors,
                                           const RateFamily& rates, double lo, double tolerance = 1e-5);
/// Exact λ_c by bisection on the Markov criterion (Bernoulli links at the family's rates);
/// nullopt when the criterion does not apply or nothing in [lo, 1] is stable. The criterion
/// is computed exactly (an eigenvalue of a small transition matrix), so the bisection is run
/// to near machine precision: the scalar example gives 1 − 1/α² = 0.36 to 1e-12.
std::optional<double> exact_rate_markov(const Matrix& A, std::span<const SensorSpec> sensors, const RateFamily& rates,
                                        double lo, double tolerance = 1e-12);

struct RegionPoint {
  double lambda1 = 0.0;
  double lambda2_lower = 0.0;                    // Liu-Goldsmith Thm 3 closed form
  std::optional<double> lambda2_upper;           // LMI bisection (nullopt: unstable even at λ2 = 1)
  std::optional<double> lambda2_upper_iteration; // cross-check by the g iteration
  std::optional<double> lambda2_exact;           // Markov criterion where it applies
};

struct RegionOptions {
  int points = 21;          // λ1 grid over [0, 1]
  bool use_lmi = true;
  double tolerance = 1e-4;
  /// Grid points done of `points` (netkf/support/progress.hpp).
  ProgressCallback progress;
};

/// Stability region bounds for exactly two sensors (Liu-Goldsmith Thm 3, Figs. 4-5).
std::vector<RegionPoint> stability_region(const Matrix& A, const Matrix& Q, std::span<const SensorSpec> sensors,
                                          const RegionOptions& options = {});

}  // namespace netkf::theory
