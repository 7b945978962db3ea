// The actuation link's theory (core/include/netkf/theory/actuation.hpp) against independent
// expectations: the scalar closed forms of Schenato et al. 2007 (zeroing actuator: mean-square
// stable iff ν̄(a − bℓ)² + (1 − ν̄)a² < 1; the optimal controller's critical rate 1 − 1/a²; the
// scalar control Riccati equation solved as a quadratic), and Monte Carlo simulations of the
// jump system itself (hold, Gilbert-Elliott, the long-run cost), written here from the loop's
// equations, not from the operator.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "netkf/model/scenario.hpp"
#include "netkf/theory/actuation.hpp"
#include "netkf/theory/lqr.hpp"

namespace {

using netkf::BernoulliLink;
using netkf::GilbertElliottLink;
using netkf::LinkModel;
using netkf::Matrix;
using netkf::OnLoss;
using netkf::Vector;
namespace theory = netkf::theory;

Matrix scalar(double v) { return Matrix::Constant(1, 1, v); }

TEST(ActuationTheory, ZeroOnLossRadiusIsTheScalarClosedForm) {
  const double a = 1.3, b = 1.0, l = 1.0;  // a − bℓ = 0.3
  const auto modes = theory::actuation_modes(scalar(a), scalar(b), scalar(l), OnLoss::zero);
  for (double nu : {0.0, 0.2, 0.5, 0.7, 0.9, 1.0}) {
    const double closed_form = nu * (a - b * l) * (a - b * l) + (1.0 - nu) * a * a;
    EXPECT_NEAR(theory::mss_radius(modes, BernoulliLink{1.0 - nu}), closed_form, 1e-12) << "nu " << nu;
  }
  // ν_c: the closed form equal to 1.
  const double critical = (a * a - 1.0) / (a * a - (a - b * l) * (a - b * l));
  const auto found = theory::actuation_critical_rate(modes, BernoulliLink{0.5});
  ASSERT_TRUE(found.rate.has_value()) << found.reason;
  EXPECT_NEAR(*found.rate, critical, 1e-8);
}

TEST(ActuationTheory, AStablePlantWithAStableLoopIsStableAtEveryRate) {
  // Zero on loss, a² < 1 and (a − bℓ)² < 1: the closed form is < 1 for every ν̄, ν_c = 0.
  const auto modes = theory::actuation_modes(scalar(0.9), scalar(1.0), scalar(0.5), OnLoss::zero);
  const auto found = theory::actuation_critical_rate(modes, BernoulliLink{0.5});
  ASSERT_TRUE(found.rate.has_value()) << found.reason;
  EXPECT_EQ(*found.rate, 0.0);
}

// E[x_N^2] of the scalar loop x' = a x + b u^a, u^a = −ℓ x when the input arrives, else 0 (zero)
// or the previous u^a (hold), from x_0 = 1 and u^a_{-1} = 0; arrivals from `arrive(rng)`. With
// its standard error: x_N^2 is heavy-tailed (a few runs that lost many inputs dominate it).
struct Estimate {
  double mean = 0.0;
  double standard_error = 0.0;
};
template <class Arrivals>
Estimate monte_carlo_second_moment(double a, double b, double l, OnLoss on_loss, int steps, int runs,
                                 Arrivals make_arrivals, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  double sum = 0.0, sum_sq = 0.0;
  for (int run = 0; run < runs; ++run) {
    auto arrives = make_arrivals(rng);
    double x = 1.0, held = 0.0;
    for (int k = 0; k < steps; ++k) {
      const double u = arrives(rng) ? -l * x : (on_loss == OnLoss::hold ? held : 0.0);
      held = u;
      x = a * x + b * u;
    }
    sum += x * x;
    sum_sq += x * x * x * x;
  }
  const double mean = sum / runs;
  return {mean, std::sqrt((sum_sq / runs - mean * mean) / runs)};
}

// The same from the second-moment operator: Y_i = E[z z' 1{chain in i}], z = x (zero) or [x; u^a_{-1}] (hold).
double operator_second_moment(const theory::ActuationModes& modes, const LinkModel& link,
                              const std::vector<double>& initial_state_probability, int steps) {
  const Matrix op = theory::second_moment_operator(modes, link);
  const Eigen::Index N = modes.delivered.rows();
  Vector y = Vector::Zero(op.rows());
  for (std::size_t i = 0; i < initial_state_probability.size(); ++i) {
    Matrix Y0 = Matrix::Zero(N, N);
    Y0(0, 0) = initial_state_probability[i];
    y.segment(static_cast<Eigen::Index>(i) * N * N, N * N) = Eigen::Map<const Vector>(Y0.data(), N * N);
  }
  for (int k = 0; k < steps; ++k) y = op * y;
  double x2 = 0.0;
  for (std::size_t i = 0; i < initial_state_probability.size(); ++i) x2 += y(static_cast<Eigen::Index>(i) * N * N);
  return x2;
}

TEST(ActuationTheory, HoldSecondMomentMatchesMonteCarloOfTheLoop) {
  const double a = 1.2, b = 1.0, l = 0.9, nu = 0.6;
  const int steps = 12, runs = 400000;
  const auto modes = theory::actuation_modes(scalar(a), scalar(b), scalar(l), OnLoss::hold);
  const double theory = operator_second_moment(modes, BernoulliLink{1.0 - nu}, {1.0}, steps);
  const Estimate mc = monte_carlo_second_moment(
      a, b, l, OnLoss::hold, steps, runs,
      [&](std::mt19937_64&) {
        return [&](std::mt19937_64& r) { return std::bernoulli_distribution(nu)(r); };
      },
      11);
  EXPECT_NEAR(mc.mean, theory, 4.0 * mc.standard_error)
      << "operator " << theory << ", Monte Carlo " << mc.mean << " ± " << mc.standard_error;
  EXPECT_LT(mc.standard_error, 0.05 * theory);  // the check has teeth
}

TEST(ActuationTheory, GilbertElliottSecondMomentMatchesMonteCarloOfTheLoop) {
  // The chain moves, then the input's fate is drawn in the state entered (netkf/links/loss_model.hpp).
  const GilbertElliottLink ge{.p = 0.2, .r = 0.5, .loss_good = 0.05, .loss_bad = 0.6};
  const double a = 1.1, b = 1.0, l = 0.8;
  const int steps = 8, runs = 400000;
  const double pi_bad = ge.p / (ge.p + ge.r);
  for (OnLoss on_loss : {OnLoss::zero, OnLoss::hold}) {
    const auto modes = theory::actuation_modes(scalar(a), scalar(b), scalar(l), on_loss);
    const double theory = operator_second_moment(modes, ge, {1.0 - pi_bad, pi_bad}, steps);
    const Estimate mc = monte_carlo_second_moment(
        a, b, l, on_loss, steps, runs,
        [&](std::mt19937_64& r) {
          bool bad = std::bernoulli_distribution(pi_bad)(r);  // stationary start
          return [&ge, bad](std::mt19937_64& rr) mutable {
            bad = bad ? !std::bernoulli_distribution(ge.r)(rr) : std::bernoulli_distribution(ge.p)(rr);
            return !std::bernoulli_distribution(bad ? ge.loss_bad : ge.loss_good)(rr);
          };
        },
        on_loss == OnLoss::zero ? 12 : 13);
    EXPECT_NEAR(mc.mean, theory, 4.0 * mc.standard_error)
        << netkf::to_string(on_loss) << ": operator " << theory << ", Monte Carlo " << mc.mean << " ± "
        << mc.standard_error;
    EXPECT_LT(mc.standard_error, 0.1 * theory);
  }
}

TEST(ActuationTheory, OptimalControllerCriticalRateIsOneMinusOneOverASquared) {
  // Schenato et al. 2007 (and the TCP-case paper): for B square and invertible the optimal
  // controller's critical rate is ν_c = 1 − 1/α², where both bounds meet.
  const double a = 1.25;
  const auto rates = theory::optimal_control_rates(scalar(a), scalar(1.0), scalar(1.0), scalar(0.5),
                                                     /*use_lmi=*/false);
  EXPECT_NEAR(rates.lower, 1.0 - 1.0 / (a * a), 1e-12);
  ASSERT_TRUE(rates.upper_iteration.has_value());
  EXPECT_NEAR(*rates.upper_iteration, 1.0 - 1.0 / (a * a), 1e-4);
}

TEST(ActuationTheory, LossyControlRiccatiIsTheScalarQuadratic) {
  // S = a²S + q − ν a²b²S²/(b²S + r)  ⇔  b²(1 − a² + νa²) S² + (r(1 − a²) − q b²) S − q r = 0.
  const double a = 1.25, b = 0.8, q = 2.0, r = 0.5;
  for (double nu : {0.5, 0.7, 0.95, 1.0}) {
    const double A2 = b * b * (1.0 - a * a + nu * a * a), B1 = r * (1.0 - a * a) - q * b * b, C0 = -q * r;
    const double S = (-B1 + std::sqrt(B1 * B1 - 4.0 * A2 * C0)) / (2.0 * A2);
    const auto solved = netkf::theory::solve_lossy_dare(scalar(a), scalar(b), scalar(q), scalar(r), nu);
    ASSERT_TRUE(solved.has_value()) << "nu " << nu;
    EXPECT_NEAR((*solved)(0, 0), S, 1e-8 * S) << "nu " << nu;
    const Matrix L = netkf::theory::lossy_lqr_gain(scalar(a), scalar(b), scalar(q), scalar(r), nu);
    EXPECT_NEAR(L(0, 0), b * S * a / (b * b * S + r), 1e-8) << "nu " << nu;
  }
  // Below ν_c = 1 − 1/a² = 0.36 there is no solution.
  EXPECT_FALSE(netkf::theory::solve_lossy_dare(scalar(a), scalar(b), scalar(q), scalar(r), 0.3).has_value());
}

TEST(ActuationTheory, LongRunCostMatchesMonteCarloOfTheLoopWithItsState) {
  // The estimate exact (Π = 0): J = tr(S_x Q), against the average of x'Qx x + u'Ru u (u as
  // applied) over a long run of the noisy scalar loop.
  const double a = 1.2, b = 1.0, l = 0.8, q = 0.3, qx = 1.0, ru = 0.5, nu = 0.75;
  for (OnLoss on_loss : {OnLoss::zero, OnLoss::hold}) {
    const auto modes = theory::actuation_modes(scalar(a), scalar(b), scalar(l), on_loss);
    const auto model =
        theory::actuation_cost_model(scalar(a), scalar(q), modes, BernoulliLink{1.0 - nu}, scalar(qx), scalar(ru));
    ASSERT_TRUE(model.has_value());
    std::mt19937_64 rng(on_loss == OnLoss::zero ? 21 : 22);
    std::normal_distribution<double> noise(0.0, std::sqrt(q));
    std::bernoulli_distribution arrives(nu);
    double x = 0.0, held = 0.0, sum = 0.0;
    const int burn_in = 1000, steps = 4000000;
    for (int k = 0; k < burn_in + steps; ++k) {
      const double u = arrives(rng) ? -l * x : (on_loss == OnLoss::hold ? held : 0.0);
      held = u;
      if (k >= burn_in) sum += qx * x * x + ru * u * u;
      x = a * x + b * u + noise(rng);
    }
    EXPECT_NEAR(sum / steps / model->constant, 1.0, 0.03)
        << netkf::to_string(on_loss) << ": theory " << model->constant << ", Monte Carlo " << sum / steps;
  }
}

TEST(ActuationTheory, RegionOfTheScalarLoopIsTheProductOfTheClosedForms) {
  // `analyze --region` for the scalar loop x' = a x + b u + w, y = x + v, u = −ℓ x̂ zeroed on a
  // loss, acknowledged: the estimator is stable iff γ̄ > 1 − 1/a² (Sinopoli 2004, C invertible),
  // the control side iff ν̄ > ν_c = (a² − 1)/(a² − (a − bℓ)²) (the zeroing closed form above), and
  // by separation the region is their product.
  const double a = 1.25, b = 1.0, l = 0.9;
  const std::string text =
      "period_ms: 10\n"
      "plant:\n"
      "  A: [[1.25]]\n  Q: [[1.0]]\n  B: [[1.0]]\n"
      "  control: { gain: [[0.9]], link: { model: bernoulli, loss: 0.2 }, on_loss: zero, acknowledged: true }\n"
      "sensors: [ { id: 4, C: [[1.0]], R: [[2.5]], link: { model: bernoulli, loss: 0.3 } } ]\n";
  const netkf::Scenario scenario = netkf::parse_scenario(text, "region.yaml");
  const double gamma_c = 1.0 - 1.0 / (a * a);
  const double nu_c = (a * a - 1.0) / (a * a - (a - b * l) * (a - b * l));
  const auto region = theory::actuation_region(scenario, 4, 11);
  EXPECT_EQ(region.sensor_id, 4);
  ASSERT_TRUE(region.gamma_lower && region.gamma_upper);
  EXPECT_NEAR(*region.gamma_lower, gamma_c, 1e-5);
  EXPECT_NEAR(*region.gamma_upper, gamma_c, 1e-5);
  ASSERT_EQ(region.points.size(), 11u);
  for (const auto& p : region.points) {
    if (p.gamma < gamma_c - 1e-9) {
      EXPECT_EQ(p.estimator, theory::Verdict::no) << p.gamma;
      EXPECT_EQ(p.nu_lower, 1.0) << p.gamma;  // no ν̄ makes the loop stable
      EXPECT_FALSE(p.nu_upper) << p.gamma;
    } else if (p.gamma > gamma_c + 1e-9) {
      EXPECT_EQ(p.estimator, theory::Verdict::yes) << p.gamma;
      EXPECT_NEAR(p.nu_lower, nu_c, 1e-8) << p.gamma;
      ASSERT_TRUE(p.nu_upper) << p.gamma;
      EXPECT_NEAR(*p.nu_upper, nu_c, 1e-8) << p.gamma;
    }
  }
}

}  // namespace
