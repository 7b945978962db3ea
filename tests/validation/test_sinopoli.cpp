// Sinopoli et al., "Kalman filtering with intermittent observations": the paper's numbers
// (Sec. IV, V) and independent closed forms. Expected values come from the paper or from
// docs/validation.md (computed independently), never from netkf.
#include <gtest/gtest.h>

#include <cmath>

#include "netkf/theory/critical_rate.hpp"
#include "lmi.hpp"  // theory/ private: the validation sees core/src/theory
#include "netkf/theory/operating_point.hpp"
#include "netkf/theory/report.hpp"
#include "netkf/theory/riccati.hpp"
#include "theory_systems.hpp"

namespace netkf::theory {
namespace {
using netkf::testing::mat;

TEST(Sinopoli, ScalarCriticalRateBothBoundsAre036) {
  // Sec. IV: A = -1.25, C invertible => lower = upper = 1 - 1/1.25² = 0.36.
  const auto report = analyze(netkf::testing::sinopoli_scalar(0.6));
  ASSERT_TRUE(report.critical_rate.has_value());
  EXPECT_NEAR(report.critical_rate->lower, 0.36, 1e-12);
  ASSERT_TRUE(report.critical_rate->upper.has_value());
  EXPECT_NEAR(*report.critical_rate->upper, 0.36, 2e-4);  // LMI via CSDP
  ASSERT_TRUE(report.critical_rate->upper_iteration.has_value());
  EXPECT_NEAR(*report.critical_rate->upper_iteration, 0.36, 2e-4);
  ASSERT_TRUE(report.critical_rate->exact.has_value());
  EXPECT_NEAR(*report.critical_rate->exact, 0.36, 1e-5);
  EXPECT_EQ(report.stable, Verdict::yes);
}

TEST(Sinopoli, ScalarBoundsAtRate06) {
  // S̄ solves S = 0.4·1.5625 S + 1 => S = 1/0.375; V̄ = 7.3266 (docs/validation.md).
  const auto report = analyze(netkf::testing::sinopoli_scalar(0.6));
  ASSERT_TRUE(report.lower_trace && report.upper_trace);
  EXPECT_NEAR(*report.lower_trace, 1.0 / 0.375, 1e-9);
  EXPECT_NEAR(*report.upper_trace, 7.3266, 1e-4);
}

TEST(Sinopoli, ScalarFixedPointSolvesTheQuadratic) {
  // Independent closed form: V = g_λ(V) for scalars is the quadratic
  // λ C² V² + (R(1 − (1−λ)A²) − C²(A²... )) ... solved directly here.
  const double a = -1.25, q = 1.0, r = 2.5, l = 0.6;
  // V = a²V + q − l a² V²/(V + r)  <=>  (1 − a²)V² + (r(1 − a²) − q + l a² r... ) expand:
  // (V − a²V − q)(V + r) + l a² V² = 0  => (1 − a² + l a²) V² + (r − a² r − q) V − q r = 0.
  const double A2 = a * a;
  const double qa = 1.0 - A2 + l * A2, qb = r - A2 * r - q, qc = -q * r;
  const double expected = (-qb + std::sqrt(qb * qb - 4 * qa * qc)) / (2 * qa);
  const auto patterns = independent_arrival_patterns(netkf::testing::sinopoli_scalar(l).sensors, std::vector<double>{l});
  const auto V = expected_covariance_upper_bound(mat({{a}}), mat({{q}}), patterns);
  ASSERT_EQ(V.status, BoundStatus::bounded);
  EXPECT_NEAR(V.V(0, 0), expected, 1e-9);
}

// Sec. IV: λ_c = 1 − 1/1.25² = 0.36. `netkf analyze` and both rows of the live status (the
// configured links, the observed rates) give the paper's verdict on either side of it.
TEST(Sinopoli, ScalarVerdictOnEitherSideOfTheCriticalRateFromAnalyzeAndTheLiveStatus) {
  for (double rate : {0.2, 0.35, 0.37, 0.6, 0.95}) {
    SCOPED_TRACE(rate);
    const Verdict paper = rate > 0.36 ? Verdict::yes : Verdict::no;
    const auto s = netkf::testing::sinopoli_scalar(rate);
    EXPECT_EQ(analyze(s).stable, paper);
    EXPECT_EQ(assess_configured_links(s).stable, paper);
    EXPECT_EQ(assess_operating_point(s, {rate}).stable, paper);
  }
}

TEST(Sinopoli, BelowCriticalRateIsUnboundedNotHuge) {
  const auto report = analyze(netkf::testing::sinopoli_scalar(0.3));
  EXPECT_EQ(report.stable, Verdict::no);
  EXPECT_FALSE(report.lower_trace.has_value());
  EXPECT_FALSE(report.upper_trace.has_value());
}

TEST(Sinopoli, MimoSingleUnstableEigenvalueCriticalRate036) {
  const auto report = analyze(netkf::testing::sinopoli_mimo(0.8));
  ASSERT_TRUE(report.critical_rate.has_value());
  EXPECT_NEAR(report.critical_rate->lower, 0.36, 1e-12);
  ASSERT_TRUE(report.critical_rate->upper && report.critical_rate->upper_iteration);
  EXPECT_NEAR(*report.critical_rate->upper, 0.36, 5e-4);
  EXPECT_NEAR(*report.critical_rate->upper_iteration, 0.36, 5e-4);
  EXPECT_NEAR(*report.critical_rate->exact, 0.36, 1e-5);
}

TEST(Sinopoli, MimoAtFullArrivalIsTheStandardRiccatiTrace) {
  // docs/validation.md: at λ = 1, Tr V̄ = trace of the steady-state Riccati solution = 5573.87.
  const auto report = analyze(netkf::testing::sinopoli_mimo(1.0));
  ASSERT_TRUE(report.upper_trace.has_value());
  EXPECT_NEAR(*report.upper_trace, 5573.87, 0.01);
}

TEST(Sinopoli, GeneralExampleUpperBoundAboveLower) {
  // Fig. 4: lower 0.36, the LMI upper bound strictly larger; the LMI and the g-iteration agree.
  const auto report = analyze(netkf::testing::sinopoli_general(0.9));
  ASSERT_TRUE(report.critical_rate.has_value());
  EXPECT_NEAR(report.critical_rate->lower, 0.36, 1e-12);
  ASSERT_TRUE(report.critical_rate->upper && report.critical_rate->upper_iteration);
  EXPECT_GT(*report.critical_rate->upper, 0.36 + 0.01);
  EXPECT_NEAR(*report.critical_rate->upper, *report.critical_rate->upper_iteration, 1e-3);
}

TEST(Sinopoli, LmiFeasibilityFlipsAtTheCriticalRate) {
  const auto sensors = netkf::testing::sinopoli_scalar(0.5).sensors;
  const Matrix A = mat({{-1.25}});
  auto at = [&](double l) { return solve_stability_lmi(A, independent_arrival_patterns(sensors, std::vector<double>{l})); };
  EXPECT_TRUE(at(0.40).feasible());
  EXPECT_FALSE(at(0.32).feasible());
}

TEST(Sinopoli, SectionVStaticGainNumbersNeedAEqualsMinus125) {
  // Sec. V quotes P̄ = 7.32, K_λ = −0.93, K_SS = −0.70 at λ = 0.6 and says A = −1.5; the numbers
  // are reproduced by A = −1.25 (C = 1, Q = 1, R = 2.5) and not by A = −1.5.
  const Matrix C = mat({{1.0}}), Q = mat({{1.0}}), R = mat({{2.5}});
  const auto sensors = netkf::testing::sinopoli_scalar(0.6).sensors;
  auto check = [&](double a, double expected_P, double expected_K, double expected_Kss) {
    const Matrix A = mat({{a}});
    const auto V = expected_covariance_upper_bound(A, Q, independent_arrival_patterns(sensors, std::vector<double>{0.6}));
    const auto Vss = expected_covariance_upper_bound(A, Q, independent_arrival_patterns(sensors, std::vector<double>{1.0}));
    EXPECT_NEAR(V.V(0, 0), expected_P, 0.01) << "A = " << a;
    EXPECT_NEAR(predictor_gain(A, C, R, V.V)(0, 0), expected_K, 0.005) << "A = " << a;
    EXPECT_NEAR(predictor_gain(A, C, R, Vss.V)(0, 0), expected_Kss, 0.005) << "A = " << a;
  };
  check(-1.25, 7.32, -0.93, -0.70);   // the paper's numbers
  check(-1.5, 41.85, -1.415, -0.976);  // what A = −1.5 would give (docs/validation.md)
}

TEST(Sinopoli, StaticGainPredictorWithKLambdaAchievesVbar) {
  // Eq. (28) corrected (numerator Q + λK²R): the static K_λ filter's steady state is V̄.
  const Matrix A = mat({{-1.25}}), C = mat({{1.0}}), Q = mat({{1.0}}), R = mat({{2.5}});
  const double l = 0.6;
  const auto sensors = netkf::testing::sinopoli_scalar(l).sensors;
  const auto V = expected_covariance_upper_bound(A, Q, independent_arrival_patterns(sensors, std::vector<double>{l}));
  const Matrix K = predictor_gain(A, C, R, V.V);
  const auto P = static_gain_covariance(A, C, Q, R, l, K);
  ASSERT_TRUE(P.has_value());
  const double k = K(0, 0), a = -1.25;
  const double closed = (1.0 + l * k * k * 2.5) / (1.0 - (1 - l) * a * a - l * (a - k) * (a - k));
  EXPECT_NEAR((*P)(0, 0), closed, 1e-10);
  EXPECT_NEAR((*P)(0, 0), 7.3266, 1e-4);
}

TEST(Sinopoli, StaticGainStabilityThresholds) {
  // Eq. (27) read as λ > λ_s = (A² − 1)/(A² − (A − KC)²): 0.4461 for K_SS, 0.3849 for K_λ, 0.36 for A/C.
  const Matrix A = mat({{-1.25}}), C = mat({{1.0}}), Q = mat({{1.0}}), R = mat({{2.5}});
  auto threshold = [&](double k) {
    return infimum_stable_rate(
        [&](double l) { return static_gain_covariance(A, C, Q, R, l, mat({{k}})).has_value(); }, 0.0, 1.0, 1e-7);
  };
  EXPECT_NEAR(*threshold(-0.70079), 0.4461, 2e-4);
  EXPECT_NEAR(*threshold(-0.93199), 0.3849, 2e-4);
  EXPECT_NEAR(*threshold(-1.25), 0.36, 1e-5);
}

}  // namespace
}  // namespace netkf::theory
