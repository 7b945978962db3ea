// Expected-covariance maps and their bounds (see theory/riccati.hpp for the papers' equations).
#include "netkf/theory/riccati.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace netkf::theory {

Matrix kron(const Matrix& a, const Matrix& b) {
  Matrix out(a.rows() * b.rows(), a.cols() * b.cols());
  for (Eigen::Index i = 0; i < a.rows(); ++i)
    for (Eigen::Index j = 0; j < a.cols(); ++j)
      out.block(i * b.rows(), j * b.cols(), b.rows(), b.cols()) = a(i, j) * b;
  return out;
}

namespace {

Matrix symmetrised(const Matrix& m) { return 0.5 * (m + m.transpose()); }

// Optimal gain for pattern S at X (Sinopoli's K_X = −A X C'(C X C' + R)⁻¹, eq. before (29)).
Matrix optimal_gain(const Matrix& A, const ArrivalPattern& s, const Matrix& X) {
  if (s.C.rows() == 0) return Matrix::Zero(A.rows(), 0);
  const Matrix innovation = s.C * X * s.C.transpose() + s.R;
  // K' = −M⁻¹ C X A' (M symmetric positive definite).
  return -innovation.ldlt().solve(s.C * X * A.transpose()).transpose();
}

// Largest-magnitude eigenvalue of the positive linear map X ↦ Σ π_S F_S X F_S'.
double positive_map_radius(std::span<const ArrivalPattern> patterns, const std::vector<Matrix>& F) {
  const Eigen::Index n = F.front().rows();
  if (n <= 12) {
    Matrix L = Matrix::Zero(n * n, n * n);
    for (std::size_t i = 0; i < patterns.size(); ++i) L += patterns[i].probability * kron(F[i], F[i]);
    return Eigen::EigenSolver<Matrix>(L, false).eigenvalues().cwiseAbs().maxCoeff();
  }
  // Power iteration: the map is positive, so ρ is attained on the PSD cone (Krein-Rutman).
  Matrix X = Matrix::Identity(n, n);
  double rho = 0.0;
  for (int it = 0; it < 500; ++it) {
    Matrix Y = Matrix::Zero(n, n);
    for (std::size_t i = 0; i < patterns.size(); ++i) Y += patterns[i].probability * F[i] * X * F[i].transpose();
    const double t = Y.trace();
    if (!(t > 0.0) || !std::isfinite(t)) return t > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
    rho = t / X.trace();
    X = Y / t;
  }
  return rho;
}

}  // namespace

const char* to_string(BoundStatus status) {
  switch (status) {
    case BoundStatus::bounded: return "bounded";
    case BoundStatus::unbounded: return "unbounded";
    case BoundStatus::undecided: return "undecided";
  }
  return "?";
}

double spectral_radius(const Matrix& A) {
  if (A.size() == 0) return 0.0;
  return Eigen::EigenSolver<Matrix>(A, false).eigenvalues().cwiseAbs().maxCoeff();
}

std::vector<ArrivalPattern> independent_arrival_patterns(std::span<const SensorSpec> sensors,
                                                         std::span<const double> arrival_rates) {
  if (sensors.size() != arrival_rates.size())
    throw std::invalid_argument("arrival rates: expected " + std::to_string(sensors.size()) + " values, got " +
                                std::to_string(arrival_rates.size()));
  if (sensors.size() > 16) throw std::invalid_argument("arrival patterns: more than 16 sensors");
  for (double rate : arrival_rates)
    if (!(rate >= 0.0 && rate <= 1.0)) throw std::invalid_argument("arrival rate outside [0,1]");
  const std::size_t d = sensors.size();
  const Eigen::Index n = d == 0 ? 0 : sensors.front().C.cols();
  std::vector<ArrivalPattern> patterns;
  for (std::uint32_t mask = 0; mask < (1u << d); ++mask) {
    ArrivalPattern p;
    p.probability = 1.0;
    Eigen::Index m = 0;
    for (std::size_t i = 0; i < d; ++i) {
      const bool arrived = (mask >> i) & 1u;
      p.probability *= arrived ? arrival_rates[i] : 1.0 - arrival_rates[i];
      if (arrived) {
        p.sensor_indices.push_back(static_cast<int>(i));
        m += sensors[i].C.rows();
      }
    }
    if (p.probability <= 0.0) continue;
    p.C = Matrix::Zero(m, n);
    p.R = Matrix::Zero(m, m);
    Eigen::Index row = 0;
    for (int i : p.sensor_indices) {
      const auto& s = sensors[static_cast<std::size_t>(i)];
      p.C.middleRows(row, s.C.rows()) = s.C;
      p.R.block(row, row, s.R.rows(), s.R.cols()) = s.R;
      row += s.C.rows();
    }
    patterns.push_back(std::move(p));
  }
  return patterns;
}

