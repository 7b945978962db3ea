#pragma once
// `netkf launch`: one run of a scenario's network (or of this host's part of it), in five
// steps — prepare (inputs, private files, the network's window), start (the domain guard,
// then the children of the launch plan), serve (supervise, record, show, until the run
// ends), stop (children, recording, presence), conclude (verdict, checks, exit status).
// Errors of the user's input are CommandError(bad_usage) before anything starts; a run
// that fails ends in order and then throws CommandError(run_failed) with the reason.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "netkf/cli/dashboard/dashboard_server.hpp"  // kDefaultMaxConnections
#include "netkf/cli/live/live_bus.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::cli {

/// Sensors a live network runs at most (the largest measured to run: BENCHMARKS.md).
/// The channel's link status topic holds one instance per link: dds::topics::kMaxLinks, this and
/// the actuation link.
inline constexpr std::size_t kMaxLiveSensors = 4096;

struct LaunchOptions {
  std::optional<std::string> scenario;
  double duration = 0.0;  // 0: until Ctrl-C
  std::optional<std::string> record;
  std::optional<std::string> record_samples;
  std::optional<std::string> mcap_profile;  // --mcap-profile json|ros2 (--record FILE.mcap only)
  std::optional<std::string> events;  // replay: an events file (what --record journaled)
  NetworkSettings network;
  std::string log_level = "warn";
  std::string restart_policy = "restart";
  int max_restarts = 3;
  std::string sensors_per_process = "auto";  // "auto" or a positive integer
  int sensor_nice = 0;
  double status_interval = 1.0;
  std::optional<std::string> pid_file;
  std::string dashboard = "8470";  // port, or "off"
  std::optional<std::string> dashboard_bind;
  std::vector<std::string> dashboard_allow_origins;
  std::size_t dashboard_max_connections = kDefaultMaxConnections;
  std::vector<std::string> checks;  // "NAME<VALUE", evaluated at the end of the run
  std::optional<std::string> summary;
  double domain_check = 1.5;  // seconds to look for another network on the domain before starting
  std::string only = "all";   // --only: the roles this launch runs (LaunchRoles)
  std::optional<std::uint64_t> run_id;         // --run-id: shared by every host's launch
  std::optional<std::string> serve_discovery;  // --serve-discovery ADDR:PORT
  double ready_timeout = 30.0;  // the plant's wait for the whole network (presence)
  bool allow_divergence = false;  // a closed loop leaving plant.state_bound ends the run with exit 0
  bool standby = false;           // a hot-standby estimator beside the primary
  bool warm_spares = true;        // --no-warm-spares: restarts start fresh processes
};

/// The scenario file (or the built-in default); CommandError(bad_usage) when it is invalid.
Scenario load_or_default(const std::optional<std::string>& file);

class Recording;
class LaunchRun;

/// Handlers that feed a recording only (`netkf record`); `invalid` counts the rejected samples.
BusHandlers recording_handlers(Recording& recording, std::uint64_t& invalid);

/// One launch. Its parts (the plan, the supervisor, the console, the recording, the bus, the
/// private files) are the room's own: `LaunchRun` (cli/launch/launch_run.hpp) holds them.
class Launch {
 public:
  explicit Launch(LaunchOptions options);
  ~Launch();
  Launch(const Launch&) = delete;
  Launch& operator=(const Launch&) = delete;

  /// The whole run; returns 0 or throws CommandError.
  int run();

 private:
  std::unique_ptr<LaunchRun> run_;
};

}  // namespace netkf::cli
