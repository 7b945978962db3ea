#pragma once
// The channel emulator's DDS wiring (docs/architecture.md, "channel_emulator"): relays raw
// measurements to the delivered topic through one link per sensor (Bernoulli or Gilbert-Elliott
// loss, then an optional delay, seeded from the scenario), applies the scenario's timeline and
// the changes from netkf/link/control from a period's first sample on, journals every change on
// netkf/link/change, and publishes link status about once a second and after every change
// (transient-local, so late joiners see it). Constructed from its options on a participant;
// run() serves until stop(), then publishes the final status. The integration tests run it in
// process (tests/integration/test_node_apps.cpp); main.cpp only parses flags.
//
// Threads: samples are decided and relayed on the DDS receive thread (one draw and a write:
// cheaper than the context switch of a hand-off, see endpoints.hpp); a delayed sample goes
// into the release queue, which the io thread's timer empties at each release time. Link
// changes and status run on the io thread. One mutex guards the links and the queue.
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <cstdint>
#include <memory>
#include <vector>

#include "netkf/dds/participant.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/nodes/channel_links.hpp"

namespace netkf::nodes {

struct ChannelAppOptions {
  /// Publish link status this often.
  int status_period_ms = 1000;
  /// Readers of the delivered samples (estimators, the launch's recorder) to wait for, bounded,
  /// before saying it is present; 0: present at once.
  int delivered_readers = 0;
};

/// What the channel did so far (for its summary lines and for tests).
struct ChannelAppStats {
  std::vector<LinkStatus> links;
  std::uint64_t held = 0;             // delayed samples waiting for their release
  std::uint64_t unknown_sensor_samples = 0;
  int delivered_readers = 0;          // readers matched by both delivered writers, single and batch (estimator, recorders)
  std::uint64_t raw_batches = 0;      // batches received from sensor processes of several sensors
};

class ChannelApp {
 public:
  /// Logs each link (and the timeline). Throws (std::invalid_argument, DdsError) when the
  /// scenario cannot be run.
  ChannelApp(const Scenario& scenario, dds::Participant& participant, ChannelAppOptions options = {});
  ~ChannelApp();
  ChannelApp(const ChannelApp&) = delete;
  ChannelApp& operator=(const ChannelApp&) = delete;

  /// Serve until stop(); then publish the final status (for late joiners) and wait (bounded)
  /// for its acknowledgement. Call once.
  void run();
  /// End run() soon (thread-safe; idempotent).
  void stop();
  /// The io_context run() serves (for a signal_set in main).
  boost::asio::io_context& io();

  ChannelAppStats stats() const;
  /// One line per link: samples in, delivered, dropped, observed loss, mean burst.
  void log_summary() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace netkf::nodes