double all_lost_probability(std::span<const double> arrival_rates) {
  double q = 1.0;
  for (double rate : arrival_rates) q *= 1.0 - rate;
  return q;
}

Matrix modified_riccati_map(const Matrix& A, const Matrix& C, const Matrix& Q, const Matrix& R,
                            double arrival_rate, const Matrix& X) {
  // Sinopoli eq. (17).
  const Matrix innovation = C * X * C.transpose() + R;
  const Matrix correction = A * X * C.transpose() * innovation.ldlt().solve(C * X * A.transpose());
  return symmetrised(A * X * A.transpose() + Q - arrival_rate * correction);
}

Matrix expected_riccati_map(const Matrix& A, const Matrix& Q, std::span<const ArrivalPattern> patterns,
                            const Matrix& X) {
  // Liu-Goldsmith eq. (12) over all patterns: Σ π_S = 1, so the A X A' + Q terms add up once.
  Matrix out = A * X * A.transpose() + Q;
  for (const auto& s : patterns) {
    if (s.C.rows() == 0) continue;
    const Matrix innovation = s.C * X * s.C.transpose() + s.R;
    out -= s.probability * (A * X * s.C.transpose()) * innovation.ldlt().solve(s.C * X * A.transpose());
  }
  return symmetrised(out);
}

std::optional<Matrix> lyapunov_lower_bound(const Matrix& A, const Matrix& Q, double q) {
  // S = q A S A' + Q has a PSD solution iff √q·A is stable (q α² < 1), Sinopoli Thm 3.
  const double alpha = spectral_radius(A);
  if (q * alpha * alpha >= 1.0) return std::nullopt;
  const Eigen::Index n = A.rows();
  if (q == 0.0) return Q;
  if (n <= 30) {
    const Matrix M = Matrix::Identity(n * n, n * n) - q * kron(A, A);
    const Vector s = M.partialPivLu().solve(Eigen::Map<const Vector>(Q.data(), n * n));
    return symmetrised(Eigen::Map<const Matrix>(s.data(), n, n));
  }
  // Larger systems: the Neumann series Σ q^k A^k Q A'^k (converges since q α² < 1).
  Matrix S = Q, term = Q;
  for (int k = 0; k < 100000; ++k) {
    term = q * A * term * A.transpose();
    S += term;
    if (term.norm() <= 1e-15 * S.norm()) break;
  }
  return symmetrised(S);
}

double linearised_spectral_radius(const Matrix& A, std::span<const ArrivalPattern> patterns, const Matrix& X) {
  std::vector<Matrix> F;
  F.reserve(patterns.size());
  for (const auto& s : patterns) {
    if (s.C.rows() == 0) F.push_back(A);
    else F.push_back(A + optimal_gain(A, s, X) * s.C);
  }
  return positive_map_radius(patterns, F);
}

