#pragma once
// Zero-mean Gaussian vectors with a given covariance, drawn from a seeded netkf::Rng
// (process noise w_k ~ N(0, Q), sensor noise v_k ~ N(0, R), initial state x_0 ~ N(x0, P0)).
#include <cstdint>

#include "netkf/random.hpp"
#include "netkf/types.hpp"

namespace netkf::nodes {

class GaussianSampler {
 public:
  /// `covariance` must be symmetric positive semidefinite (checked by the scenario loader);
  /// a PSD square root is used so singular Q (e.g. noise on some states only) works.
  GaussianSampler(const Matrix& covariance, std::uint64_t seed);
  /// One draw S z with z ~ N(0, I) and S S' = covariance.
  Vector draw();
  int dim() const { return static_cast<int>(root_.rows()); }

 private:
  Matrix root_;
  Rng rng_;
};

}  // namespace netkf::nodes
