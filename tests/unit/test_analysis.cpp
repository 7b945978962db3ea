// Analysis building blocks: maps, bounds, patterns, the operating-point assessment the live
// system calls, and bad input. Expected values are closed forms.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <vector>
#include <cmath>
#include <limits>

#include "netkf/analysis/operating_point.hpp"
#include "netkf/analysis/report.hpp"
#include "netkf/analysis/riccati.hpp"
#include "../validation/theory_systems.hpp"

namespace netkf::analysis {
namespace {
using netkf::testing::mat;

TEST(Analysis, PatternsCoverAllSubsetsAndSumToOne) {
  const auto s = netkf::testing::liu_goldsmith_fig5(0.3, 0.6);
  const std::vector<double> rates{0.3, 0.6};
  const auto patterns = independent_arrival_patterns(s.sensors, rates);
  ASSERT_EQ(patterns.size(), 4u);
  double total = 0.0;
  for (const auto& p : patterns) total += p.probability;
  EXPECT_NEAR(total, 1.0, 1e-15);
  EXPECT_NEAR(all_lost_probability(rates), 0.7 * 0.4, 1e-15);
  EXPECT_THROW(independent_arrival_patterns(s.sensors, std::vector<double>{0.3}), std::invalid_argument);
  EXPECT_THROW(independent_arrival_patterns(s.sensors, std::vector<double>{0.3, 1.5}), std::invalid_argument);
}

TEST(Analysis, ScalarLyapunovClosedForm) {
  // S = q a² S + Q  =>  S = Q / (1 − q a²)
  const auto S = lyapunov_lower_bound(mat({{-1.25}}), mat({{1.0}}), 0.5);
  ASSERT_TRUE(S.has_value());
  EXPECT_NEAR((*S)(0, 0), 1.0 / (1.0 - 0.5 * 1.5625), 1e-12);
  EXPECT_FALSE(lyapunov_lower_bound(mat({{-1.25}}), mat({{1.0}}), 0.7).has_value());
}

TEST(Analysis, UpperBoundAtFullArrivalSolvesTheScalarRiccatiEquation) {
  // λ = 1: V = a²V + q − a²V²/(V + r)  =>  V² + (r − a² r − q)V − q r = 0.
  const double a = 1.3, q = 0.5, r = 2.0;
  const double b = r - a * a * r - q;
  const double expected = (-b + std::sqrt(b * b + 4 * q * r)) / 2;
  const std::vector<SensorSpec> sensors{netkf::testing::sensor(1, mat({{1.0}}), mat({{r}}))};
  const auto V = expected_covariance_upper_bound(mat({{a}}), mat({{q}}),
                                                 independent_arrival_patterns(sensors, std::vector<double>{1.0}));
  ASSERT_EQ(V.status, BoundStatus::bounded);
  EXPECT_NEAR(V.V(0, 0), expected, 1e-10);
}

TEST(Analysis, OperatingPointIsFastAndDecides) {
  const auto s = netkf::testing::sinopoli_scalar(0.6);
  const auto above = assess_operating_point(s, {0.6});
  EXPECT_EQ(above.stable, Verdict::yes);
  ASSERT_TRUE(above.upper_trace.has_value());
  EXPECT_NEAR(*above.upper_trace, 7.3266, 1e-4);
  const auto below = assess_operating_point(s, {0.3});
  EXPECT_EQ(below.stable, Verdict::no);
  EXPECT_FALSE(below.upper_trace.has_value());
  EXPECT_FALSE(below.reason.empty());
}

TEST(Analysis, OperatingPointBadInputIsUnknownNotACrash) {
  const auto s = netkf::testing::liu_goldsmith_fig5(0.5, 0.5);
  EXPECT_EQ(assess_operating_point(s, {0.5}).stable, Verdict::unknown);
  EXPECT_EQ(assess_operating_point(s, {0.5, std::numeric_limits<double>::quiet_NaN()}).stable, Verdict::unknown);
  // Out-of-range observed rates are clamped, not rejected.
  EXPECT_EQ(assess_operating_point(s, {1.2, 1.0}).stable, Verdict::yes);
}

TEST(Analysis, ConfiguredGilbertLinksUseTheMarkovCriterion) {
  auto s = netkf::testing::sinopoli_scalar(0.6);
  s.sensors[0].link = GilbertElliottLink{0.1, 0.3, 0.0, 1.0};  // α²(1 − r) = 1.09 > 1
  const auto a = assess_configured_links(s);
  EXPECT_EQ(a.stable, Verdict::no);
  ASSERT_TRUE(a.markov_criterion.has_value());
  EXPECT_NEAR(*a.markov_criterion, 1.5625 * 0.7, 1e-10);
}

// `analyze --region`'s progress bar is fed the region's grid points done.
TEST(Analysis, RegionReportsItsGridPointsAsProgress) {
  const auto s = netkf::testing::liu_goldsmith_case1(0.5, 0.5);
  AnalyzeOptions o;
  o.region = true;
  o.region_points = 4;
  o.use_lmi = false;
  std::vector<std::int64_t> done;
  o.progress = [&](std::int64_t d, std::int64_t total) {
    EXPECT_EQ(total, 4);
    done.push_back(d);
  };
  const auto report = analyze(s, o);
  ASSERT_EQ(report.region.size(), 4u);
  ASSERT_GE(done.size(), 2u);
  EXPECT_EQ(done.front(), 0);
  EXPECT_EQ(done.back(), 4);
  for (std::size_t i = 1; i < done.size(); ++i) EXPECT_GT(done[i], done[i - 1]);
}

}  // namespace
}  // namespace netkf::analysis
