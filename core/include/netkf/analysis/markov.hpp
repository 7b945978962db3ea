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
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "netkf/scenario.hpp"
#include "netkf/types.hpp"

namespace netkf::analysis {

struct EigenBlockCriterion {
  double modulus = 0.0;          // α_i
  int dimension = 0;             // n_i
  double deficiency_rate = 0.0;  // limsup P(R_N(i))^{1/N} = ρ(M_i)
  double criterion = 0.0;        // α_i² · deficiency_rate (stable block iff < 1)
  int chain_states = 0;          // size of the rank-deficient chain
};

struct MarkovCriterion {
  bool applies = false;               // false: an assumption fails, see `reasons`
  double value = 0.0;                 // max over eigen-blocks of α_i² ρ(M_i)
  std::vector<EigenBlockCriterion> blocks;
  std::vector<std::string> reasons;   // why it does not apply / what was assumed
  bool stable() const { return applies && value < 1.0; }
};

struct MarkovOptions {
  int max_chain_states = 600;   // per eigen-block; larger (e.g. aperiodic rotations) => not applicable
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

}  // namespace netkf::analysis
