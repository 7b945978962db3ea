#include "netkf/nodes/sensor_simulator.hpp"

#include <stdexcept>

namespace netkf::nodes {

namespace {
const SensorSpec& find_or_throw(const Scenario& scenario, int sensor_id) {
  const SensorSpec* s = scenario.find_sensor(sensor_id);
  if (s == nullptr) {
    throw std::invalid_argument("scenario '" + scenario.name + "' has no sensor with id " + std::to_string(sensor_id));
  }
  return *s;
}
}  // namespace

SensorSimulator::SensorSimulator(const Scenario& scenario, int sensor_id)
    : id_(sensor_id),
      C_(find_or_throw(scenario, sensor_id).C),
      noise_(find_or_throw(scenario, sensor_id).R,
             derive_seed(scenario.seed, "sensor-noise", static_cast<std::uint64_t>(sensor_id))) {}

std::optional<Vector> SensorSimulator::measure(std::uint64_t k, const Vector& x, std::string* why) {
  auto skip = [&](const std::string& reason) -> std::optional<Vector> {
    ++skipped_;
    if (why != nullptr) *why = reason;
    return std::nullopt;
  };
  if (x.size() != C_.cols()) {
    return skip("truth for period " + std::to_string(k) + " has " + std::to_string(x.size()) + " values, expected " +
                std::to_string(C_.cols()));
  }
  if (!x.allFinite()) return skip("truth for period " + std::to_string(k) + " is not finite");
  if (last_k_ && k <= *last_k_) {
    return skip("truth for period " + std::to_string(k) + " is not after the last measured period " +
                std::to_string(*last_k_));
  }
  last_k_ = k;
  ++measured_;
  return Vector(C_ * x + noise_.draw());
}

}  // namespace netkf::nodes
