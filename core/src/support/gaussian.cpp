#include "netkf/support/gaussian.hpp"

#include <Eigen/Eigenvalues>

namespace netkf {

Matrix psd_square_root(const Matrix& M) {
  const Eigen::SelfAdjointEigenSolver<Matrix> eig(0.5 * (M + M.transpose()));
  return eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
}

GaussianSampler::GaussianSampler(const Matrix& covariance, std::uint64_t seed)
    : root_(psd_square_root(covariance)), rng_(seed) {}

Vector GaussianSampler::draw() {
  Vector z(root_.cols());
  for (Eigen::Index i = 0; i < z.size(); ++i) z(i) = rng_.standard_normal();
  return root_ * z;
}

}  // namespace netkf
