#pragma once
// The plant's ground truth of one period (idl/netkf.idl, Truth): what the sensors measure and
// recorders score estimates against.
#include <cstdint>
#include <vector>

namespace netkf {

struct Truth {
  std::int64_t k = 0;
  double t = 0.0;             // t_k, seconds
  std::vector<double> x;      // x_k
  std::vector<double> u;      // closed loop: the input u_{k-1} the plant applied to produce x_k (else empty)
  bool input_arrived = true;  // ν_{k-1}: u_{k-1} reached the plant in time (true at k = 0 and in an open loop)
};

}  // namespace netkf
