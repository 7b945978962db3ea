#include "netkf/nodes/gaussian.hpp"

#include <Eigen/Eigenvalues>

namespace netkf::nodes {

GaussianSampler::GaussianSampler(const Matrix& covariance, std::uint64_t seed) : rng_(seed) {
  // Symmetric square root V sqrt(D): works for PSD (singular) covariances, unlike Cholesky.
  const Eigen::SelfAdjointEigenSolver<Matrix> eig(0.5 * (covariance + covariance.transpose()));
  const Vector d = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  root_ = eig.eigenvectors() * d.asDiagonal();
}

Vector GaussianSampler::draw() {
  Vector z(root_.cols());
  for (Eigen::Index i = 0; i < z.size(); ++i) z(i) = rng_.standard_normal();
  return root_ * z;
}

}  // namespace netkf::nodes
