#pragma once
// One offline run of the networked filter (no DDS, no clock): what `netkf sweep --offline`
// measures per run. The scenario as the estimator sees it (with_effective_links: a sample later
// than the deadline counts as lost), every sensor measuring every period through its link's
// LinkLossProcess, the core IntermittentKalmanFilter fusing what arrived.
//
// Like the Monte Carlo (monte_carlo.hpp) it simulates the estimation error e_k = x_k − x̂_k
// rather than the state: the filter is linear in its data and a known control input cancels
// in the error, so the error has the same law as x − x̂ of the closed or open loop, with all
// its digits even for unstable A (monte_carlo.cpp, file comment).
#include <cstdint>
#include <functional>
#include <vector>

#include "netkf/model/scenario.hpp"

namespace netkf {

/// One period k of an offline run, after its fused update.
struct OfflinePeriod {
  std::int64_t k = 0;
  double squared_error = 0.0;     // |x_k − x̂_{k|k}|²
  double trace_P = 0.0;           // Tr P_{k|k}
  double trace_P_pred = 0.0;      // Tr P_{k|k-1} (before the period's fused update)
  std::vector<int> fused;         // sensor ids fused this period (sorted)
  std::vector<bool> arrived;      // per sensor in scenario order: its sample arrived in time
  bool diverging = false;         // the filter's state is `diverging`
};

/// Runs `periods` periods (≥ 1) of `scenario` with the random streams derived from `seed`
/// (derive_seed(seed, "process-noise" | "sensor-noise" | "link", id)) and calls `on_period`
/// after each. Deterministic given (scenario, seed, periods). Throws std::invalid_argument for
/// periods < 1 and for a scenario with link events (a timeline needs the live network).
void simulate_offline_run(const Scenario& scenario, std::uint64_t seed, std::int64_t periods,
                          const std::function<void(const OfflinePeriod&)>& on_period);

}  // namespace netkf
