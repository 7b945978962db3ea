#pragma once
// Offline Monte Carlo of the intermittent Kalman filter (docs/architecture.md, `netkf simulate`):
// N runs × T steps of the core filter with the real loss processes, seeded from the
// scenario, on a worker pool. Deterministic given the seed, whatever the thread count
// (runs are grouped in fixed chunks and reduced in chunk order).
//
// Precision with unstable A: the state grows like α^t, so x − x̂ computed from x loses
// every digit after a few hundred steps (docs/validation.md, "Fig. 7"). The runs
// therefore simulate the estimation error directly; see monte_carlo.cpp for why this is
// the same filter and the same law.
#include <cstdint>
#include <optional>
#include <vector>

#include "netkf/model/scenario.hpp"
#include "netkf/support/progress.hpp"

namespace netkf {

struct MonteCarloOptions {
  int runs = 1000;
  int steps = 300;
  std::optional<std::uint64_t> seed;   // default: the scenario's seed
  int threads = 0;                     // 0: std::thread::hardware_concurrency()
  bool record_series = false;          // per-step means (for plots)
  /// Kernel: the real IntermittentKalmanFilter (reference), or the fixed-size kernel that runs
  /// the same recursion with stack-allocated matrices on blocks of runs in lockstep
  /// (scalar-output sensors, n ≤ 6, at most 16 sensors); `automatic` takes the fast kernel where
  /// it applies. Both use the real LinkLossProcess and draw the same numbers for a run.
  enum class Kernel { automatic, reference, fixed_size } kernel = Kernel::automatic;
  /// Runs done of `runs`, from the worker threads at most every 100 ms (netkf/support/progress.hpp).
  ProgressCallback progress;
};

/// Mean and standard error of the mean over runs.
struct MeanSe {
  double mean = 0.0;
  double se = 0.0;
};

struct MonteCarloSeriesPoint {
  int step = 0;
  MeanSe trace_P_pred;
  MeanSe sq_error_pred;
};

struct MonteCarloResult {
  int runs = 0;
  int steps = 0;
  std::uint64_t seed = 0;
  // At the last step T−1: Tr P_{k|k−1}, Tr P_{k|k}, ||x − x̂_{k|k−1}||², ||x − x̂_{k|k}||².
  MeanSe trace_P_pred, trace_P_filt, sq_error_pred, sq_error_filt;
  double diverged_fraction = 0.0;  // filter state `diverging` at the end, or non-finite
  int finite_runs = 0;             // runs whose numbers entered the means
  bool used_fixed_size_kernel = false;
  std::vector<MonteCarloSeriesPoint> series;  // with record_series
};

/// Throws std::invalid_argument for runs/steps < 1.
MonteCarloResult run_monte_carlo(const Scenario& scenario, const MonteCarloOptions& options = {});

}  // namespace netkf
