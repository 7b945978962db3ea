// Monte Carlo throughput (filter steps per second) of netkf::run_monte_carlo for the scalar
// Sinopoli scenario and a 6-state, 4-sensor scenario; compare with bench/numpy_monte_carlo.py
// (the same simulation vectorised in NumPy). Results: BENCHMARKS.md, "Monte Carlo throughput".
#include <benchmark/benchmark.h>

#include "netkf/model/scenario.hpp"
#include "netkf/sim/monte_carlo.hpp"

namespace {

netkf::Scenario make(const netkf::Matrix& A, const netkf::Matrix& Q, const std::vector<netkf::Matrix>& Cs, double r,
                     double rate) {
  netkf::Scenario s;
  s.name = "bench";
  s.seed = 42;
  s.plant.A = A;
  s.plant.Q = Q;
  s.plant.x0 = netkf::Vector::Zero(A.rows());
  s.plant.P0 = netkf::Matrix::Identity(A.rows(), A.rows());
  int id = 1;
  for (const auto& C : Cs) {
    netkf::SensorSpec sensor;
    sensor.id = id++;
    sensor.C = C;
    sensor.R = netkf::Matrix::Constant(1, 1, r);
    sensor.link = netkf::BernoulliLink{1.0 - rate};
    s.sensors.push_back(sensor);
  }
  return s;
}

netkf::Scenario scalar() {
  return make(netkf::Matrix::Constant(1, 1, -1.25), netkf::Matrix::Ones(1, 1), {netkf::Matrix::Ones(1, 1)}, 2.5, 0.6);
}

netkf::Scenario six_state() {
  netkf::Matrix A(6, 6);
  A << 1.05, 0.2, 0, 0, 0, 0, -0.2, 1.05, 0, 0, 0, 0, 0, 0, 1.1, 0.1, 0, 0, 0, 0, 0, 0.9, 0.3, 0, 0, 0, 0, 0, 0.8,
      0.1, 0, 0, 0, 0, 0, 0.7;
  std::vector<netkf::Matrix> Cs(4, netkf::Matrix::Zero(1, 6));
  Cs[0](0, 0) = 1;
  Cs[1](0, 1) = Cs[1](0, 2) = 1;
  Cs[2](0, 2) = Cs[2](0, 3) = 1;
  Cs[3](0, 4) = Cs[3](0, 5) = 1;
  return make(A, netkf::Matrix::Identity(6, 6), Cs, 1.0, 0.8);
}

void run(benchmark::State& state, const netkf::Scenario& s, netkf::MonteCarloOptions::Kernel kernel) {
  netkf::MonteCarloOptions o;
  o.runs = static_cast<int>(state.range(0));
  o.steps = 300;
  o.threads = static_cast<int>(state.range(1));
  o.kernel = kernel;
  for (auto _ : state) {
    auto r = netkf::run_monte_carlo(s, o);
    benchmark::DoNotOptimize(r.trace_P_pred.mean);
  }
  state.counters["filter_steps_per_s"] =
      benchmark::Counter(static_cast<double>(o.runs) * o.steps * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
}

void BM_Scalar_Fast(benchmark::State& st) { run(st, scalar(), netkf::MonteCarloOptions::Kernel::fixed_size); }
void BM_Scalar_Reference(benchmark::State& st) { run(st, scalar(), netkf::MonteCarloOptions::Kernel::reference); }
void BM_SixState4Sensors_Fast(benchmark::State& st) { run(st, six_state(), netkf::MonteCarloOptions::Kernel::fixed_size); }
void BM_SixState4Sensors_Reference(benchmark::State& st) {
  run(st, six_state(), netkf::MonteCarloOptions::Kernel::reference);
}

}  // namespace

// Args: runs, threads. Wall-clock time (the pool uses several cores).
BENCHMARK(BM_Scalar_Fast)->Args({20000, 1})->Args({20000, 2})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Scalar_Reference)->Args({2000, 2})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SixState4Sensors_Fast)->Args({2000, 1})->Args({2000, 2})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SixState4Sensors_Reference)->Args({500, 2})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_MAIN();
