// The TCP-like LQG loop of Schenato, Sinopoli, Franceschetti, Poolla & Sastry, "Foundations of
// control and estimation over lossy networks", Proc. IEEE 95(1), 2007, Sec. V (and Sinopoli et
// al., "Optimal control with unreliable communication: the TCP case", ACC 2005): observations
// arrive with probability γ̄, inputs with ν̄ (a lost input is applied as zero), both links
// acknowledged. The optimal controller is u_k = −L x̂_{k|k} with L from the control Riccati
// equation at ν̄, and the long-run mean cost lim (1/N) E Σ (x'W x + ν_k u'U u) lies in
//   J_min = tr(S Q) + (1 − γ̄) tr((A'SA + W − S) P̲),      P̲ = (1 − γ̄) A P̲ A' + Q,
//   J_max = tr(S Q) + tr((A'SA + W − S)(P̄ − γ̄ P̄C'(CP̄C' + R)^{-1}CP̄)),
// P̄ the fixed point of the estimator's modified Riccati map at γ̄, S that of the control map at
// ν̄; both exist, and the loop is stable, iff γ̄ > γ_c and ν̄ > ν_c (the region is a product:
// separation), with γ_c = ν_c = 1 − 1/α² when C and B are square and invertible.
//
// What is NOT here: a figure or table of either paper. Their example sections (matrices, the
// plotted region or cost curves) were not readable in the stored copies (only the openings of
// the texts, with the cost functional and the TCP/UDP information sets); no number of theirs is
// asserted. Instead the library's bounds are checked against the scalar closed forms of the
// formulas above (each Riccati equation solved as a quadratic), on Sinopoli 2004's scalar
// example (A = −1.25, C = 1, Q = 1, R = 2.5, whose P̄ = 7.3266 at γ̄ = 0.6 docs/validation.md
// lists), and against a Monte Carlo of the whole loop (Kalman filter with intermittent
// observations, lossy-input LQR, plant) written here from the loop's equations.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <optional>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "netkf/theory/actuation.hpp"
#include "netkf/theory/lqr.hpp"

