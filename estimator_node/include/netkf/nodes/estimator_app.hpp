#pragma once
// The estimator node's DDS wiring (docs/architecture.md, "estimator_node"): reads the plant's
// ticks and the delivered samples, fuses each period through EstimatorCore, publishes the
// estimate and (closed loop) the control input. Constructed from its options on a participant;
// run() serves until stop() (from any thread, e.g. a signal handler's). The integration tests
// run it in process (tests/integration/test_estimator_app.cpp); main.cpp only parses flags.
//
// Threads: delivered samples are handled on the DDS receive thread (bookkeeping, and the fused
// update when a sample completes its period: microseconds, and a hand-off would add a context
// switch per sample to the latency; see endpoints.hpp). Ticks, the deadline and the status log
// run on the io thread, which owns the timers. One mutex guards the estimator core.
// With late_policy fuse_within a late sample is only stored on the receive thread; the re-run
// it calls for (up to D + 1 fused updates, BENCHMARKS.md "Late-sample re-run") is posted to the io
// thread, which publishes the revised estimates. (If a sample completes its period before
// that post runs, the receive thread re-runs first: the in-time estimate must include it.)
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "netkf/dds/participant.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/nodes/estimator_core.hpp"

namespace netkf::nodes {

struct EstimatorAppOptions {
  /// Log a summary line this often.
  int status_period_ms = 10000;
  /// Continue from the last estimate a previous life published (a restart) instead of the scenario's prior.
  std::optional<Estimate> resume;
  /// Ownership strength of its estimate and control writers (exclusive ownership, topics.hpp):
  /// of several estimators (a hot standby), the plant and every reader take the strongest live
  /// one's; an estimator whose io thread asserted nothing for dds::kOwnershipLease counts as
  /// gone (a standby takes over, a restarted estimator is not held off by its dead predecessor).
  std::uint32_t ownership_strength = 1000000;
};

/// What the estimator did so far (for its summary line and for tests).
struct EstimatorAppStats {
  std::uint64_t published = 0;         // estimates written, revisions included
  std::uint64_t revisions = 0;         // of those, revised estimates (late_policy fuse_within)
  std::uint64_t late_fused_total = 0;  // late samples fused into revisions
  std::optional<std::uint64_t> last_fused_period;
  std::uint64_t late_total = 0;
  std::uint64_t rejected_total = 0;
  std::uint32_t restarts = 0;
  FilterState state = FilterState::ok;
};

class EstimatorApp {
 public:
  /// Throws (std::invalid_argument, DdsError) when the scenario or checkpoint cannot be run.
  EstimatorApp(const Scenario& scenario, dds::Participant& participant, EstimatorAppOptions options = {});
  ~EstimatorApp();
  EstimatorApp(const EstimatorApp&) = delete;
  EstimatorApp& operator=(const EstimatorApp&) = delete;

  /// Serve until stop(). Call once.
  void run();
  /// End run() soon (thread-safe; idempotent).
  void stop();
  /// The io_context run() serves (for a signal_set in main).
  boost::asio::io_context& io();

  EstimatorAppStats stats() const;
  /// Whether the estimate writer has matched n readers: the topic keeps nothing for late
  /// joiners, so a test that must see the first estimate waits on this first.
  bool wait_for_estimate_readers(int n, std::chrono::milliseconds timeout) const;
  /// One line: estimates published, last period, late, rejected, state.
  void log_summary() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace netkf::nodes
