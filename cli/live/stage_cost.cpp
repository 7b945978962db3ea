#include "netkf/cli/live/stage_cost.hpp"

#include <cmath>

namespace netkf::cli {

RunningCost::RunningCost(const Scenario& scenario) {
  const auto& control = scenario.plant.control;
  if (!control) return;
  const auto n = scenario.plant.A.rows();
  const auto m = scenario.plant.B ? scenario.plant.B->cols() : 0;
  state_weight_ = control->lqr_Qx.value_or(Matrix(Matrix::Identity(n, n)));
  input_weight_ = control->lqr_Ru.value_or(Matrix(Matrix::Identity(m, m)));
}

void RunningCost::add(const Truth& truth) {
  if (!state_weight_ || static_cast<Eigen::Index>(truth.x.size()) != state_weight_->rows() ||
      static_cast<Eigen::Index>(truth.u.size()) != input_weight_->rows())
    return;
  const Eigen::Map<const Vector> x(truth.x.data(), static_cast<Eigen::Index>(truth.x.size()));
  const Eigen::Map<const Vector> u(truth.u.data(), static_cast<Eigen::Index>(truth.u.size()));
  const double c = x.dot(*state_weight_ * x) + u.dot(*input_weight_ * u);
  if (!std::isfinite(c)) return;
  sum_ += c;
  ++periods_;
}

std::optional<double> RunningCost::mean() const {
  if (periods_ == 0) return std::nullopt;
  return sum_ / static_cast<double>(periods_);
}

}  // namespace netkf::cli
