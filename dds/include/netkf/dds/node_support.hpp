#pragma once
#include <signal.h>
// What the nodes' DDS side shares: a warm spare's gate, the stop on a signal, the wait for
// readers to match, the discovery server's address (the mains' flags: node_main/run_node.hpp).
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "netkf/dds/participant.hpp"

namespace netkf::dds {

/// " (N more like it left out)" after a throttled warning (netkf::LogThrottle); "" for none.
inline std::string left_out_text(std::uint64_t left_out) {
  return left_out ? " (" + std::to_string(left_out) + " more like it left out)" : std::string();
}

/// Environment variable of the discovery server (as --discovery-server).
inline constexpr const char* kDiscoveryServerEnv = "NETKF_DISCOVERY_SERVER";
/// The discovery server: the flag when given (non-empty), else $NETKF_DISCOVERY_SERVER, else
/// nullopt (the localhost profile). Throws DdsError when it is not ADDR:PORT.
std::optional<DiscoveryServerAddress> resolve_discovery_server(const std::optional<std::string>& flag);

/// A warm spare (--spare; `netkf launch` keeps one per channel and estimator): the process
/// creates its DDS participant, so the network discovers it ahead of need, and waits before it
/// builds its node. SIGUSR1 makes it the node (a restart without a new participant to discover);
/// SIGINT/SIGTERM end it. Construct it first in main, before any thread exists: it blocks those
/// signals so that the wait takes them (sigwait) whichever thread they are sent to.
class SpareGate {
 public:
  explicit SpareGate(bool spare);
  ~SpareGate();
  SpareGate(const SpareGate&) = delete;
  SpareGate& operator=(const SpareGate&) = delete;
  /// Not a spare: true at once. A spare: wait for SIGUSR1 (true) or SIGINT/SIGTERM (false).
  bool wait_until_needed();

 private:
  bool spare_;
  bool restored_ = false;
  sigset_t previous_{};
};

/// SIGINT/SIGTERM end the node cleanly: `on_stop(signal)` runs on the io thread, then `io`
/// stops. Constructed before any blocking start-up wait so a signal then is not fatal.
class StopOnSignal {
 public:
  StopOnSignal(boost::asio::io_context& io, std::function<void(int)> on_stop = {});

 private:
  boost::asio::signal_set signals_;
};

/// Before a node says it is present (the plant starts period 0 when every process is), the
/// readers of its volatile topics must have matched its writers: a sample written before is lost
/// (e2e bernoulli once recorded no delivered sample of periods 0-4: the launch's reader matched
/// the channel's writer 200 ms after the run began). Polls `matched()` every 2 ms on the io
/// thread (a signal still stops the node) until it holds or `limit` passed, then calls
/// `then(matched)` once on the io thread. Destroying it cancels a wait in progress.
class WhenMatched {
 public:
  WhenMatched(boost::asio::io_context& io, std::function<bool()> matched, std::chrono::milliseconds limit,
              std::function<void(bool matched)> then);
  /// Waited so far (or in all, once `then` ran).
  std::chrono::milliseconds waited() const;

 private:
  void schedule(std::chrono::milliseconds after);
  void poll();
  boost::asio::steady_timer timer_;
  std::function<bool()> matched_;
  std::function<void(bool)> then_;
  std::chrono::steady_clock::time_point started_, deadline_;
  std::optional<std::chrono::steady_clock::time_point> ended_;
};

}  // namespace netkf::dds
