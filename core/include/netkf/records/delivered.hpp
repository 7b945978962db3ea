#pragma once
// A measurement the channel emulator delivered to the estimator (idl/netkf.idl, Measurement on
// the delivered topic), as recorders see it.
#include <cstdint>
#include <vector>

namespace netkf {

struct DeliveredMeasurement {
  int sensor_id = 0;
  std::int64_t k = 0;
  double stamp = 0.0;  // the sensor's publish stamp, seconds
  std::vector<double> y;
};

}  // namespace netkf
