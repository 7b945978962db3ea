// Monte Carlo runner: determinism (seed, threads) and agreement of the fixed-size kernel
// with the reference kernel (the core IntermittentKalmanFilter itself).
#include <gtest/gtest.h>

#include "netkf/monte_carlo.hpp"
#include "../validation/theory_systems.hpp"

namespace netkf {
namespace {

void expect_same(const MonteCarloResult& a, const MonteCarloResult& b, double tol) {
  EXPECT_NEAR(a.trace_P_pred.mean, b.trace_P_pred.mean, tol * (1 + std::abs(a.trace_P_pred.mean)));
  EXPECT_NEAR(a.trace_P_filt.mean, b.trace_P_filt.mean, tol * (1 + std::abs(a.trace_P_filt.mean)));
  EXPECT_NEAR(a.sq_error_pred.mean, b.sq_error_pred.mean, tol * (1 + std::abs(a.sq_error_pred.mean)));
  EXPECT_NEAR(a.sq_error_filt.mean, b.sq_error_filt.mean, tol * (1 + std::abs(a.sq_error_filt.mean)));
  EXPECT_NEAR(a.sq_error_pred.se, b.sq_error_pred.se, tol * (1 + std::abs(a.sq_error_pred.se)));
  EXPECT_EQ(a.diverged_fraction, b.diverged_fraction);
}

TEST(MonteCarlo, SameSeedSameNumbersWhateverTheThreads) {
  const auto s = netkf::testing::liu_goldsmith_fig5(0.6, 0.7);
  MonteCarloOptions o;
  o.runs = 300;
  o.steps = 50;
  o.threads = 1;
  const auto one = run_monte_carlo(s, o);
  o.threads = 2;
  const auto two = run_monte_carlo(s, o);
  expect_same(one, two, 0.0);
  o.seed = s.seed + 1;
  const auto other = run_monte_carlo(s, o);
  EXPECT_NE(one.sq_error_pred.mean, other.sq_error_pred.mean);
}

TEST(MonteCarlo, FixedSizeKernelMatchesTheCoreFilter) {
  for (const auto& s : {netkf::testing::sinopoli_scalar(0.6), netkf::testing::sinopoli_mimo(0.7),
                        netkf::testing::liu_goldsmith_fig5(0.5, 0.6)}) {
    MonteCarloOptions o;
    o.runs = 100;
    o.steps = 120;
    o.kernel = MonteCarloOptions::Kernel::reference;
    const auto reference = run_monte_carlo(s, o);
    o.kernel = MonteCarloOptions::Kernel::fixed_size;
    const auto fast = run_monte_carlo(s, o);
    EXPECT_FALSE(reference.used_fixed_size_kernel);
    EXPECT_TRUE(fast.used_fixed_size_kernel);
    expect_same(reference, fast, 1e-8);
  }
}

TEST(MonteCarlo, FixedSizeKernelMatchesTheCoreFilterWithSeveralScalarLinks) {
  // n = 1 takes the kernel's vectorised path; three sensors on Bernoulli and Gilbert-Elliott
  // links, and a run count that fills neither a block of runs nor a chunk.
  using netkf::testing::mat;
  auto s = netkf::testing::system(
      mat({{-1.25}}), mat({{1.0}}),
      {netkf::testing::sensor(1, mat({{1.0}}), mat({{2.5}}), BernoulliLink{0.5}),
       netkf::testing::sensor(2, mat({{0.5}}), mat({{1.0}}), GilbertElliottLink{0.1, 0.4, 0.0, 1.0}),
       netkf::testing::sensor(3, mat({{2.0}}), mat({{4.0}}), BernoulliLink{0.7})});
  MonteCarloOptions o;
  o.runs = 45;
  o.steps = 90;
  o.record_series = true;
  o.kernel = MonteCarloOptions::Kernel::reference;
  const auto reference = run_monte_carlo(s, o);
  o.kernel = MonteCarloOptions::Kernel::fixed_size;
  const auto fast = run_monte_carlo(s, o);
  expect_same(reference, fast, 1e-8);
  ASSERT_EQ(fast.series.size(), reference.series.size());
  for (std::size_t k = 0; k < fast.series.size(); ++k) {
    EXPECT_NEAR(fast.series[k].trace_P_pred.mean, reference.series[k].trace_P_pred.mean,
                1e-8 * (1 + reference.series[k].trace_P_pred.mean));
    EXPECT_NEAR(fast.series[k].sq_error_pred.mean, reference.series[k].sq_error_pred.mean,
                1e-8 * (1 + reference.series[k].sq_error_pred.mean));
  }
  o.threads = 1;
  const auto one = run_monte_carlo(s, o);
  o.threads = 2;
  const auto two = run_monte_carlo(s, o);
  expect_same(one, two, 0.0);
  EXPECT_EQ(one.series.back().trace_P_pred.mean, two.series.back().trace_P_pred.mean);
}

TEST(MonteCarlo, RejectsEmptyRuns) {
  MonteCarloOptions o;
  o.runs = 0;
  EXPECT_THROW(run_monte_carlo(netkf::testing::sinopoli_scalar(0.6), o), std::invalid_argument);
}

}  // namespace
}  // namespace netkf
