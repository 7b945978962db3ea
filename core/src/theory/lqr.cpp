// Steady-state LQR gain via the structured doubling algorithm (SDA) for the DARE.
//
// Why SDA rather than iterating the Riccati recursion X <- A'XA - ... + Qx: the
// recursion converges only linearly, at the rate of the closed-loop spectral radius
// squared, which is painfully slow for lightly damped loops; SDA converges
// quadratically under the same assumptions ((A,B) stabilisable, (A,Qx) detectable)
// and needs only n x n solves. Reference: E. K.-W. Chu, H.-Y. Fan, W.-W. Lin,
// "A structure-preserving doubling algorithm for continuous-time algebraic Riccati
// equations", and its discrete-time form (Lin & Xu, SIAM J. Matrix Anal. Appl. 2006):
//   A_{k+1} = A_k (I + G_k H_k)^{-1} A_k
//   G_{k+1} = G_k + A_k (I + G_k H_k)^{-1} G_k A_k'
//   H_{k+1} = H_k + A_k' H_k (I + G_k H_k)^{-1} A_k,
// started at A_0 = A, G_0 = B Ru^{-1} B', H_0 = Qx; H_k -> X (the stabilising solution).
// The result is checked afterwards (residual and Schur stability of A - B L), so a
// failure of the assumptions can never slip through as a wrong gain.
#include "netkf/theory/lqr.hpp"

#include <cmath>
#include <complex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "netkf/theory/riccati.hpp"

