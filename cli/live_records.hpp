#pragma once
// What the live commands (launch, record, ctl) see of the network, in plain C++:
// filled from the DDS library's types in one adapter (live_bus.cpp), consumed by the
// recorder and the status view, which therefore need no DDS to be tested.
#include <cstdint>
#include <string>
#include <vector>

namespace netkf::cli {

/// Ground truth x_k of period k at time t_k (from the plant).
struct TruthRecord {
  std::int64_t k = 0;
  double t = 0.0;
  std::vector<double> x;
};

/// The estimator's output for period k: x̂_{k|k}, P_{k|k} (row-major) and bookkeeping.
struct EstimateRecord {
  std::int64_t k = 0;
  double t = 0.0;
  std::vector<double> xhat;
  std::vector<double> P;       // n*n, row-major (may be empty if not carried)
  double trace_P = 0.0;
  std::vector<int> fused;      // sensor ids fused for k (sorted)
  std::uint32_t late = 0;      // samples that arrived during k for periods already fused
  std::uint32_t rejected = 0;
  std::string state;           // "ok" / "diverging"
  double publish_stamp = 0.0;  // seconds (clock of the estimator)
};

/// A measurement the channel delivered to the estimator.
struct DeliveredRecord {
  int sensor_id = 0;
  std::int64_t k = 0;
  double stamp = 0.0;          // sensor publish stamp, seconds
  std::vector<double> y;
};

/// One link of the channel emulator, as it last reported itself.
struct LinkStatusRecord {
  int sensor_id = 0;
  std::string model;           // "bernoulli" / "gilbert_elliott"
  std::vector<double> params;  // bernoulli: {loss}; GE: {p, r, loss_good, loss_bad}
  std::uint64_t samples_in = 0;
  std::uint64_t delivered = 0;
  std::uint64_t dropped = 0;
  double observed_loss = 0.0;
  double mean_burst_length = 0.0;
  std::uint64_t last_request_id = 0;
  std::string rejection_reason;  // empty when the last request was applied
};

/// The channel's answer to one link change request.
struct LinkReplyRecord {
  std::uint64_t request_id = 0;
  int sensor_id = 0;
  bool applied = false;
  std::string reason;
};

}  // namespace netkf::cli
