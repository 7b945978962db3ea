#pragma once
// The plant node's DDS wiring (docs/architecture.md, "plant_node"): the stand-in for the
// physical world. Each period T it steps x_{k+1} = A x_k + B u_k + w_k and publishes the truth
// (netkf/truth) and the sample clock with the applied input (netkf/tick). Constructed from its
// options on a participant; run() waits (bounded) for its subscribers, then steps until the last
// period (max_periods, or the state bound) or stop(). The integration tests run it in process
// (tests/integration/test_node_apps.cpp); main.cpp only parses flags.
//
// Threads: everything runs on the io thread. The period is driven by an absolute-deadline
// steady_timer (t_k = t_0 + k T), so periods do not drift. Control inputs are posted there from
// the DDS receive thread. The start-up wait for subscribers polls on the io thread's timer too,
// never blocking it, so a signal (SIGINT/SIGTERM on the same io_context) ends the wait at once.
// A mutex guards the simulator only for stats() from other threads.
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <cstdint>
#include <memory>

#include "netkf/dds/participant.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::nodes {

struct PlantAppOptions {
  /// Stop after this many periods (0 = unlimited); the last tick says so (final_tick).
  std::uint64_t max_periods = 0;
  /// Wait at most this long for the sensors and the estimator to match before period 0.
  int startup_wait_ms = 10000;
  /// Truth readers to wait for before period 0 (< 0: one per sensor of the scenario). With
  /// wait_for_presence, at least this many (those its launch knows of) and every present one.
  int truth_readers = -1;
  /// Tick readers to wait for before period 0: the estimators (2 with a hot standby).
  int tick_readers = 1;
  /// Start only when presence (netkf/presence) shows every sensor of the scenario, the channel
  /// and the estimator of this run, and the truth has matched every present process that reads
  /// it. Past startup_wait_ms, or when a process of this run loaded another scenario, run()
  /// throws naming what is missing (never a run without its readers). `netkf launch` sets it.
  bool wait_for_presence = false;
  /// After the wait: matching the plant's writers does not mean the sensors already match the
  /// channel, etc., so period 0 waits this much longer.
  int settle_ms = 500;
};

/// What the plant did so far (for its summary line and for tests).
struct PlantAppStats {
  std::uint64_t periods = 0;          // periods stepped
  std::uint64_t missing_inputs = 0;   // control inputs missing at their step
  std::uint64_t stale_inputs = 0;     // of which arrived late
  bool finished = false;              // the run ended on its own (max periods or state bound)
  std::uint64_t clock_reanchored = 0;  // times the plant fell more than a period behind its clock
  std::uint64_t periods_behind = 0;    // periods it fell behind in all (not replayed)
};

class PlantApp {
 public:
  /// Throws (std::invalid_argument, DdsError) when the scenario cannot be run.
  PlantApp(const Scenario& scenario, dds::Participant& participant, PlantAppOptions options = {});
  ~PlantApp();
  PlantApp(const PlantApp&) = delete;
  PlantApp& operator=(const PlantApp&) = delete;

  /// Wait for the subscribers, then step until the last period or stop(). Call once. Throws
  /// std::runtime_error when wait_for_presence is set and the network did not come together.
  void run();
  /// End run() soon (thread-safe; idempotent).
  void stop();
  /// The io_context run() serves (for a signal_set in main).
  boost::asio::io_context& io();

  PlantAppStats stats() const;
  /// One line: periods stepped, control inputs missing (and late).
  void log_summary() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace netkf::nodes
