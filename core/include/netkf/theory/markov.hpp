#pragma once
// Necessary and sufficient stability criterion for Markov (incl. Gilbert-Elliott and
// i.i.d.) packet losses: E[P_{k|k-1}] stays bounded iff
//     α_i² · limsup_N P(R_N(i))^{1/N} < 1   for every eigen-block i of A
// (multi-sensor paper Thm 4 and Thm 7; Rohr-Marelli-Fu Thm 3.1), where R_N(i) is the
// set of arrival sequences of length N for which the block's columns of the regression
// matrix O_N = S_N col{C, CA, ..., CA^{N-1}} (eq. 14) are rank deficient.
//
// Computation (multi-sensor paper Thm 9, Rohr et al. Lemma 4.1 / Thm 4.1): in the
// eigen-coordinates of a diagonalisable A, block i evolves as α_i U_i with U_i unitary
// diagonal. We track, for each block, the subspace W of functionals of the current
// state that the received samples have revealed (W ← W U_i⁻¹ + span{C_j V_i : j arrived})
// jointly with the links' Markov states. The rank-deficient (dim W < n_i) states form a
// finite chain for periodic blocks; its sub-stochastic transition matrix M has
// P(R_N) = u M^N v and limsup P(R_N)^{1/N} = ρ(M) (eq. 35-36: per step here rather than
// per period τ, which is the same number).
//
// Any number of sensors (multi-sensor paper Thm 7 needs, per block i, only which sensors
// have arrived; the default path, MarkovOptions::group_sensors):
//  * a sensor j with C_j V_i = 0 never observes block i and drops out of its chain;
//  * the rank of the stacked rows depends only on the union of the arrived sensors' row
//    spaces, so sensors with the same row space in block i form one observation class; a
//    class "arrives" when any member does. Independent Bernoulli members merge into one
//    Bernoulli link (loss Π loss_j); identical Gilbert-Elliott members are tracked by how
//    many are in the bad state (an exactly lumpable chain, m + 1 states); the class chain
//    is the product of those. Exact, with 2^{classes} masks instead of 2^d;
//  * when the block has one class and every observing sensor alone reveals the whole block
//    (C_j V_i of full column rank n_i), W never leaves {0}: R_N(i) is "every observing
//    sensor lost N times", whose chain is the Kronecker product of the links' lost-chains
//    M_j(to, from) = T_j(from, to) · loss_j(to), so limsup P(R_N)^{1/N} = Π_j ρ(M_j)
//    (= Π_j (1 − λ_j) for Bernoulli links). Exact and O(d): `product`;
//  * otherwise, with more classes than max_classes, bounds (`bounds`): necessary,
//    P(R_N) ≥ P(every observing sensor lost), rate ≥ Π_j ρ(M_j); sufficient, dropping
//    classes only adds rank-deficient sequences, so the exact chain over the max_classes
//    most reliable classes bounds the rate from above. The block decides when the upper
//    criterion is < 1 (stable) or the lower one ≥ 1 (unstable); else the criterion does
//    not apply.
// The 2^d enumeration over single sensors (group_sensors = false, d ≤ 16) is kept as the
// reference the tests compare with.
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "netkf/model/scenario.hpp"
#include "netkf/support/types.hpp"

namespace netkf::theory {

struct EigenBlockCriterion {
  double modulus = 0.0;          // α_i
  int dimension = 0;             // n_i
  double deficiency_rate = 0.0;  // limsup P(R_N(i))^{1/N} = ρ(M_i)
  double criterion = 0.0;        // α_i² · deficiency_rate (stable block iff < 1)
  int chain_states = 0;          // size of the rank-deficient chain
  std::string method;            // "product", "classes", "enumerated" or "bounds" (see above)
  int observing_sensors = 0;     // sensors with C_j V_i ≠ 0
  int classes = 0;               // observation classes (distinct row spaces) among them
  double criterion_lower = 0.0;  // "bounds": α_i² Π_j ρ(M_j) (≥ 1: unstable, necessary condition)
  double criterion_upper = 0.0;  // "bounds": α_i² · rate over a subset of classes (< 1: stable, sufficient)
};

struct MarkovCriterion {
  bool applies = false;               // false: an assumption fails, see `reasons`
  double value = 0.0;                 // max over eigen-blocks of α_i² ρ(M_i)
  std::vector<EigenBlockCriterion> blocks;
  std::vector<std::string> reasons;   // why it does not apply / what was assumed
  /// false: some block was decided by its bounds; `value` is then the number that decided
  /// (an upper criterion < 1 for stable, a lower one ≥ 1 for unstable), not the exact one.
  bool exact = true;
  bool stable() const { return applies && value < 1.0; }
};

struct MarkovOptions {
  int max_chain_states = 600;   // per eigen-block; larger (e.g. aperiodic rotations) => not applicable
  bool group_sensors = true;    // false: the reference 2^d enumeration over single sensors (d ≤ 16)
  int max_classes = 8;          // observation classes tracked exactly per block (2^classes masks)
  int max_class_link_states = 64;  // product of the classes' chain sizes tracked exactly
};

/// Criterion for the sensors with their configured links (Bernoulli or Gilbert-Elliott,
/// links independent of each other). Reads each link's loss model only: pass the sensors of
/// with_effective_links() when links have delay.
MarkovCriterion markov_stability_criterion(const Matrix& A, std::span<const SensorSpec> sensors,
                                           const MarkovOptions& options = {});

/// Multi-sensor paper Thm 12 (second-order A = α diag(e^{iθ1}, e^{iθ2}), i.i.d. links with
/// arrival rates p_i, rank col{C_i, C_j} = 2, (A, C_i) observable): stable iff
///     Π(1 − p_i)^τ / min_j p*_j · α^{2τ} < 1,   p*_j = Π_{k ∈ J_j} (1 − p_k)  (eq. 37-38).
/// Returned as the per-step number α² (Π(1 − p_i)^τ / min_j p*_j)^{1/τ}, comparable with
/// MarkovCriterion::value. τ is read as the least τ with A^τ a real multiple of I, i.e.
/// e^{i(θ1−θ2)τ} = 1 — the period of the rank pattern of O_N. (The paper's "A^τ = α^τ I"
/// would double τ for e.g. a 90° rotation, where A² = −α² I already repeats the rank
/// pattern; with it, the formula disagrees with the transition matrix.)
/// nullopt when an assumption fails; `why_not` then says which.
std::optional<double> second_order_iid_criterion(const Matrix& A, std::span<const SensorSpec> sensors,
                                                 std::span<const double> arrival_rates,
                                                 std::string* why_not = nullptr, int* period = nullptr);

}  // namespace netkf::theory
