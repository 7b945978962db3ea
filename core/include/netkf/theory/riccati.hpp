#pragma once
// Expected-covariance maps for the Kalman filter with intermittent observations and
// their bounds.
//
//  * Sinopoli et al., eq. (17): the modified algebraic Riccati map
//      g_λ(X) = A X A' + Q − λ A X C'(C X C' + R)⁻¹ C X A'.
//  * Liu-Goldsmith eq. (12), generalised from two to d independently lost sensors:
//      g(X) = Σ_S π_S [A X A' + Q − A X C_S'(C_S X C_S' + R_S)⁻¹ C_S X A'],
//    summed over every arrival pattern S ⊆ {1..d} (π_S its probability, C_S / R_S the
//    received sensors' rows stacked). With one sensor this is g_λ.
//  * Lower bound S̄ (Sinopoli Thm 4 / Liu-Goldsmith Thm 4): S = q A S A' + Q with q the
//    probability that nothing arrives; upper bound V̄ = g(V̄) (Sinopoli Thm 6a).
//    Both bound lim E[P_{k|k-1}] when the arrivals are i.i.d.
// Divergence is reported as "unbounded" (std::nullopt / status), never as a huge number.
#include <optional>
#include <span>
#include <vector>

#include "netkf/model/scenario.hpp"
#include "netkf/support/types.hpp"

namespace netkf::theory {

/// One subset S of sensors whose samples arrive in the same period, with its probability π_S.
struct ArrivalPattern {
  std::vector<int> sensor_indices;  // indices into the sensor list (not ids); empty = all lost
  double probability = 0.0;         // π_S
  Matrix C;                         // C_S: received sensors' C_i stacked (0 x n when empty)
  Matrix R;                         // R_S: block diagonal of their R_i
};

/// All 2^d arrival patterns of d independent Bernoulli links with the given arrival rates
/// λ_i (one per sensor, in the sensor order). Patterns of probability 0 are left out.
/// Throws std::invalid_argument when sizes differ or a rate is outside [0,1], or d > 16.
std::vector<ArrivalPattern> independent_arrival_patterns(std::span<const SensorSpec> sensors,
                                                         std::span<const double> arrival_rates);

/// Probability that no sample arrives in a period (q = Π(1 − λ_i)).
double all_lost_probability(std::span<const double> arrival_rates);

/// Sinopoli eq. (17): g_λ(X) for one sensor (C, R) with arrival rate λ.
Matrix modified_riccati_map(const Matrix& A, const Matrix& C, const Matrix& Q, const Matrix& R,
                            double arrival_rate, const Matrix& X);

/// Liu-Goldsmith eq. (12) generalised to d sensors: E[P_{k+1} | P_k = X].
Matrix expected_riccati_map(const Matrix& A, const Matrix& Q, std::span<const ArrivalPattern> patterns,
                            const Matrix& X);

/// Lower bound S̄: the solution of S = q A S A' + Q (Sinopoli Thm 4 with q = 1 − λ;
/// Liu-Goldsmith Thm 4 with q = (1−λ1)(1−λ2)). nullopt when q·α² ≥ 1 (no PSD solution:
/// unbounded).
std::optional<Matrix> lyapunov_lower_bound(const Matrix& A, const Matrix& Q, double all_lost_probability);

enum class BoundStatus { bounded, unbounded, undecided };
const char* to_string(BoundStatus status);

struct UpperBoundOptions {
  int max_iterations = 20000;        // iterations of V ← g(V) before giving up (undecided)
  double divergence_trace = 1e15;    // Tr V above this (relative to 1 + Tr Q) = unbounded
  double tolerance = 1e-12;          // relative change that ends the policy iteration
};

struct UpperBound {
  BoundStatus status = BoundStatus::undecided;
  Matrix V;             // V̄ when bounded (fixed point of g), else the last iterate
  int iterations = 0;   // g iterations until the stability certificate (or divergence)
};

/// Upper bound V̄ = g(V̄) (Sinopoli Thm 6a; Liu-Goldsmith Thm 6a).
/// Method: iterate V ← g(V) from V = 0 (monotone, Sinopoli Thm 1) until the gains
/// K_S(V) make the linear part L(X) = Σ π_S F_S X F_S' (F_S = A + K_S C_S) contractive,
/// ρ(Σ π_S F_S ⊗ F_S) < 1. That is a certificate that ∃X > φ(K, X) (Sinopoli Lemma 3/
/// Thm 5b), so V̄ exists; it is then found exactly by policy iteration X ← fixed point
/// of φ(K(X), ·) (a linear solve), which converges monotonically from above.
/// If Tr V passes the divergence bound first, no X > g(X) exists: unbounded.
UpperBound expected_covariance_upper_bound(const Matrix& A, const Matrix& Q,
                                           std::span<const ArrivalPattern> patterns,
                                           const UpperBoundOptions& options = {});

/// ρ(Σ π_S F_S ⊗ F_S) for the optimal gains at X (the spectral radius of the derivative
/// of g at X). < 1 certifies that g has a fixed point.
double linearised_spectral_radius(const Matrix& A, std::span<const ArrivalPattern> patterns, const Matrix& X);

/// α = max |eig(A)|.
double spectral_radius(const Matrix& A);

/// Kronecker product a ⊗ b: vec(F X F') = (F ⊗ F) vec(X) for column-major vec.
Matrix kron(const Matrix& a, const Matrix& b);

}  // namespace netkf::theory

namespace netkf::theory {

/// Steady-state covariance of the static-gain predictor x̂_{t+1} = A x̂_t + γ_t K (y_t − C x̂_t)
/// (Sinopoli Sec. V, eqs. 27-28, one sensor, arrival rate λ):
///   P = (1−λ)(A P A' + Q) + λ((A − K C) P (A − K C)' + Q + K R K').
/// In the scalar case P̄ = (Q + λK²R) / (1 − (1−λ)A² − λ(A − KC)²) — note λK²R: eq. (28) as
/// printed omits the λ. nullopt when the recursion is unstable.
std::optional<Matrix> static_gain_covariance(const Matrix& A, const Matrix& C, const Matrix& Q, const Matrix& R,
                                             double arrival_rate, const Matrix& K);

/// Kalman gain of the static predictor in Sinopoli Sec. V's sign convention
/// (F = A − K C): K = A X C'(C X C' + R)⁻¹.
Matrix predictor_gain(const Matrix& A, const Matrix& C, const Matrix& R, const Matrix& X);

}  // namespace netkf::theory
