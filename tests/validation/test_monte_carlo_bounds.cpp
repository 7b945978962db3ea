// Monte Carlo of the real filter against the papers' bounds: S̄ ≤ E[P_{k|k-1}] ≤ V̄
// (Sinopoli Thm 4; Liu-Goldsmith Thm 4), and the filter's consistency E||e||² = E[Tr P].
#include <gtest/gtest.h>

#include <cmath>

#include "netkf/sim/monte_carlo.hpp"
#include "netkf/theory/report.hpp"
#include "theory_systems.hpp"

namespace netkf {
namespace {

void expect_between_bounds(const Scenario& s, int runs, int steps) {
  theory::AnalyzeOptions options;
  options.use_lmi = false;
  const auto bounds = theory::analyze(s, options);
  ASSERT_TRUE(bounds.lower_trace && bounds.upper_trace);
  MonteCarloOptions o;
  o.runs = runs;
  o.steps = steps;
  const auto mc = run_monte_carlo(s, o);
  const double se = mc.trace_P_pred.se;
  EXPECT_GE(mc.trace_P_pred.mean, *bounds.lower_trace - 3.0 * se) << s.name;
  EXPECT_LE(mc.trace_P_pred.mean, *bounds.upper_trace + 3.0 * se) << s.name;
  // Consistency of the error simulation with the filter's own covariance: E||x − x̂||² = E Tr P.
  EXPECT_NEAR(mc.sq_error_pred.mean, mc.trace_P_pred.mean, 4.0 * std::hypot(mc.sq_error_pred.se, se)) << s.name;
  EXPECT_NEAR(mc.sq_error_filt.mean, mc.trace_P_filt.mean,
              4.0 * std::hypot(mc.sq_error_filt.se, mc.trace_P_filt.se)) << s.name;
  EXPECT_EQ(mc.diverged_fraction, 0.0);
}

TEST(MonteCarloBounds, ScalarSinopoliAtRate06) {
  auto s = netkf::testing::sinopoli_scalar(0.6);
  s.name = "sinopoli-scalar";
  expect_between_bounds(s, 4000, 300);
}

TEST(MonteCarloBounds, TwoSensorLiuGoldsmith) {
  auto s = netkf::testing::liu_goldsmith_fig5(0.5, 0.7);
  s.name = "liu-goldsmith-fig5";
  expect_between_bounds(s, 2000, 200);
}

TEST(MonteCarloBounds, ErrorsKeepPrecisionOverThousandsOfSteps) {
  // 3000 steps at α = 1.25: the plant would be ~1e290; the simulated errors stay O(1) and
  // consistent with Tr P (a state-based simulation has no correct digit left here).
  auto s = netkf::testing::sinopoli_scalar(0.8);
  MonteCarloOptions o;
  o.runs = 2000;
  o.steps = 3000;
  const auto mc = run_monte_carlo(s, o);
  EXPECT_TRUE(std::isfinite(mc.sq_error_pred.mean));
  EXPECT_NEAR(mc.sq_error_pred.mean, mc.trace_P_pred.mean, 4.0 * std::hypot(mc.sq_error_pred.se, mc.trace_P_pred.se));
}

}  // namespace
}  // namespace netkf