UpperBound expected_covariance_upper_bound(const Matrix& A, const Matrix& Q,
                                           std::span<const ArrivalPattern> patterns,
                                           const UpperBoundOptions& options) {
  UpperBound result;
  const Eigen::Index n = A.rows();
  const double bound = options.divergence_trace * (1.0 + Q.trace());
  Matrix V = Matrix::Zero(n, n);
  bool certified = false;
  // Certificate checks cost an n²×n² eigenproblem: every iteration for small n, else sparser.
  const int check_every = n <= 3 ? 1 : 8;
  for (int it = 1; it <= options.max_iterations; ++it) {
    V = expected_riccati_map(A, Q, patterns, V);
    result.iterations = it;
    if (!V.allFinite() || V.trace() > bound) {
      result.status = BoundStatus::unbounded;
      result.V = V;
      return result;
    }
    if ((it % check_every == 0 || it < 4) && linearised_spectral_radius(A, patterns, V) < 1.0) {
      certified = true;
      break;
    }
  }
  if (!certified) {
    result.V = V;
    return result;  // undecided
  }
  // Replaces V by `next`; true once the relative change is below the tolerance.
  auto settle = [&](Matrix next) {
    const double change = (next - V).norm();
    V = std::move(next);
    return change <= options.tolerance * std::max(1.0, V.norm());
  };
  if (n > 30) {
    // Too large for the Kronecker solve: plain iteration (converges, Sinopoli Thm 1).
    for (int it = 0; it < options.max_iterations; ++it)
      if (settle(expected_riccati_map(A, Q, patterns, V))) break;
    result.status = BoundStatus::bounded;
    result.V = V;
    return result;
  }
  // Policy iteration: X_{j+1} solves X = Σ π_S (F_S X F_S' + Q + K_S R_S K_S') with the gains of X_j
  // (Sinopoli eq. (29) φ(K, X); Liu-Goldsmith eq. (16)). Monotone from above to V̄.
  const Matrix I = Matrix::Identity(n * n, n * n);
  for (int j = 0; j < 200; ++j) {
    Matrix L = Matrix::Zero(n * n, n * n);
    Matrix constant = Matrix::Zero(n, n);
    for (const auto& s : patterns) {
      if (s.C.rows() == 0) {
        L += s.probability * kron(A, A);
        constant += s.probability * Q;
        continue;
      }
      const Matrix K = optimal_gain(A, s, V);
      const Matrix F = A + K * s.C;
      L += s.probability * kron(F, F);
      constant += s.probability * (Q + K * s.R * K.transpose());
    }
    const Vector x = (I - L).partialPivLu().solve(Eigen::Map<const Vector>(constant.data(), n * n));
    Matrix next = symmetrised(Eigen::Map<const Matrix>(x.data(), n, n));
    if (!next.allFinite() || settle(std::move(next))) break;
  }
  result.status = BoundStatus::bounded;
  result.V = V;
  return result;
}

}  // namespace netkf::theory

namespace netkf::theory {

std::optional<Matrix> static_gain_covariance(const Matrix& A, const Matrix& C, const Matrix& Q, const Matrix& R,
                                             double arrival_rate, const Matrix& K) {
  const Eigen::Index n = A.rows();
  const Matrix F = A - K * C;
  const Matrix L = (1.0 - arrival_rate) * kron(A, A) + arrival_rate * kron(F, F);
  if (Eigen::EigenSolver<Matrix>(L, false).eigenvalues().cwiseAbs().maxCoeff() >= 1.0) return std::nullopt;
  const Matrix constant = Q + arrival_rate * K * R * K.transpose();
  const Vector x = (Matrix::Identity(n * n, n * n) - L).partialPivLu().solve(Eigen::Map<const Vector>(constant.data(), n * n));
  return symmetrised(Eigen::Map<const Matrix>(x.data(), n, n));
}

Matrix predictor_gain(const Matrix& A, const Matrix& C, const Matrix& R, const Matrix& X) {
  const Matrix innovation = C * X * C.transpose() + R;
  return innovation.ldlt().solve(C * X * A.transpose()).transpose();
}

}  // namespace netkf::theory
