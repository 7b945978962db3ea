#pragma once
// The parts of one `netkf launch` and its five steps (launch.hpp): private to the launch room.
#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "console.hpp"
#include "launch_files.hpp"
#include "launch_plan.hpp"
#include "launch_supervisor.hpp"
#include "netkf/cli/launch/launch.hpp"
#include "netkf/cli/launch/run_end_watch.hpp"
#include "netkf/cli/live/live_bus.hpp"
#include "netkf/cli/live/run_summary.hpp"
#include "netkf/cli/recording/recording.hpp"
#include "netkf/dds/participant.hpp"
#include "netkf/model/scenario.hpp"
#include "outage_watch.hpp"
#include "run_verdict.hpp"

namespace netkf::cli {

/// Handlers that feed a recording and, when given, the launch's live model, its console and its
/// run summary. Each record reaches the model once, first (the in-time estimates only), then
/// the recording, the console and the summary, which read the model.
BusHandlers recording_handlers(Recording& recording, LiveModel* model, LiveConsole* console,
                               RunSummaryBuilder* summary, std::uint64_t& invalid);

class LaunchRun {
 public:
  using Clock = std::chrono::steady_clock;
  explicit LaunchRun(LaunchOptions options);
  ~LaunchRun();
  LaunchRun(const LaunchRun&) = delete;
  LaunchRun& operator=(const LaunchRun&) = delete;

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
