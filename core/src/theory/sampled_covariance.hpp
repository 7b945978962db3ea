#pragma once
// lim E[P_{k|k-1}] of the intermittent filter estimated by simulation, for links whose
// arrivals have memory (Gilbert-Elliott): Sinopoli's bounds S̄ ≤ lim E[P] ≤ V̄ (Thm 4, 6) and
// their multi-sensor form (Liu-Goldsmith Thm 4) assume i.i.d. arrivals, and no closed bound
// for Markov arrivals is implemented here. The covariance recursion does not depend on the
// measurements, only on which samples arrived:
//     P_{k+1} = A (P_k − P_k C_k' (C_k P_k C_k' + R_k)⁻¹ C_k P_k) A' + Q
// (Sinopoli eq. 9 with the arrived sensors' C_i stacked and R_i block-diagonal; the multi-sensor
// paper's eq. 5), so each run draws the links' own loss sequences (LinkLossProcess, seeded from
// the scenario: reproducible) and averages Tr P_{k|k-1} over its periods after a burn-in. The
// result is an estimate with its standard error over the runs, never a bound, and it decides no
// verdict: it is only computed where the Markov criterion already said "stable".
// No threads, no logging.
#include <cstdint>
#include <optional>
#include <span>

#include "netkf/model/scenario.hpp"
#include "netkf/support/types.hpp"

namespace netkf::theory {

struct SampledCovarianceOptions {
  int runs = 64;                    // independent runs (the standard error is over these)
  int periods = 2000;               // periods averaged per run, after the burn-in
  int burn_in = 200;                // periods dropped at the start of each run (P_0 forgotten)
  double divergence_trace = 1e12;   // a run whose Tr P exceeds this has no finite mean to estimate
};

struct SampledCovariance {
  double trace_mean = 0.0;      // estimate of lim E[Tr P_{k|k-1}]: the mean of the runs' time averages
  double standard_error = 0.0;  // sd of the runs' time averages / √runs
  int runs = 0;
  int periods = 0;
  int burn_in = 0;
};

/// `sensors` with their links' loss models as the estimator sees them (delays folded in, as
/// with_effective_links does); trace links are sampled by their empirical model. nullopt when
/// a run diverged (Tr P above options.divergence_trace) or there is no sensor. `seed`: the
/// scenario's seed (each run and link draws from its own derived stream).
std::optional<SampledCovariance> sampled_expected_covariance(const Matrix& A, const Matrix& Q, const Matrix& P0,
                                                             std::span<const SensorSpec> sensors, std::uint64_t seed,
                                                             const SampledCovarianceOptions& options = {});

}  // namespace netkf::theory