namespace netkf::theory {
namespace {

std::string shape(const Matrix& M) {
  return std::to_string(M.rows()) + "x" + std::to_string(M.cols());
}

[[noreturn]] void fail(const std::string& what) { throw std::invalid_argument("lqr: " + what); }

// "%g": a residual of 3e-07 is not "0.000000".
std::string g_text(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

double scale_of(const Matrix& M) { return std::max(1.0, M.cwiseAbs().maxCoeff()); }

void check_symmetric(const Matrix& M, const char* name) {
  if ((M - M.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale_of(M)) fail(std::string(name) + " is not symmetric");
}

double smallest_eigenvalue(const Matrix& M) {
  Eigen::SelfAdjointEigenSolver<Matrix> es(0.5 * (M + M.transpose()), Eigen::EigenvaluesOnly);
  return es.eigenvalues().minCoeff();
}

// Popov-Belevitch-Hautus tests on the modes of A with |mu| >= 1:
// stabilisable iff rank [A - mu I, B] = n, detectable iff rank [A - mu I; Qx] = n.
void check_pbh(const Matrix& A, const Matrix& B, const Matrix& Qx) {
  using CMatrix = Eigen::MatrixXcd;
  const Eigen::Index n = A.rows();
  const auto eig = Eigen::EigenSolver<Matrix>(A, false).eigenvalues();
  const double tol = 1e-10 * std::max(scale_of(A), std::max(scale_of(B), scale_of(Qx)));
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::complex<double> mu = eig(i);
    if (std::abs(mu) < 1.0 - 1e-12) continue;  // stable modes need neither control nor weight
    const CMatrix shifted = A.cast<std::complex<double>>() - mu * CMatrix::Identity(n, n);
    CMatrix reach(n, n + B.cols());
    reach << shifted, B.cast<std::complex<double>>();
    const double s_reach = Eigen::JacobiSVD<CMatrix>(reach).singularValues()(n - 1);
    std::ostringstream m;
    m << mu.real();
    if (mu.imag() != 0.0) m << (mu.imag() > 0 ? "+" : "") << mu.imag() << "i";
    if (s_reach <= tol) fail("(A, B) is not stabilisable: the mode with eigenvalue " + m.str() + " cannot be controlled");
    CMatrix observe(2 * n, n);
    observe << shifted, Qx.cast<std::complex<double>>();
    const double s_obs = Eigen::JacobiSVD<CMatrix>(observe).singularValues()(n - 1);
    if (s_obs <= tol)
      fail("(A, Qx) is not detectable: the mode with eigenvalue " + m.str() + " has no weight in Qx");
  }
}

// The arguments of the Riccati equations: shapes, finiteness, symmetry, definiteness, PBH.
void check_arguments(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru) {
  const Eigen::Index n = A.rows();
  if (n == 0 || A.cols() != n) fail("A must be square and non-empty, got " + shape(A));
  if (B.rows() != n || B.cols() == 0) fail("B must be " + std::to_string(n) + "xp with p >= 1, got " + shape(B));
  const Eigen::Index p = B.cols();
  if (Qx.rows() != n || Qx.cols() != n) fail("Qx must be " + shape(A) + ", got " + shape(Qx));
  if (Ru.rows() != p || Ru.cols() != p)
    fail("Ru must be " + std::to_string(p) + "x" + std::to_string(p) + ", got " + shape(Ru));
  if (!A.allFinite() || !B.allFinite() || !Qx.allFinite() || !Ru.allFinite()) fail("non-finite entry in A, B, Qx or Ru");
  check_symmetric(Qx, "Qx");
  check_symmetric(Ru, "Ru");
  if (smallest_eigenvalue(Qx) < -1e-10 * scale_of(Qx)) fail("Qx is not positive semidefinite");
  if (smallest_eigenvalue(Ru) <= 1e-12 * scale_of(Ru)) fail("Ru is not positive definite");
  check_pbh(A, B, Qx);
}

}  // namespace

Matrix solve_dare(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru) {
  check_arguments(A, B, Qx, Ru);
  const Eigen::Index n = A.rows();
  const Matrix I = Matrix::Identity(n, n);
  Matrix Ak = A;
  Matrix G = B * Ru.ldlt().solve(B.transpose());
  G = 0.5 * (G + G.transpose());
  Matrix H = 0.5 * (Qx + Qx.transpose());
  bool converged = false;
  for (int it = 0; it < 200 && !converged; ++it) {
    const Eigen::PartialPivLU<Matrix> W(I + G * H);  // I + G H is nonsingular for G, H PSD
    const Matrix W_A = W.solve(Ak);
    const Matrix W_G = W.solve(G);
    Matrix H_next = H + Ak.transpose() * H * W_A;
    Matrix G_next = G + Ak * W_G * Ak.transpose();
    Ak = Ak * W_A;
    H_next = 0.5 * (H_next + H_next.transpose());
    G = 0.5 * (G_next + G_next.transpose());
    if (!H_next.allFinite() || !G.allFinite() || !Ak.allFinite()) fail("Riccati doubling iteration diverged");
    const double change = (H_next - H).norm();
    H = std::move(H_next);
    converged = change <= 1e-14 * std::max(1.0, H.norm()) || Ak.norm() <= 1e-300;
  }
  if (!converged) fail("Riccati doubling iteration did not converge in 200 steps");
  return H;
}

Matrix lqr_gain(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru) {
  const Matrix X = solve_dare(A, B, Qx, Ru);
  const Matrix BtX = B.transpose() * X;
  const Matrix S = Ru + BtX * B;                 // Ru + B'XB, PD because Ru is
  const Matrix L = S.ldlt().solve(BtX * A);      // (Ru + B'XB)^{-1} B'XA
  // Verify instead of trusting the iteration: residual of the DARE and closed-loop stability.
  const Matrix residual = A.transpose() * X * A - (BtX * A).transpose() * L + Qx - X;
  if (!L.allFinite() || residual.norm() > 1e-8 * std::max(1.0, X.norm()))
    fail("Riccati solution does not satisfy the DARE (relative residual " +
         g_text(residual.norm() / std::max(1.0, X.norm())) + ")");
  const double rho = spectral_radius(A - B * L);
  if (!(rho < 1.0)) fail("closed loop A - B L is not Schur stable (spectral radius " + g_text(rho) + ")");
  return L;
}


std::optional<Matrix> solve_lossy_dare(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru,
                                       double arrival_rate) {
  if (!(arrival_rate >= 0.0 && arrival_rate <= 1.0))
    fail("the arrival rate must be in [0, 1], got " + g_text(arrival_rate));
  if (arrival_rate == 1.0) return solve_dare(A, B, Qx, Ru);
  check_arguments(A, B, Qx, Ru);
  // Duality: with A → A', C → B', Q → Qx, R → Ru the estimator's g_ν(X) = A X A' + Q
  // − ν A X C'(C X C' + R)^{-1} C X A' is this equation's right-hand side; "no inputs
  // arrive" is the empty pattern, "the input arrives" the pattern with C = B'.
  std::vector<ArrivalPattern> patterns;
  if (arrival_rate < 1.0) patterns.push_back({{}, 1.0 - arrival_rate, Matrix(0, A.rows()), Matrix(0, 0)});
  if (arrival_rate > 0.0) patterns.push_back({{0}, arrival_rate, B.transpose(), Ru});
  const UpperBound S = expected_covariance_upper_bound(A.transpose(), Qx, patterns);
  if (S.status == BoundStatus::unbounded) return std::nullopt;
  if (S.status == BoundStatus::undecided)
    fail("the Riccati equation for arrival rate " + g_text(arrival_rate) + " was neither solved nor shown unsolvable in " +
         std::to_string(S.iterations) + " iterations (the rate is within a hair of its critical value)");
  return 0.5 * (S.V + S.V.transpose());
}

Matrix lossy_lqr_gain(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru, double arrival_rate) {
  if (arrival_rate == 1.0) return lqr_gain(A, B, Qx, Ru);
  const auto S = solve_lossy_dare(A, B, Qx, Ru, arrival_rate);
  if (!S)
    fail("no gain is optimal (or mean-square stabilising) when inputs arrive at rate " + g_text(arrival_rate) +
         ": the Riccati equation S = A'SA + Qx - rate A'SB(B'SB + Ru)^-1 B'SA has no solution (the rate is at or "
         "below the critical rate of the optimal controller, Schenato et al. 2007)");
  const Matrix BtS = B.transpose() * *S;
  const Matrix L = (Ru + BtS * B).ldlt().solve(BtS * A);
  if (!L.allFinite()) fail("the gain for arrival rate " + g_text(arrival_rate) + " is not finite");
  return L;
}

}  // namespace netkf::theory
