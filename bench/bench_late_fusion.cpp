// The re-run of estimator.late_policy fuse_within (EstimatorCore::revise): its worst case is a
// late sample for the oldest period of the ring, so the filter is re-run over all D fused
// periods (D fused updates with every sensor, D predictions). D = 64 (the largest allowed) and
// 16 sensors of size 2, for n in {2, 6, 12} states; and, for scale, one in-time period (tick,
// 16 samples, fused update). Results and the command: BENCHMARKS.md, "Late-sample re-run"
// (scripts/bench.sh late-fusion).
#include <benchmark/benchmark.h>

#include <vector>

#include "netkf/nodes/estimator_core.hpp"
#include "netkf/support/random.hpp"

namespace {

using netkf::Matrix;
using netkf::Vector;
using netkf::nodes::EstimatorCore;

constexpr int kSensors = 16;
constexpr int kMeasurementDim = 2;
constexpr std::int64_t kMs = 1000000;

Matrix random_matrix(netkf::Rng& rng, Eigen::Index rows, Eigen::Index cols) {
  Matrix M(rows, cols);
  for (Eigen::Index i = 0; i < rows; ++i)
    for (Eigen::Index j = 0; j < cols; ++j) M(i, j) = rng.standard_normal();
  return M;
}

netkf::Scenario scenario(int n, int D) {
  netkf::Rng rng(netkf::derive_seed(2026, "bench-late-fusion", static_cast<std::uint64_t>(n)));
  netkf::Scenario s;
  s.name = "bench-late-fusion";
  s.period_ms = 10;
  s.plant.A = 0.95 * Matrix::Identity(n, n) + 0.05 * random_matrix(rng, n, n);
  s.plant.Q = Matrix::Identity(n, n);
  s.plant.x0 = Vector::Zero(n);
  s.plant.P0 = Matrix::Identity(n, n);
  for (int i = 0; i < kSensors; ++i) {
    netkf::SensorSpec sp;
    sp.id = i + 1;
    sp.C = random_matrix(rng, kMeasurementDim, n);
    sp.R = Matrix::Identity(kMeasurementDim, kMeasurementDim);
    s.sensors.push_back(sp);
  }
  s.estimator.deadline_ms = 8;
  s.estimator.late_policy = netkf::LatePolicy::fuse_within;
  s.estimator.max_delay_periods = D;
  return s;
}

// One period: the tick, every sensor but sensor 1 in time, the deadline.
void run_period(EstimatorCore& core, std::uint64_t k, const Vector& y) {
  const auto t = static_cast<std::int64_t>(k) * 10 * kMs;
  benchmark::DoNotOptimize(core.on_tick(k, Vector(), t));
  for (int id = 2; id <= kSensors; ++id) benchmark::DoNotOptimize(core.on_sample(id, k, y, t, t + kMs));
  benchmark::DoNotOptimize(core.on_deadline(t + 8 * kMs));
}

// Sensor 1's sample of the oldest period in the ring arrives late: the re-run covers all D
// periods, each with all 16 sensors.
void BM_ReRun_Worst(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int D = static_cast<int>(state.range(1));
  EstimatorCore core(scenario(n, D));
  const Vector y = Vector::Constant(kMeasurementDim, 0.3);
  std::uint64_t k = 0;
  for (; k < static_cast<std::uint64_t>(D); ++k) run_period(core, k, y);
  for (auto _ : state) {
    state.PauseTiming();
    run_period(core, k, y);
    const std::uint64_t oldest = k + 1 - static_cast<std::uint64_t>(D);
    core.on_sample(1, oldest, y, 0, static_cast<std::int64_t>(k) * 10 * kMs + 9 * kMs);
    ++k;
    state.ResumeTiming();
    const auto revised = core.revise(static_cast<std::int64_t>(k) * 10 * kMs);
    benchmark::DoNotOptimize(revised.data());
    if (revised.size() != static_cast<std::size_t>(D)) state.SkipWithError("the re-run did not cover D periods");
  }
}

// For scale: one in-time period with fuse_within D (the history bookkeeping included).
void BM_InTimePeriod(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int D = static_cast<int>(state.range(1));
  EstimatorCore core(scenario(n, D));
  const Vector y = Vector::Constant(kMeasurementDim, 0.3);
  std::uint64_t k = 0;
  for (auto _ : state) run_period(core, k++, y);
}

BENCHMARK(BM_ReRun_Worst)->ArgNames({"n", "D"})->Args({2, 64})->Args({6, 64})->Args({12, 64})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_InTimePeriod)->ArgNames({"n", "D"})->Args({2, 64})->Args({6, 64})->Args({12, 64})->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
