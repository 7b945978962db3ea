#pragma once
// The stability verdict: is lim E[P_{k|k-1}] bounded for the plant and its links?
// `netkf analyze` (theory/report.hpp) and the live status (theory/operating_point.hpp)
// both take it from decide_stability(), so the two never disagree on one scenario.
#include <optional>
#include <span>
#include <string>

#include "netkf/model/scenario.hpp"
#include "netkf/support/types.hpp"
#include "netkf/theory/arrival_groups.hpp"
#include "netkf/theory/markov.hpp"
#include "netkf/theory/riccati.hpp"

namespace netkf::theory {

enum class Verdict { yes, no, unknown };
const char* to_string(Verdict verdict);

/// Iterations of V ← g(V) allowed to V̄ (expected_covariance_upper_bound) before it is
/// left undecided. One cap for every verdict: the live status recomputes it about once a
/// second, and near the boundary an undecided V̄ runs to the cap (cost: BENCHMARKS.md,
/// "Operating-point assessment"). It still decides liu-goldsmith-fig5's V̄ (unbounded).
inline constexpr int stability_upper_bound_iterations = 5000;

struct StabilityDecision {
  Verdict stable = Verdict::unknown;
  std::string reason;          // one line: which result decided, or why none did
  MarkovCriterion markov;      // not computed without sensors (applies = false)
  bool iid_bounds = false;     // S̄ and V̄ computed: at least one sensor, every link Bernoulli
  std::optional<Matrix> lower;  // S̄ (nullopt: unbounded, or not computed)
  UpperBound upper;            // V̄ (status undecided after 0 iterations when not computed)
  BoundMethod upper_method = BoundMethod::enumerated;  // how V̄ was summed (theory/arrival_groups.hpp)
  double upper_standard_error = 0.0;  // sampled V̄ only: standard error of Tr V̄
};

/// The verdict for the plant (A, Q) and the sensors with their links, in this order:
///  1. no sensors: open-loop prediction, bounded iff α < 1;
///  2. the necessary-and-sufficient Markov criterion where it applies, for Bernoulli and
///     Gilbert-Elliott links alike (multi-sensor paper Thm 7; Rohr et al. Thm 3.1);
///  3. every link Bernoulli (i.i.d. arrivals): V̄ = g(V̄) exists ⇒ stable (Sinopoli Thm 3/5)
///     when V̄ was summed exactly (enumerated or grouped; a sampled V̄ never decides);
///     else S̄ does not exist, q α² ≥ 1 with q the all-lost probability ⇒ unstable
///     (Sinopoli Thm 3; Liu-Goldsmith Thm 3 for d links);
///  4. otherwise unknown. Gilbert-Elliott links have memory: the i.i.d. bounds at their
///     stationary rates bound nothing for them, so they never decide.
/// Reads each link's loss model only: pass the sensors of with_effective_links() when links
/// have delay. Any number of sensors: the criterion groups sensors per eigen-block and V̄
/// is summed over count vectors or sampled (theory/markov.hpp, arrival_groups.hpp);
/// `seed` (the scenario's) seeds the sampling.
StabilityDecision decide_stability(const Matrix& A, const Matrix& Q, std::span<const SensorSpec> sensors,
                                   std::uint64_t seed = 0);

/// A number in a verdict's text: six significant digits, or enough to tell it from 1 next
/// to a "< 1" verdict.
std::string verdict_number(double v);

}  // namespace netkf::theory
