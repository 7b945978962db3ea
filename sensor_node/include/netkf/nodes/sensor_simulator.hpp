#pragma once
// One sensor (docs/architecture.md, "sensor_node"): y_{i,k} = C_i x_k + v_{i,k}, v_{i,k} ~ N(0, R_i)
// (Liu-Goldsmith eq. 2 / multi-sensor paper eq. 2). It knows only its own C_i, R_i.
#include <cstdint>
#include <optional>
#include <string>

#include "netkf/model/scenario.hpp"
#include "netkf/support/gaussian.hpp"

namespace netkf::nodes {

class SensorSimulator {
 public:
  /// Throws std::invalid_argument when the scenario has no sensor `sensor_id`.
  /// Noise stream: derive_seed(seed, "sensor-noise", sensor_id).
  SensorSimulator(const Scenario& scenario, int sensor_id);

  /// The sample for period k from the truth x_k. Returns nullopt (and `why`) for a truth of
  /// the wrong size, non-finite, or for a period not after the last one measured (a
  /// duplicate or reordered truth is not measured twice, so the noise stream stays aligned).
  std::optional<Vector> measure(std::uint64_t k, const Vector& x, std::string* why = nullptr);

  int id() const { return id_; }
  int output_dim() const { return static_cast<int>(C_.rows()); }
  std::uint64_t measured() const { return measured_; }
  std::uint64_t skipped() const { return skipped_; }

 private:
  int id_;
  Matrix C_;
  GaussianSampler noise_;
  std::optional<std::uint64_t> last_k_;
  std::uint64_t measured_ = 0;
  std::uint64_t skipped_ = 0;
};

}  // namespace netkf::nodes
