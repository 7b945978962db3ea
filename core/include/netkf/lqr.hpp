#pragma once
// Steady-state LQR gain for the optional LQG loop (docs/architecture.md, "plant_node"): the
// estimator's controller applies u_k = -L x̂_{k|k}. By the separation principle the
// gain does not change the estimation error, so any stabilising L keeps the papers'
// theory intact; LQR is just a principled way to pick one from weights.
#include "netkf/types.hpp"

namespace netkf {

/// Stabilising solution X of the discrete algebraic Riccati equation
///   X = A'XA - A'XB (Ru + B'XB)^{-1} B'XA + Qx.
/// Requires A n x n, B n x p, Qx n x n symmetric PSD, Ru p x p symmetric PD,
/// (A, B) stabilisable and (A, Qx) detectable. Throws std::invalid_argument otherwise
/// (with a message saying which condition failed) or if the iteration does not converge.
Matrix solve_dare(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru);

/// Steady-state LQR gain L = (Ru + B'XB)^{-1} B'XA (p x n), X from solve_dare; the
/// closed loop A - B L is Schur stable. Throws std::invalid_argument like solve_dare.
Matrix lqr_gain(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru);

}  // namespace netkf
