#include "netkf/nodes/plant_simulator.hpp"

namespace netkf::nodes {

PlantSimulator::PlantSimulator(const Scenario& scenario)
    : A_(scenario.plant.A),
      B_(scenario.plant.B),
      period_s_(scenario.period_s()),
      state_bound_(scenario.plant.state_bound),
      initial_(scenario.plant.P0, derive_seed(scenario.seed, "initial-state")),
      process_noise_(scenario.plant.Q, derive_seed(scenario.seed, "process-noise")) {
  if (scenario.plant.control) on_loss_ = scenario.plant.control->on_loss;
  if (B_) last_applied_ = Vector::Zero(B_->cols());
  const auto n = scenario.plant.A.rows();
  x_ = scenario.plant.x0.size() == n ? scenario.plant.x0 : Vector(Vector::Zero(n));
}

bool PlantSimulator::set_input(std::uint64_t k, const Vector& u, std::string* why) {
  auto fail = [&](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (!B_) return fail("the plant has no input (no plant.B in the scenario)");
  if (u.size() != B_->cols()) {
    return fail("input for period " + std::to_string(k) + " has " + std::to_string(u.size()) + " values, expected " +
                std::to_string(B_->cols()));
  }
  if (!u.allFinite()) return fail("input for period " + std::to_string(k) + " is not finite");
  // u_k is applied when stepping from k to k+1, i.e. in the step that produces period k+1.
  if (k + 1 < next_k_) {
    ++stale_inputs_;
    return fail("input for period " + std::to_string(k) + " arrived after the plant moved past it (stale)");
  }
  inputs_[k] = u;
  return true;
}

PlantStep PlantSimulator::step() {
  PlantStep s;
  s.k = next_k_;
  s.t = static_cast<double>(next_k_) * period_s_;
  Vector u;
  if (B_) u = Vector::Zero(B_->cols());
  if (next_k_ == 0) {
    x_ += initial_.draw();  // x_0 ~ N(x0, P0)
  } else {
    const std::uint64_t input_k = next_k_ - 1;
    if (B_) {
      if (auto it = inputs_.find(input_k); it != inputs_.end()) {
        u = it->second;
        missing_in_a_row_ = 0;
      } else {
        ++missing_inputs_;
        ++missing_in_a_row_;
        s.input_missing = true;
        if (on_loss_ == OnLoss::hold) u = last_applied_;  // the actuator keeps its last input
      }
      last_applied_ = u;
    }
    Vector next = A_ * x_ + process_noise_.draw();
    if (B_) next += *B_ * u;
    x_ = next;
    inputs_.erase(inputs_.begin(), inputs_.upper_bound(input_k));
  }
  s.x = x_;
  s.applied_input = u;
  s.inputs_missing_in_a_row = missing_in_a_row_;
  s.bound_exceeded = !x_.allFinite() || x_.lpNorm<Eigen::Infinity>() > state_bound_;
  ++next_k_;
  return s;
}

}  // namespace netkf::nodes
