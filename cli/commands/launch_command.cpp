// `netkf launch`: its options (the run itself is launch/launch.hpp).
#include "command_options.hpp"
#include "netkf/cli/commands/commands.hpp"
#include "netkf/cli/launch/launch.hpp"
#include "netkf/cli/common/output_file.hpp"
#include "netkf/cli/recording/recording.hpp"

namespace netkf::cli {

namespace {

void add_process_options(CLI::App* cmd, LaunchOptions* o);
void add_view_and_check_options(CLI::App* cmd, LaunchOptions* o);

/// Every file the launch writes, before anything is opened (output_file.hpp): regular files,
/// each its own and none an input; an earlier run's recording only replaced with --force.
void check_launch_outputs(const LaunchOptions& o, bool force) {
  const std::vector<FileArg> recordings = Recording::outputs("--record", o.record, "--record-samples", o.record_samples);
  std::vector<FileArg> outputs = recordings;
  if (o.summary) outputs.push_back({"--summary", *o.summary});
  if (o.pid_file) outputs.push_back({"--pid-file", *o.pid_file});
  std::vector<FileArg> inputs;
  if (o.scenario) inputs.push_back({"the scenario", *o.scenario});
  if (o.events) inputs.push_back({"--events", *o.events});
  check_output_files(outputs, inputs);
  Recording::mcap_options("--record", o.record, o.mcap_profile, nullptr);  // refuses a profile without FILE.mcap
  if (!force) refuse_existing(recordings, "give --force");
}

}  // namespace

void add_launch_command(CLI::App& app) {
  auto o = std::make_shared<LaunchOptions>();
  auto* cmd = app.add_subcommand("launch", "Start and supervise all processes of a scenario on localhost");
  cmd->add_option("scenario", o->scenario, "Scenario YAML (default: built-in three-sensor scenario)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--duration", o->duration, "Stop after S seconds (default: until Ctrl-C)")->check(duration_seconds());
  cmd->add_option("--record", o->record,
                  "Write one CSV row per period: k,t,x..,xhat..,trace_P,fused,late,state,late_samples; and the live link changes "
                  "to FILE.events.yaml (replay with --events). FILE.mcap: an MCAP file instead (truth, estimates, "
                  "link status and changes, delivered samples with --record-samples; JSON, for Foxglove/PlotJuggler)");
  cmd->add_option("--mcap-profile", o->mcap_profile,
                  "With --record FILE.mcap: json (default: JSON messages for Foxglove/PlotJuggler) or ros2 (a rosbag2 "
                  "bag: netkf_msgs CDR on /netkf/... topics, for ros2 bag and Foxglove's ROS 2 panels; docs/recording.md)")
      ->check(CLI::IsMember({"json", "ros2"}));
  cmd->add_option("--events", o->events,
                  "Replay link changes: an events file (as --record writes FILE.events.yaml); at the same period "
                  "they apply before the scenario's own events")
      ->check(CLI::ExistingFile);
  cmd->add_option("--record-samples", o->record_samples,
                  "Write every delivered measurement: k,sensor_id,stamp,fused,y..");
  auto force = std::make_shared<bool>(false);
  cmd->add_flag("--force", *force, "Replace the --record and --record-samples files (and the journal) of an earlier run");
  add_network_options(cmd, o->network);
  add_process_options(cmd, o.get());
  add_view_and_check_options(cmd, o.get());
  cmd->callback([o, force] {
    run_command([&] {
      check_launch_outputs(*o, *force);
      return Launch(*o).run();
    });
  });
}

namespace {

/// How the launch runs its processes: logging, restarts, grouping, roles and hosts.
void add_process_options(CLI::App* cmd, LaunchOptions* o) {
  cmd->add_option("--log-level", o->log_level, "Log level of the node processes (trace..off)")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}));
  cmd->add_option("--restart-policy", o->restart_policy,
                  "When a sensor or the channel dies: restart it (with backoff) or fail the launch")
      ->check(CLI::IsMember({"restart", "fail"}));
  cmd->add_option("--max-restarts", o->max_restarts, "Restarts per process before the launch fails")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--sensors-per-process", o->sensors_per_process,
                  "Sensors hosted by each sensor_node process (one DDS participant each). auto: one each "
                  "while there are at most 2 sensors per CPU, else grouped to keep 2 sensor processes per CPU")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            if (v == "auto") return {};
            const bool digits = !v.empty() && v.size() <= 6 && v.find_first_not_of("0123456789") == std::string::npos;
            if (digits && std::stoi(v) >= 1) return {};
            return "must be 'auto' or a whole number of sensors >= 1, got '" + v + "'";
          },
          "auto|K"))
      ->capture_default_str();
  cmd->add_option("--only", o->only,
                  "Run only these roles on this host (the rest of the network runs on other hosts): a comma list "
                  "of plant, sensors, sensors=ID[,ID...], channel, estimator; default all (deploy/README.md)")
      ->capture_default_str();
  cmd->add_option("--run-id", o->run_id,
                  "The run id every process stamps on its samples; the launches of one network on several hosts "
                  "share it (default: drawn at random for a whole network, derived from the scenario and the domain "
                  "with --only)")
      ->check(CLI::Range(std::uint64_t{1}, std::numeric_limits<std::uint64_t>::max()));
  cmd->add_option("--serve-discovery", o->serve_discovery,
                  "Also be the network's Fast DDS Discovery Server, listening on ADDR:PORT (an address of this host); "
                  "this host's processes use it, the other hosts' launches give --discovery-server ADDR:PORT");
  cmd->add_option("--ready-timeout", o->ready_timeout,
                  "Seconds the plant waits for every sensor, the channel and the estimator (on any host) to be "
                  "present before it fails naming the missing")
      ->check(seconds_in(0.1, 3600.0))
      ->capture_default_str();
  cmd->add_option("--domain-check", o->domain_check,
                  "Seconds to look for another netkf network on the DDS domain before starting (0: skip)")
      ->check(seconds_in(0.0, 60.0))
      ->capture_default_str();
  cmd->add_flag("--standby", o->standby,
                "Run a hot-standby estimator beside the primary: both fuse the same samples, the plant and every "
                "reader take the primary's inputs and estimates (DDS exclusive ownership) until its liveliness "
                "lease (50 ms) expires, then the standby's; a dead estimator comes back as the new standby");
  cmd->add_flag("!--no-warm-spares", o->warm_spares,
                "Restart a dead channel or estimator as a fresh process instead of activating its warm spare (a "
                "process started ahead that already joined the network: a restart then costs no DDS discovery)");
  cmd->add_option("--sensor-nice", o->sensor_nice,
                  "CPU priority (nice 0..19) of the sensor processes: they stand in for separate devices; a "
                  "positive value lets the channel and the estimator go first on a small machine")
      ->check(CLI::Range(0, 19))
      ->capture_default_str();
}

