#pragma once
// The estimator's output for one period: the one estimate type every layer passes along
// (the estimator core fills it, dds/ converts it to and from the wire, the CLI records,
// shows and checkpoints it). Field names follow the wire type (idl/netkf.idl).
#include <cstdint>
#include <vector>

#include "netkf/filter/kalman_filter.hpp"
#include "netkf/support/types.hpp"

namespace netkf {

struct Estimate {
  std::uint64_t k = 0;
  std::uint32_t revision = 0;     // 0: the in-time estimate of k (published once, at its deadline);
                                  // n > 0: its n-th correction after late samples were fused (late_policy fuse_within)
  double t = 0.0;                 // t_k = k·period, seconds
  Vector x_hat;                   // x̂_{k|k}
  Matrix P;                       // P_{k|k}
  double trace_P_pred = 0.0;      // Tr P_{k|k-1}: what the theory's bounds S̄, V̄ bound (Sinopoli Thm 4/6)
  std::vector<int> fused;         // sensor ids fused for k (sorted)
  std::uint32_t late = 0;         // late samples counted since the previous published estimate (never fused)
  std::vector<int> late_sensors;  // their sensor ids, one entry per late sample (late == its size)
  std::vector<std::uint64_t> late_periods;  // the period each of them was for (same order and size)
  std::uint64_t late_total = 0;   // running totals of the run
  std::uint64_t rejected_total = 0;
  FilterState state = FilterState::ok;
  std::uint32_t restarts = 0;     // times this run's estimator was restarted from its last estimate
  std::int64_t fused_at_ns = 0;   // steady clock of the estimator when k was fused
  std::int64_t stamp_ns = 0;      // ... when it was published (0: not yet)
  std::int64_t last_sample_stamp_ns = 0;  // newest sensor publish stamp among the fused samples (0: none)

  double trace_P() const { return P.trace(); }  // Tr P_{k|k}
  /// From the newest fused sample's publication to this estimate's, seconds (none: no sample fused).
  bool has_pipeline_latency() const { return last_sample_stamp_ns > 0 && stamp_ns > 0; }
  double pipeline_latency_s() const { return static_cast<double>(stamp_ns - last_sample_stamp_ns) * 1e-9; }
};

}  // namespace netkf
