// Fused measurement update: the production update (IntermittentKalmanFilter::update,
// factored information form) against the naive stacked form with an explicit inverse
// of the (2d x 2d) innovation covariance, and the sequential Joseph-form reference,
// for n in {2, 6, 12} states and d in {1, 4, 16, 64} received sensors of size 2.
// The "per_sensor" counter is time per update / d: flat in d means linear cost.
// Results and the command: BENCHMARKS.md, "Fused update" (scripts/bench.sh fused-update).
#include <benchmark/benchmark.h>

#include <vector>

#include "netkf/filter/kalman_filter.hpp"
#include "netkf/support/random.hpp"

namespace {

using netkf::Matrix;
using netkf::Vector;

struct Setup {
  netkf::FilterModel model;
  Vector x;
  Matrix P;
  std::vector<Vector> y;
  std::vector<netkf::SensorSample> samples;
  std::vector<netkf::ReceivedBlock> blocks;
};

Matrix random_matrix(netkf::Rng& rng, Eigen::Index rows, Eigen::Index cols) {
  Matrix M(rows, cols);
  for (Eigen::Index i = 0; i < rows; ++i)
    for (Eigen::Index j = 0; j < cols; ++j) M(i, j) = rng.standard_normal();
  return M;
}
Matrix random_spd(netkf::Rng& rng, Eigen::Index n) {
  const Matrix G = random_matrix(rng, n, n);
  return G * G.transpose() / static_cast<double>(n) + 0.5 * Matrix::Identity(n, n);
}

Setup make_setup(int n, int d) {
  netkf::Rng rng(netkf::derive_seed(2026, "bench-fused-update", static_cast<std::uint64_t>(100 * n + d)));
  Setup s;
  s.model.A = random_matrix(rng, n, n);
  s.model.Q = random_spd(rng, n);
  for (int i = 0; i < d; ++i) s.model.sensors.push_back({i + 1, random_matrix(rng, 2, n), random_spd(rng, 2)});
  s.x = random_matrix(rng, n, 1);
  s.P = random_spd(rng, n);
  for (int i = 0; i < d; ++i) s.y.push_back(random_matrix(rng, 2, 1));
  for (int i = 0; i < d; ++i) {
    const auto& sensor = s.model.sensors[static_cast<std::size_t>(i)];
    s.samples.push_back({sensor.id, s.y[static_cast<std::size_t>(i)]});
    s.blocks.push_back({&sensor.C, &sensor.R, &s.y[static_cast<std::size_t>(i)]});
  }
  return s;
}

void set_counters(benchmark::State& state, int d) {
  state.counters["d"] = d;
  state.counters["per_sensor"] = benchmark::Counter(
      d, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// Production: the filter's update. The state evolves from one iteration to the next
// (P shrinks), which does not change the amount of work (no data-dependent branches).
void BM_FusedUpdate_Production(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int d = static_cast<int>(state.range(1));
  const Setup s = make_setup(n, d);
  netkf::IntermittentKalmanFilter filter(s.model, s.x, s.P);
  for (auto _ : state) {
    auto result = filter.update(s.samples);
    benchmark::DoNotOptimize(result);
    benchmark::DoNotOptimize(filter.x().data());
  }
  set_counters(state, d);
}

void BM_FusedUpdate_NaiveStackedInverse(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int d = static_cast<int>(state.range(1));
  const Setup s = make_setup(n, d);
  for (auto _ : state) {
    auto post = netkf::fused_update_stacked_inverse(s.x, s.P, s.blocks);
    benchmark::DoNotOptimize(post.P.data());
  }
  set_counters(state, d);
}

void BM_FusedUpdate_SequentialJoseph(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int d = static_cast<int>(state.range(1));
  const Setup s = make_setup(n, d);
  for (auto _ : state) {
    auto post = netkf::fused_update_sequential(s.x, s.P, s.blocks);
    benchmark::DoNotOptimize(post.P.data());
  }
  set_counters(state, d);
}

#define NETKF_FUSED_ARGS ArgsProduct({{2, 6, 12}, {1, 4, 16, 64}})->ArgNames({"n", "d"})
BENCHMARK(BM_FusedUpdate_Production)->NETKF_FUSED_ARGS;
BENCHMARK(BM_FusedUpdate_NaiveStackedInverse)->NETKF_FUSED_ARGS;
BENCHMARK(BM_FusedUpdate_SequentialJoseph)->NETKF_FUSED_ARGS;

}  // namespace

BENCHMARK_MAIN();
