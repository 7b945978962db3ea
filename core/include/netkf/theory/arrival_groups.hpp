#pragma once
// The expected Riccati map (Liu-Goldsmith eq. 12, over every arrival pattern) for any
// number of sensors.
//
// A pattern S enters the map only through its information J_S = Σ_{j∈S} C_j' R_j⁻¹ C_j:
// with M = C_S X C_S' + R_S, the push-through identity gives
//     X C_S' M⁻¹ C_S X = X − (I + X J_S)⁻¹ X,   A + K_S C_S = A (I + X J_S)⁻¹,
// so a pattern is carried as C = J_S^{1/2} (at most n rows) with R = I, and every map of
// theory/riccati.hpp is unchanged. Sensors with the same (C_i, R_i) are exchangeable in
// J_S: only how many of them arrived matters, and with independent links of rates λ_j
// that count is Poisson-binomial (binomial when the rates agree). So the map is an exact
// sum over Π_g (m_g + 1) count vectors (multinomial over the groups g of m_g sensors)
// instead of 2^N patterns. With all sensors distinct this is the 2^N enumeration itself.
//
// Policy (docs/validation.md, "Beyond 16 sensors"):
//   * Π_g (m_g + 1) ≤ exact_pattern_limit: exact (method `enumerated` when every group
//     has one sensor, else `grouped`);
//   * otherwise `sampled`: B batches of S patterns drawn from the links (seeded from the
//     scenario); each batch's empirical map gives its own V̄, and the report gives their
//     mean and standard error. A sampled V̄ is an estimate, not a bound: it never decides a
//     verdict. S̄ needs only q = Π(1 − λ_i) and is always exact.
#include <cstdint>
#include <span>
#include <vector>

#include "netkf/model/scenario.hpp"
#include "netkf/support/types.hpp"
#include "netkf/theory/riccati.hpp"

namespace netkf::theory {

enum class BoundMethod { enumerated, grouped, sampled };
const char* to_string(BoundMethod method);

/// Largest number of (count-vector) patterns summed exactly; 2^12 keeps every network of
/// up to 12 distinct sensors on the exact path.
inline constexpr std::size_t exact_pattern_limit = 4096;

struct SamplingOptions {
  std::uint64_t seed = 0;  // the scenario seed (stream "theory-bounds")
  int batches = 8;         // B
  int samples = 256;       // S patterns per batch
};

/// The pattern sets the expected map sums over: one set (weights summing to 1) when exact,
/// `batches` equal-weight empirical sets when sampled.
struct PatternSets {
  BoundMethod method = BoundMethod::enumerated;
  std::vector<std::vector<ArrivalPattern>> sets;
  std::size_t groups = 0;  // exchangeable groups (same C, R)
};

/// Patterns of independent Bernoulli links with arrival rates λ_i, compressed as above
/// (sensor_indices hold one representative per arrived group member, for reading only).
/// Throws std::invalid_argument for a size mismatch or a rate outside [0, 1].
PatternSets grouped_arrival_patterns(std::span<const SensorSpec> sensors, std::span<const double> arrival_rates,
                                     const SamplingOptions& sampling = {},
                                     std::size_t limit = exact_pattern_limit);

/// Force the sampled path (for tests and comparisons).
PatternSets sampled_arrival_patterns(std::span<const SensorSpec> sensors, std::span<const double> arrival_rates,
                                     const SamplingOptions& sampling);

struct UpperBoundEstimate {
  UpperBound bound;               // exact: V̄ itself; sampled: mean of the batches' V̄ (status bounded iff all are)
  BoundMethod method = BoundMethod::enumerated;
  double trace_standard_error = 0.0;  // sampled only: sd of the batches' Tr V̄ / √B
  int batches = 1;
  int samples_per_batch = 0;      // sampled only
};

/// V̄ = g(V̄) (Sinopoli Thm 6a; Liu-Goldsmith Thm 6a) over the pattern sets.
UpperBoundEstimate expected_covariance_upper_bound(const Matrix& A, const Matrix& Q, const PatternSets& patterns,
                                                   const UpperBoundOptions& options = {});

}  // namespace netkf::theory