namespace {

using netkf::BernoulliLink;
using netkf::Matrix;
using netkf::OnLoss;
using netkf::SensorSpec;
namespace theory = netkf::theory;

Matrix scalar(double v) { return Matrix::Constant(1, 1, v); }

// The library's J_min, J_max for the optimal TCP-like loop, composed the way `netkf analyze`
// does (theory/actuation.cpp): nullopt outside the stability region.
struct LibraryBounds {
  double lower = 0.0;
  double upper = 0.0;
  theory::CostModel model;
  theory::FilteredCovarianceBounds pi;
  Matrix gain;
};
std::optional<LibraryBounds> library_bounds(const Matrix& A, const Matrix& B, const Matrix& C, const Matrix& Q,
                                            const Matrix& R, const Matrix& W, const Matrix& U, double gamma,
                                            double nu) {
  if (!netkf::theory::solve_lossy_dare(A, B, W, U, nu)) return std::nullopt;
  LibraryBounds out;
  out.gain = netkf::theory::lossy_lqr_gain(A, B, W, U, nu);
  const auto modes = theory::actuation_modes(A, B, out.gain, OnLoss::zero);
  const auto model = theory::actuation_cost_model(A, Q, modes, BernoulliLink{1.0 - nu}, W, U);
  SensorSpec sensor;
  sensor.C = C;
  sensor.R = R;
  sensor.link = BernoulliLink{1.0 - gamma};
  const std::vector<SensorSpec> sensors{sensor};
  const auto pi = theory::filtered_covariance_bounds(A, Q, sensors);
  if (!model || !pi) return std::nullopt;
  out.model = *model;
  out.pi = *pi;
  std::tie(out.lower, out.upper) = theory::cost_bounds(*model, *pi);
  return out;
}

// The positive root of k2 x² + k1 x + k0 = 0 (k0 < 0 < k2: exactly one).
double positive_root(double k2, double k1, double k0) { return (-k1 + std::sqrt(k1 * k1 - 4.0 * k2 * k0)) / (2.0 * k2); }

TEST(ActuationSchenato, ScalarCostBoundsAreTheClosedForms) {
  // Sinopoli 2004's scalar plant, with an input b = 1 and weights W = U = 1.
  const double a = -1.25, b = 1.0, c = 1.0, q = 1.0, r = 2.5, w = 1.0, u = 1.0;
  struct Point {
    double gamma, nu;
  };
  for (const Point p : {Point{0.6, 0.6}, Point{0.8, 0.5}, Point{0.5, 0.9}, Point{0.95, 0.95}, Point{1.0, 0.7}}) {
    // S = a²S + w − ν a²b²S²/(b²S + u)  ⇔  b²(1 − a² + νa²) S² + (u(1 − a²) − w b²) S − w u = 0.
    const double S = positive_root(b * b * (1.0 - a * a + p.nu * a * a), u * (1.0 - a * a) - w * b * b, -w * u);
    // P̄ = a²P̄ + q − γ a²c²P̄²/(c²P̄ + r): the same equation for the dual system.
    const double Pbar = positive_root(c * c * (1.0 - a * a + p.gamma * a * a), r * (1.0 - a * a) - q * c * c, -q * r);
    const double Plow = q / (1.0 - (1.0 - p.gamma) * a * a);
    const double weight = a * a * S + w - S;  // = ν a²b²S²/(b²S + u) at the optimum
    ASSERT_NEAR(weight, p.nu * a * a * b * b * S * S / (b * b * S + u), 1e-9 * S);
    const double J_max = S * q + weight * (Pbar - p.gamma * c * c * Pbar * Pbar / (c * c * Pbar + r));
    const double J_min = S * q + weight * (1.0 - p.gamma) * Plow;

    const auto lib = library_bounds(scalar(a), scalar(b), scalar(c), scalar(q), scalar(r), scalar(w), scalar(u),
                                    p.gamma, p.nu);
    ASSERT_TRUE(lib.has_value()) << "γ̄ " << p.gamma << ", ν̄ " << p.nu;
    EXPECT_NEAR(lib->model.constant, S * q, 1e-8 * S * q) << "tr(SQ) at ν̄ " << p.nu;
    EXPECT_NEAR(lib->model.weight(0, 0), weight, 1e-8 * weight) << "A'SA + W − S at ν̄ " << p.nu;
    EXPECT_NEAR(lib->upper, J_max, 1e-7 * J_max) << "J_max at γ̄ " << p.gamma << ", ν̄ " << p.nu;
    if (p.gamma < 1.0) {
      EXPECT_NEAR(lib->lower, J_min, 1e-8 * J_min) << "J_min at γ̄ " << p.gamma << ", ν̄ " << p.nu;
    } else {
      // Every sample arrives: P_{k|k} is the standard filter's, the cost exact (J_max); the
      // paper's J_min, tr(SQ) at γ̄ = 1, is a looser lower bound the library improves on.
      EXPECT_NEAR(lib->lower, J_max, 1e-7 * J_max);
      EXPECT_LT(J_min, lib->lower);
    }
    EXPECT_LE(lib->lower, lib->upper);
    if (p.gamma == 0.6) {
      EXPECT_NEAR(Pbar, 7.3266, 1e-4);  // Sinopoli 2004's V̄ (docs/validation.md)
    }
  }
}

TEST(ActuationSchenato, ScalarStabilityRegionIsTheProductOfTheCriticalRates) {
  // B and C invertible: γ_min = γ_max = ν_min = ν_max = 1 − 1/a² = 0.36, and the region where
  // the cost is finite is (0.36, 1] × (0.36, 1].
  const double a = -1.25;
  const Matrix one = scalar(1.0);
  auto finite = [&](double gamma, double nu) {
    return library_bounds(scalar(a), one, one, one, scalar(2.5), one, one, gamma, nu).has_value();
  };
  const double critical = 1.0 - 1.0 / (a * a);
  EXPECT_NEAR(critical, 0.36, 1e-15);
  EXPECT_NEAR(theory::optimal_control_rates(scalar(a), one, one, one, /*use_lmi=*/false).lower, critical, 1e-12);
  for (double other : {0.4, 0.7, 1.0}) {
    EXPECT_TRUE(finite(critical + 0.02, other)) << "γ̄ just above, ν̄ " << other;
    EXPECT_FALSE(finite(critical - 0.02, other)) << "γ̄ just below, ν̄ " << other;
    EXPECT_TRUE(finite(other, critical + 0.02)) << "ν̄ just above, γ̄ " << other;
    EXPECT_FALSE(finite(other, critical - 0.02)) << "ν̄ just below, γ̄ " << other;
  }
}

// A Monte Carlo of the whole TCP-like loop, from its equations (fixed-size Eigen: a few million
// steps): x_{k+1} = A x_k + ν_k B u_k + w_k, y_k = C x_k + v_k received when γ_k = 1; the
// estimator's filter with intermittent observations (Sinopoli 2004 eqs. 14-16, the acknowledged
// input in the prediction); u_k = −L x̂_{k|k}. Its long-run mean cost x'W x + ν u'U u, and the
// mean of tr((A'SA + W − S) P_{k|k}) along the same path, each with a batch-means standard error.
struct LoopEstimate {
  double cost = 0.0;           // long-run mean of x'Wx + ν u'Uu
  double cost_se = 0.0;
  double cost_minus_pi = 0.0;  // mean of (x'Wx + ν u'Uu − tr(weight P_{k|k})): tr(SQ) in theory
  double cost_minus_pi_se = 0.0;
  Eigen::Matrix2d mean_filtered = Eigen::Matrix2d::Zero();  // mean P_{k|k}
};
LoopEstimate simulate_tcp_loop(const Eigen::Matrix2d& A, const Eigen::Vector2d& B, const Eigen::RowVector2d& C,
                               const Eigen::Matrix2d& Q, double R, const Eigen::Matrix2d& W, double U,
                               const Eigen::RowVector2d& L, const Eigen::Matrix2d& weight, double gamma, double nu,
                               int batches, int batch_steps, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::bernoulli_distribution observation_arrives(gamma), input_arrives(nu);
  const Eigen::Matrix2d Q_root = Q.llt().matrixL();
  const double R_root = std::sqrt(R);
  Eigen::Vector2d x = Eigen::Vector2d::Zero(), x_hat = Eigen::Vector2d::Zero();
  Eigen::Matrix2d P = Q;  // P_{0|−1}
  std::vector<double> cost_batches, diff_batches;
  LoopEstimate out;
  const int burn_in = 5000;
  double cost_sum = 0.0, diff_sum = 0.0;
  long long counted = 0;
  for (long long k = 0; k < burn_in + static_cast<long long>(batches) * batch_steps; ++k) {
    // Measurement update (x_hat, P are the prediction x̂_{k|k−1}, P_{k|k−1}).
    if (observation_arrives(rng)) {
      const double y = (C * x).value() + R_root * normal(rng);
      const Eigen::Vector2d K = P * C.transpose() / ((C * P * C.transpose()).value() + R);
      x_hat += K * (y - C * x_hat);
      P -= K * C * P;
      P = 0.5 * (P + P.transpose());
    }
    const double u = -(L * x_hat).value();
    const bool arrived = input_arrives(rng);
    if (k >= burn_in) {
      const double cost = x.dot(W * x) + (arrived ? u * U * u : 0.0);
      cost_sum += cost;
      diff_sum += cost - (weight * P).trace();
      out.mean_filtered += P;
      if (++counted % batch_steps == 0) {
        cost_batches.push_back(cost_sum / batch_steps);
        diff_batches.push_back(diff_sum / batch_steps);
        cost_sum = diff_sum = 0.0;
      }
    }
    const Eigen::Vector2d applied = arrived ? Eigen::Vector2d(B * u) : Eigen::Vector2d::Zero();
    x = A * x + applied + Q_root * Eigen::Vector2d(normal(rng), normal(rng));
    x_hat = A * x_hat + applied;  // acknowledged: the estimator knows what was applied
    P = A * P * A.transpose() + Q;
  }
  auto mean_and_se = [](const std::vector<double>& v) {
    double m = 0.0, m2 = 0.0;
    for (double e : v) m += e;
    m /= static_cast<double>(v.size());
    for (double e : v) m2 += (e - m) * (e - m);
    const double n = static_cast<double>(v.size());
    return std::pair{m, std::sqrt(m2 / (n - 1.0) / n)};
  };
  std::tie(out.cost, out.cost_se) = mean_and_se(cost_batches);
  std::tie(out.cost_minus_pi, out.cost_minus_pi_se) = mean_and_se(diff_batches);
  out.mean_filtered /= static_cast<double>(counted);
  return out;
}

TEST(ActuationSchenato, LqgCostOfTheWholeLoopLiesBetweenTheBounds) {
  // A 2-d plant with one unstable mode (α = 1.2: γ_min = ν_min = 1 − 1/1.44 ≈ 0.31), a scalar
  // input and one scalar sensor, both links lossy.
  Eigen::Matrix2d A;
  A << 1.2, 1.0, 0.0, 0.9;
  const Eigen::Vector2d B(0.0, 1.0);
  const Eigen::RowVector2d C(1.0, 0.0);
  const Eigen::Matrix2d Q = 0.5 * Eigen::Matrix2d::Identity();
  const double R = 1.0, U = 1.0;
  const Eigen::Matrix2d W = Eigen::Matrix2d::Identity();
  struct Point {
    double gamma, nu;
    std::uint64_t seed;
  };
  // Rates where x and P_{k|k−1} have finite fourth moments ((1 − rate) α⁴ < 1), so the batch
  // means' standard error is itself reliable.
  for (const Point p : {Point{0.8, 0.8, 31}, Point{0.9, 0.7, 32}}) {
    const auto lib = library_bounds(A, B, C, Q, Matrix::Constant(1, 1, R), W, Matrix::Constant(1, 1, U), p.gamma,
                                    p.nu);
    ASSERT_TRUE(lib.has_value());
    const Eigen::RowVector2d L = lib->gain;
    const Eigen::Matrix2d weight = lib->model.weight;
    const LoopEstimate mc = simulate_tcp_loop(A, B, C, Q, R, W, U, L, weight, p.gamma, p.nu, 200, 5000, p.seed);
    const std::string at = "γ̄ " + std::to_string(p.gamma) + ", ν̄ " + std::to_string(p.nu) + ": J_min " +
                           std::to_string(lib->lower) + ", J_max " + std::to_string(lib->upper) + ", Monte Carlo " +
                           std::to_string(mc.cost) + " ± " + std::to_string(mc.cost_se);
    RecordProperty("gamma_" + std::to_string(p.gamma) + "_nu_" + std::to_string(p.nu), at);
    // The check has teeth: the standard error is small against the gap it must fall in.
    EXPECT_LT(mc.cost_se, 0.01 * mc.cost) << at;
    EXPECT_GT(lib->upper - lib->lower, 10.0 * mc.cost_se) << at;
    // The bounds, within 4 standard errors.
    EXPECT_GE(mc.cost, lib->lower - 4.0 * mc.cost_se) << at;
    EXPECT_LE(mc.cost, lib->upper + 4.0 * mc.cost_se) << at;
    // Sharper: along the path, cost − tr((A'SA + W − S) P_{k|k}) averages tr(SQ) exactly.
    EXPECT_NEAR(mc.cost_minus_pi, lib->model.constant, 4.0 * mc.cost_minus_pi_se)
        << at << "; tr(SQ) " << lib->model.constant << ", path " << mc.cost_minus_pi << " ± " << mc.cost_minus_pi_se;
    // And the mean P_{k|k} lies between the bounds on Π (trace, 1 % for its own noise).
    EXPECT_GE(mc.mean_filtered.trace(), 0.99 * lib->pi.lower.trace()) << at;
    EXPECT_LE(mc.mean_filtered.trace(), 1.01 * lib->pi.upper.trace()) << at;
  }
}

}  // namespace