/// What the run shows and how it is judged: status, dashboard, checks, summary.
void add_view_and_check_options(CLI::App* cmd, LaunchOptions* o) {
  cmd->add_option("--status-interval", o->status_interval, "Seconds between status updates on stderr (0: none)")
      ->check(seconds_in(0.0, 3600.0));
  cmd->add_option("--pid-file", o->pid_file,
                  "Write 'name pid' of each running process (spares as 'NAME (spare)') to FILE, rewritten after "
                  "every start, restart and death");
  cmd->add_option("--dashboard", o->dashboard,
                  "Port of the live dashboard (page, Foxglove WebSocket, /metrics), or 'off' for none")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            if (v == "off") return {};
            const bool digits = !v.empty() && v.size() <= 5 && v.find_first_not_of("0123456789") == std::string::npos;
            if (digits && std::stoi(v) <= 65535) return {};
            return "must be a port number (0-65535) or 'off', got '" + v + "'";
          },
          "PORT|off"))
      ->capture_default_str();
  cmd->add_option("--dashboard-bind", o->dashboard_bind,
                  "Address the dashboard listens on (default 127.0.0.1); any other binding requires the token "
                  "printed at start");
  cmd->add_option("--dashboard-allow-origin", o->dashboard_allow_origins,
                  "Also accept WebSocket connections from pages of this origin (e.g. a Foxglove web app); repeatable");
  cmd->add_option("--dashboard-max-connections", o->dashboard_max_connections,
                  "Connections the dashboard holds at once (HTTP and WebSocket); at the limit a new one replaces "
                  "the longest idle HTTP connection or is refused (503)")
      ->check(CLI::Range(std::size_t{1}, std::size_t{65536}))
      ->capture_default_str();
  // One value per --check: a check must never swallow the scenario file that follows it.
  cmd->add_option("--check", o->checks,
                  "Pass/fail check at the end of the run on a summary quantity: NAME<VALUE (or <=, >, >=), e.g. "
                  "'rms_error<0.8', 'link.2.observed_loss<0.35'; repeatable; exit 1 when one fails")
      ->allow_extra_args(false);
  cmd->add_flag("--allow-divergence", o->allow_divergence,
                "A closed loop that leaves plant.state_bound ends the run with exit 0 (a run started to show an "
                "unstable loop); without it such a run fails (exit 1) naming what stalled before it");
  cmd->add_option("--summary", o->summary,
                  "Write the run's summary (rms_error, late_fraction, per-link counts, latency, every check's "
                  "verdict) as JSON to FILE at the end of the run");
}

}  // namespace

}  // namespace netkf::cli
