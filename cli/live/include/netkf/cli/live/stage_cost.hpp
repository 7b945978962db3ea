#pragma once
// The closed loop's stage cost x_k'Qx x_k + u_{k-1}'Ru u_{k-1} (the LQR weights, identities for
// a given gain; the input as the plant applied it), averaged over the run: the summary's `cost`
// and the dashboard's running cost are this one mean (docs/scenario-format.md, "plant.control").
#include <cstdint>
#include <optional>

#include "netkf/model/scenario.hpp"
#include "netkf/records/truth.hpp"

namespace netkf::cli {

class RunningCost {
 public:
  /// No cost (every add ignored): an open loop.
  RunningCost() = default;
  explicit RunningCost(const Scenario& scenario);
  /// Adds the truth's stage cost when its sizes fit the weights and it is finite.
  void add(const Truth& truth);
  /// The mean over the periods costed (nullopt: an open loop, or none yet).
  std::optional<double> mean() const;
  std::uint64_t periods() const { return periods_; }

 private:
  std::optional<Matrix> state_weight_;  // Qx (closed loop only)
  std::optional<Matrix> input_weight_;  // Ru
  double sum_ = 0.0;
  std::uint64_t periods_ = 0;
};

}  // namespace netkf::cli
