#pragma once
// `netkf launch`: one run of a scenario's network (or of this host's part of it), in five
// steps — prepare (inputs, private files, the network's window), start (the domain guard,
// then the children of the launch plan), serve (supervise, record, show, until the run
// ends), stop (children, recording, presence), conclude (verdict, checks, exit status).
// Errors of the user's input are CommandError(bad_usage) before anything starts; a run
// that fails ends in order and then throws CommandError(run_failed) with the reason.
#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "netkf/cli/launch/console.hpp"
#include "netkf/cli/launch/launch_files.hpp"
#include "netkf/cli/launch/launch_plan.hpp"
#include "netkf/cli/launch/launch_supervisor.hpp"
#include "netkf/cli/launch/outage_watch.hpp"
#include "netkf/cli/launch/run_end_watch.hpp"
#include "netkf/cli/launch/run_verdict.hpp"
#include "netkf/cli/live/live_bus.hpp"
#include "netkf/cli/live/run_summary.hpp"
#include "netkf/cli/recording/recording.hpp"
#include "netkf/dds/participant.hpp"
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

/// Handlers that feed a recording and, when given, the launch's live model, its console and its
/// run summary. Each record reaches the model once, first (the in-time estimates only), then
/// the recording, the console and the summary, which read the model.
BusHandlers recording_handlers(Recording& recording, LiveModel* model, LiveConsole* console,
                               RunSummaryBuilder* summary, std::uint64_t& invalid);

class Launch {
 public:
  using Clock = std::chrono::steady_clock;
  explicit Launch(LaunchOptions options);
  ~Launch();
  Launch(const Launch&) = delete;
  Launch& operator=(const Launch&) = delete;

  /// The whole run; returns 0 or throws CommandError.
  int run();

 private:
  void prepare();
  void read_inputs();
  void resolve_discovery();
  void prepare_files();
  void open_network();
  void open_console();
  void open_bus();
  void start();
  void start_children();
  void print_launch_line();
  void serve();
  bool serve_step();
  void stop();
  int conclude();

  std::vector<dds::PresenceRecord> refresh_processes();
  void report(const std::vector<SupervisorEvent>& events, bool stopping = false);
  void write_checkpoint_for_restart();
  void write_pid_file();

  // In the order of the steps that make them: destroyed in reverse (the bus before the
  // recording it feeds, the recording before the io_context, the private files last).
  LaunchOptions o_;
  Scenario scenario_;
  RestartPolicy policy_ = RestartPolicy::restart;
  LaunchRoles roles_;
  std::uint64_t scenario_hash_ = 0;
  std::optional<dds::DiscoveryServerAddress> served_;
  std::optional<dds::DiscoveryServerAddress> discovery_;
  int domain_ = 0;
  TopicNaming naming_ = TopicNaming::netkf;  // flag, $NETKF_NAMING, the scenario's (every child gets it)
  std::vector<Check> checks_;
  std::unique_ptr<std::ostream> summary_out_;  // --summary (output_file.hpp)
  // The one live model: the console, the MCAP recorder and the summary read it (declared
  // before them: destroyed after them).
  std::unique_ptr<LiveModel> model_;
  std::unique_ptr<RunSummaryBuilder> summary_;  // only a run that asks keeps its records
  std::unique_ptr<LaunchFiles> files_;
  std::filesystem::path scenario_path_;
  std::filesystem::path checkpoint_path_;
  std::unique_ptr<dds::Participant> discovery_server_;
  boost::asio::io_context io_;
  std::unique_ptr<Recording> recording_;
  std::unique_ptr<LiveBus> bus_;
  LiveConsoleOptions console_options_;
  std::unique_ptr<LiveConsole> console_;
  std::uint64_t invalid_samples_ = 0;
  std::uint64_t run_id_ = 0;
  std::optional<Estimate> last_estimate_;  // the checkpoint a restarted estimator resumes from
  std::uint64_t fused_periods_ = 0;              // estimates that fused at least one sample
  int estimator_generation_ = 0;                 // estimators started so far, less one
  std::unique_ptr<Supervisor> supervisor_;
  std::string here_;
  LaunchPlan plan_;
  std::vector<SupervisorEvent> started_;
  RunFacts facts_;
  std::unique_ptr<OutageWatch> outages_;  // who stalled, for a diverged run's message
  Clock::time_point ended_at_;            // when the serve loop saw the run end
  std::unique_ptr<boost::asio::signal_set> signals_;
  Clock::time_point start_;
  RunEndWatch run_end_{0, std::chrono::seconds(1)};  // without the plant: its end is ours
  Clock::time_point last_presence_look_;
};

}  // namespace netkf::cli
