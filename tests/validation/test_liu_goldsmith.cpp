// Liu & Goldsmith, "Kalman filtering with partial observation losses": the stability
// region bounds (Thm 3) and the paper's Sec. VI examples. Expected values are the
// paper's closed forms and numbers.
#include <gtest/gtest.h>

#include <cmath>

#include "netkf/theory/critical_rate.hpp"
#include "netkf/theory/operating_point.hpp"
#include "netkf/theory/report.hpp"
#include "netkf/theory/riccati.hpp"
#include "theory_systems.hpp"

namespace netkf::theory {
namespace {

TEST(LiuGoldsmith, Case1InvertibleSensorsBoundsCoincide) {
  // C1, C2 square invertible: λ2c = max(0, 1 − 1/(α²(1 − λ1))) for both bounds (Sec. VI-A).
  const auto s = netkf::testing::liu_goldsmith_case1(0.5, 0.5);
  RegionOptions options;
  options.points = 6;  // λ1 = 0, 0.2, ..., 1
  const auto region = stability_region(s.plant.A, s.plant.Q, s.sensors, options);
  ASSERT_EQ(region.size(), 6u);
  const double alpha2 = 1.25 * 1.25;
  for (const auto& p : region) {
    const double expected = std::max(0.0, 1.0 - 1.0 / (alpha2 * (1.0 - p.lambda1)));
    EXPECT_NEAR(p.lambda2_lower, expected, 1e-12) << "lambda1 = " << p.lambda1;
    ASSERT_TRUE(p.lambda2_upper.has_value()) << "lambda1 = " << p.lambda1;
    EXPECT_NEAR(*p.lambda2_upper, expected, 5e-4) << "lambda1 = " << p.lambda1;
    ASSERT_TRUE(p.lambda2_upper_iteration.has_value());
    EXPECT_NEAR(*p.lambda2_upper_iteration, expected, 5e-4) << "lambda1 = " << p.lambda1;
  }
}

TEST(LiuGoldsmith, DiagonalSystemRegionIsLambda1Above084Lambda2Above59) {
  // Sec. VI-B: A = diag(2.5, 1.5), C = I split: stable iff λ1 > 0.84 and λ2 > 5/9; the upper
  // bound equals this region, the lower bound is loose.
  const auto s = netkf::testing::liu_goldsmith_diagonal(0.9, 0.9);
  RegionOptions options;
  options.points = 11;
  const auto region = stability_region(s.plant.A, s.plant.Q, s.sensors, options);
  for (const auto& p : region) {
    if (p.lambda1 < 0.84) {
      EXPECT_FALSE(p.lambda2_upper.has_value()) << "lambda1 = " << p.lambda1 << ": no λ2 can stabilise";
      EXPECT_FALSE(p.lambda2_exact.has_value());
    } else {
      ASSERT_TRUE(p.lambda2_upper.has_value()) << "lambda1 = " << p.lambda1;
      EXPECT_NEAR(*p.lambda2_upper, 5.0 / 9.0, 5e-4) << "lambda1 = " << p.lambda1;
      ASSERT_TRUE(p.lambda2_exact.has_value());
      EXPECT_NEAR(*p.lambda2_exact, 5.0 / 9.0, 5e-4);
    }
    // The lower bound is the closed form with α = 2.5, well below the true curve.
    const double open = 6.25 * (1.0 - p.lambda1);
    EXPECT_NEAR(p.lambda2_lower, open <= 1 ? 0.0 : 1.0 - 1.0 / open, 1e-12);
  }
  EXPECT_EQ(analyze(netkf::testing::liu_goldsmith_diagonal(0.85, 0.6)).stable, Verdict::yes);
  EXPECT_EQ(analyze(netkf::testing::liu_goldsmith_diagonal(0.83, 0.9)).stable, Verdict::no);
  EXPECT_EQ(analyze(netkf::testing::liu_goldsmith_diagonal(0.9, 0.55)).stable, Verdict::no);
}

// Sec. VI-B again, from the live status: stable iff λ1 > 0.84 and λ2 > 5/9, for the links as
// configured and for the same rates observed.
TEST(LiuGoldsmith, DiagonalSystemVerdictsFromTheLiveStatus) {
  const struct {
    double l1, l2;
    Verdict paper;
  } cases[] = {{0.85, 0.6, Verdict::yes}, {0.83, 0.9, Verdict::no}, {0.9, 0.55, Verdict::no}, {0.95, 0.95, Verdict::yes}};
  for (const auto& c : cases) {
    SCOPED_TRACE(std::to_string(c.l1) + ", " + std::to_string(c.l2));
    const auto s = netkf::testing::liu_goldsmith_diagonal(c.l1, c.l2);
    EXPECT_EQ(assess_configured_links(s).stable, c.paper);
    EXPECT_EQ(assess_operating_point(s, {c.l1, c.l2}).stable, c.paper);
  }
}

TEST(LiuGoldsmith, Fig5UpperCurveAboveLowerCurve) {
  const auto s = netkf::testing::liu_goldsmith_fig5(0.5, 0.5);
  RegionOptions options;
  options.points = 6;
  const auto region = stability_region(s.plant.A, s.plant.Q, s.sensors, options);
  for (const auto& p : region) {
    ASSERT_TRUE(p.lambda2_upper.has_value()) << "(A, C2) observable: some λ2 ≤ 1 is stable";
    EXPECT_GE(*p.lambda2_upper, p.lambda2_lower - 1e-9);
    EXPECT_NEAR(*p.lambda2_upper, *p.lambda2_upper_iteration, 1e-3);
  }
  // Below λ1 = 1: the curves separate (undecided band), as in Fig. 5.
  EXPECT_GT(*region.front().lambda2_upper, region.front().lambda2_lower + 0.05);
}

TEST(LiuGoldsmith, Fig5ResourceAllocationExamples) {
  // λ1 + λ2 = 0.5: (0, 0.5) stable; (0.5, 0) unstable ((A, C1) not observable);
  // (0.25, 0.25) undecided by the bounds.
  {
    const auto r = analyze(netkf::testing::liu_goldsmith_fig5(0.0, 0.5));
    EXPECT_EQ(r.stable, Verdict::yes);
    EXPECT_TRUE(r.upper_trace.has_value()) << "the upper bound alone decides (0, 0.5)";
  }
  EXPECT_EQ(analyze(netkf::testing::liu_goldsmith_fig5(0.5, 0.0)).stable, Verdict::no);
  {
    const auto s = netkf::testing::liu_goldsmith_fig5(0.25, 0.25);
    const std::vector<double> rates{0.25, 0.25};
    const auto patterns = independent_arrival_patterns(s.sensors, rates);
    // Upper bound does not exist, lower bound does: the papers' bounds leave it undecided.
    EXPECT_NE(expected_covariance_upper_bound(s.plant.A, s.plant.Q, patterns).status, BoundStatus::bounded);
    EXPECT_TRUE(lyapunov_lower_bound(s.plant.A, s.plant.Q, 0.75 * 0.75).has_value());
  }
}

TEST(LiuGoldsmith, TwoSensorMapWithOneSensorAlwaysLostIsSinopoli) {
  // g_{λ1,0} must equal Sinopoli's g_λ1 for sensor 1 alone (eq. 12 vs eq. 17).
  const auto s = netkf::testing::liu_goldsmith_fig5(0.7, 0.0);
  const std::vector<double> rates{0.7, 0.0};
  const auto patterns = independent_arrival_patterns(s.sensors, rates);
  Matrix X(2, 2);
  X << 3.0, 1.0, 1.0, 2.0;
  const Matrix two = expected_riccati_map(s.plant.A, s.plant.Q, patterns, X);
  const Matrix one = modified_riccati_map(s.plant.A, s.sensors[0].C, s.plant.Q, s.sensors[0].R, 0.7, X);
  EXPECT_LT((two - one).norm(), 1e-12);
}

}  // namespace
}  // namespace netkf::theory
