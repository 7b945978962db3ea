// Monte Carlo runner: determinism (seed, threads) and agreement of the fixed-size kernel
// with the reference kernel (the core IntermittentKalmanFilter itself).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "netkf/sim/monte_carlo.hpp"
#include "netkf/support/progress.hpp"
#include "validation/theory_systems.hpp"

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

// Progress (netkf/support/progress.hpp): what the CLI's bar is drawn from.
struct ProgressLog {
  std::mutex mutex;
  std::vector<std::pair<std::int64_t, std::int64_t>> calls;
  std::atomic<int> inside{0};
  bool overlapped = false;
  ProgressCallback callback() {
    return [this](std::int64_t done, std::int64_t total) {
      if (inside.fetch_add(1) != 0) overlapped = true;
      {
        const std::lock_guard<std::mutex> lock(mutex);
        calls.emplace_back(done, total);
      }
      std::this_thread::sleep_for(std::chrono::microseconds(50));  // widen any overlap
      inside.fetch_sub(1);
    };
  }
  void expect_monotone_to(std::int64_t total) {
    ASSERT_FALSE(calls.empty());
    EXPECT_FALSE(overlapped);
    for (std::size_t i = 0; i < calls.size(); ++i) {
      EXPECT_EQ(calls[i].second, total);
      if (i > 0) {
        EXPECT_GT(calls[i].first, calls[i - 1].first) << "call " << i;
      }
    }
    EXPECT_EQ(calls.back().first, total);
  }
};

TEST(MonteCarlo, ReportsProgressFromItsWorkersMonotoneToTheLastRun) {
  const auto s = netkf::testing::liu_goldsmith_fig5(0.6, 0.7);
  MonteCarloOptions o;
  o.runs = 300;
  o.steps = 50;
  o.threads = 3;
  const auto without = run_monte_carlo(s, o);
  ProgressLog log;
  o.progress = log.callback();
  const auto with = run_monte_carlo(s, o);
  log.expect_monotone_to(300);
  EXPECT_EQ(log.calls.front().first, 0);  // the bar can show at once
  expect_same(with, without, 0.0);        // watching does not change the numbers
}

TEST(ProgressReporter, BoundsTheRateButAlwaysReportsTheEnd) {
  ProgressLog log;
  {
    ProgressReporter progress(log.callback(), 4000, std::chrono::hours(1));
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
      threads.emplace_back([&] {
        for (int i = 0; i < 1000; ++i) progress.add(1);
      });
    for (auto& t : threads) t.join();
  }
  // Nothing is due within the hour but the start and the end.
  ASSERT_EQ(log.calls.size(), 2u);
  log.expect_monotone_to(4000);
  EXPECT_EQ(log.calls.front().first, 0);
}

TEST(ProgressReporter, ReportsWhenDueAndDoesNothingWithoutACallback) {
  ProgressLog log;
  ProgressReporter progress(log.callback(), 3, std::chrono::nanoseconds(0));
  for (int i = 0; i < 3; ++i) progress.add(1);
  EXPECT_EQ(log.calls, (std::vector<std::pair<std::int64_t, std::int64_t>>{{0, 3}, {1, 3}, {2, 3}, {3, 3}}));
  ProgressReporter silent({}, 3);
  EXPECT_NO_THROW(silent.add(3));
}

}  // namespace
}  // namespace netkf
