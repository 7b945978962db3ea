#pragma once
// Zero-mean Gaussian vectors with a given covariance, drawn from a seeded netkf::Rng
// (process noise w_k ~ N(0, Q), sensor noise v_k ~ N(0, R), initial state x_0 ~ N(x0, P0)).
#include <cstdint>

#include "netkf/support/random.hpp"
#include "netkf/support/types.hpp"

namespace netkf {

/// A square root S with S S' = M of a symmetric positive semidefinite M: V sqrt(D) from the
/// eigendecomposition, so singular covariances (noise on some states only) work, unlike Cholesky.
Matrix psd_square_root(const Matrix& M);

class GaussianSampler {
 public:
  /// `covariance` must be symmetric positive semidefinite (checked by the scenario loader).
  GaussianSampler(const Matrix& covariance, std::uint64_t seed);
  /// One draw S z with z ~ N(0, I) and S S' = covariance.
  Vector draw();
  int dim() const { return static_cast<int>(root_.rows()); }

 private:
  Matrix root_;
  Rng rng_;
};

}  // namespace netkf
