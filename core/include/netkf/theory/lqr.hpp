#pragma once
// Steady-state LQR gain for the optional LQG loop (docs/architecture.md, "plant_node"): the
// estimator's controller applies u_k = -L x̂_{k|k}. By the separation principle the
// gain does not change the estimation error, so any stabilising L keeps the papers'
// theory intact; LQR is just a principled way to pick one from weights.
#include <optional>

#include "netkf/support/types.hpp"

namespace netkf::theory {

/// Stabilising solution X of the discrete algebraic Riccati equation
///   X = A'XA - A'XB (Ru + B'XB)^{-1} B'XA + Qx.
/// Requires A n x n, B n x p, Qx n x n symmetric PSD, Ru p x p symmetric PD,
/// (A, B) stabilisable and (A, Qx) detectable. Throws std::invalid_argument otherwise
/// (with a message saying which condition failed) or if the iteration does not converge.
Matrix solve_dare(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru);

/// Steady-state LQR gain L = (Ru + B'XB)^{-1} B'XA (p x n), X from solve_dare; the
/// closed loop A - B L is Schur stable. Throws std::invalid_argument like solve_dare.
Matrix lqr_gain(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru);

/// The control Riccati equation of an actuation link that delivers each input with
/// probability ν (i.i.d.; a lost input is applied as zero), with acknowledgements (TCP-like):
///   S = A'SA + Qx − ν A'SB (B'SB + Ru)^{-1} B'SA
/// (Schenato et al. 2007, Sec. V; Sinopoli et al., ACC 2005). Its solution exists iff ν is
/// above the critical rate ν_c of the optimal controller. It is the estimator's modified
/// Riccati map g_ν of the dual system (A', B') (theory/riccati.hpp), and is solved with the
/// same fixed-point iteration. ν = 1 is solve_dare. Same requirements and errors as solve_dare;
/// std::nullopt when no solution exists (ν ≤ ν_c); throws when ν is outside [0, 1] or the
/// iteration cannot decide (ν within a hair of ν_c).
std::optional<Matrix> solve_lossy_dare(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru,
                                       double arrival_rate);

/// The TCP-like optimal gain L = (B'SB + Ru)^{-1} B'SA for that equation; u = −L x̂_{k|k}.
/// ν = 1 gives lqr_gain exactly. Throws std::invalid_argument when no solution exists (the
/// message says so), or like solve_lossy_dare.
Matrix lossy_lqr_gain(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru, double arrival_rate);

}  // namespace netkf::theory
