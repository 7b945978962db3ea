#pragma once
// The plant (docs/architecture.md, "plant_node"): x_{k+1} = A x_k + B u_k + w_k, w_k ~ N(0, Q),
// x_0 ~ N(x0, P0) (Sinopoli eq. 1; the estimator's prior is x̂_{0|-1} = x0, P_{0|-1} = P0).
// No DDS, no clock: the node calls step() once per period.
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "netkf/model/scenario.hpp"
#include "netkf/support/gaussian.hpp"

namespace netkf::nodes {

/// What the plant publishes for period k.
struct PlantStep {
  std::uint64_t k = 0;
  double t = 0.0;          // t_k = k * period (seconds since scenario start)
  Vector x;                // x_k
  Vector applied_input;    // u_{k-1} applied to produce x_k (empty without control; zeros at k = 0)
  bool input_missing = false;  // no input for k-1 had arrived (ν_{k-1} = 0): zero or the last one was applied
  std::uint64_t inputs_missing_in_a_row = 0;  // periods up to this one stepped without their input
  bool bound_exceeded = false; // |x_k|_inf > plant.state_bound: the run must end
};

class PlantSimulator {
 public:
  /// Random streams: derive_seed(seed, "initial-state") and derive_seed(seed, "process-noise").
  explicit PlantSimulator(const Scenario& scenario);

  bool closed_loop() const { return B_.has_value(); }
  int input_dim() const { return B_ ? static_cast<int>(B_->cols()) : 0; }

  /// Record the controller's input u_k for period k (applied when stepping to k+1).
  /// Inputs for periods already stepped past are stale and ignored (returns false);
  /// wrong size or non-finite values are rejected (returns false, `why` says why).
  bool set_input(std::uint64_t k, const Vector& u, std::string* why = nullptr);

  /// The first call returns period 0 (x_0); each later call advances one period.
  /// A missing input u_{k-1} is taken as zero, or with plant.control.on_loss hold as the input
  /// applied at the previous step (zero before any arrived), and the step says so; the applied
  /// input is always reported (the acknowledgement).
  PlantStep step();

  std::uint64_t next_period() const { return next_k_; }
  std::uint64_t missing_inputs() const { return missing_inputs_; }
  std::uint64_t stale_inputs() const { return stale_inputs_; }
  /// Periods stepped without their control input since the last one that had it.
  std::uint64_t inputs_missing_in_a_row() const { return missing_in_a_row_; }
  const Vector& state() const { return x_; }

 private:
  Matrix A_;
  std::optional<Matrix> B_;
  double period_s_;
  double state_bound_;
  Vector x_;
  GaussianSampler initial_;
  GaussianSampler process_noise_;
  std::map<std::uint64_t, Vector> inputs_;  // u_k by k, for k >= next_k_ - 1
  OnLoss on_loss_ = OnLoss::zero;
  Vector last_applied_;  // the input applied at the previous step
  std::uint64_t next_k_ = 0;
  std::uint64_t missing_inputs_ = 0;
  std::uint64_t stale_inputs_ = 0;
  std::uint64_t missing_in_a_row_ = 0;
};

}  // namespace netkf::nodes
