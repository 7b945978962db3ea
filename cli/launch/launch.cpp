#include "netkf/cli/launch/launch.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <unistd.h>

#include "domain_guard.hpp"
#include "launch_run.hpp"
#include "netkf/cli/common/exit_code.hpp"
#include "netkf/cli/common/open_files.hpp"
#include "netkf/cli/common/output_file.hpp"
#include "netkf/cli/common/serve_loop.hpp"
#include "netkf/cli/common/text.hpp"
#include "netkf/cli/recording/ros2_cdr_codec.hpp"
#include "netkf/dds/node_support.hpp"
#include "netkf/dds/participant_slot.hpp"
#include "netkf/dds/presence.hpp"
#include "netkf/dds/security.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/records/checkpoint.hpp"

namespace netkf::cli {
namespace {

/// Fast DDS's shared-memory files no live process holds (`fastdds shm clean`) and the
/// participant markers of `domain` that killed processes left (participant_slot.hpp). Only at
/// the start and the end of a launch: then no writer of this launch can still hold a killed
/// process's port open.
void remove_stale_shared_memory(int domain, const char* what) {
  const auto shm = clean_stale_shared_memory();
  const int slots = dds::remove_stale_participant_slots(domain);
  if (shm.zombie_segments + shm.zombie_ports + slots > 0)
    std::cerr << "netkf launch: removed what " << what << " left: " << shm.zombie_segments
              << " Fast DDS shared-memory segments, " << shm.zombie_ports << " ports (fastdds shm clean), "
              << slots << " participant markers\n";
}

/// Run `f`; any exception becomes CommandError(bad_usage) with `prefix` and its message.
template <typename F>
auto or_bad_usage(F&& f, const std::string& prefix = {}) {
  try {
    return f();
  } catch (const CommandError&) {
    throw;
  } catch (const std::exception& e) {
    fail(ExitCode::bad_usage, prefix + e.what());
  }
}

/// DDS Security: the identity of every role this host's processes take (the children's and the
/// launch's own), checked before anything starts: a missing file or a key others may read is
/// exit 2 here, not a child's death after the start.
void check_identities(const std::optional<std::string>& secure, const LaunchRoles& roles, bool dashboard) {
  const auto dir = or_bad_usage([&] { return dds::resolve_secure(secure); });
  if (!dir) return;
  std::vector<dds::Role> used{dds::Role::observer};  // the launch (without dashboard), a discovery server
  if (dashboard) used.push_back(dds::Role::ctl);
  if (roles.plant) used.push_back(dds::Role::plant);
  if (!roles.sensor_ids.empty()) used.push_back(dds::Role::sensor);
  if (roles.channel) used.push_back(dds::Role::channel);
  if (roles.estimator) used.push_back(dds::Role::estimator);
  for (const auto role : used)
    or_bad_usage([&] { dds::check_security_files(dds::security_files(*dir, role)); }, "--secure: ");
}

}  // namespace

Scenario load_or_default(const std::optional<std::string>& file) {
  if (!file) return default_scenario();
  return or_bad_usage([&] { return load_scenario_file(*file); });
}

BusHandlers recording_handlers(Recording& recording, LiveModel* model, LiveConsole* console,
                               RunSummaryBuilder* summary, std::uint64_t& invalid) {
  BusHandlers h;
  h.truth = [&recording, model, console, summary](Truth&& t) {
    if (model) model->add_truth(t);
    recording.truth(t);
    if (console) console->truth(t);
    if (summary) summary->add_truth(t);
  };
  h.estimate = [&recording, model, console, summary](Estimate&& e) {
    // A revision (late_policy fuse_within) corrects an earlier period: the model follows the
    // in-time estimates. The recording keeps the first and the final estimate of each period,
    // the summary scores both, the dashboard plots both.
    if (model && e.revision == 0) model->add_estimate(e);
    recording.estimate(e);
    if (console) console->estimate(e);
    if (summary) summary->add_estimate(e);
  };
  if (recording.wants_samples()) h.delivered = [&recording](DeliveredMeasurement&& d) { recording.delivered(d); };
  if (recording.journals_changes() || console) {
    h.link_change = [&recording, model, console](LinkChange&& c) {
      // A netkf relay's topic on the same domain is not one of the scenario's links: its
      // journal counts samples of a topic, not periods (ctl status shows it; docs/relay.md).
      if (!c.topic.empty()) return;
      if (model) model->add_link_change(c);
      recording.link_change(c);
      if (console) console->link_change(c);
    };
  }
  if (console || summary || recording.wants_link_status()) {
    h.link_status = [&recording, model, console, summary](LinkStatus&& l) {
      if (!l.topic.empty()) return;  // a netkf relay's topic (above)
      const bool link_moved = model && model->add_link_status(l);
      recording.link_status(l);
      if (summary) summary->add_link_status(l);
      if (console) console->link_status(l, link_moved);
    };
  }
  if (console) h.link_reply = [console](LinkReply&& r) { console->link_reply(r); };
  h.invalid = [model, console, &invalid](const std::string& what) {
    ++invalid;
    if (model) model->count_invalid();
    if (console) console->invalid_sample(what);
    else std::cerr << "netkf: rejected a sample: " << what << "\n";
  };
  return h;
}

BusHandlers recording_handlers(Recording& recording, std::uint64_t& invalid) {
  return recording_handlers(recording, nullptr, nullptr, nullptr, invalid);
}

Launch::Launch(LaunchOptions options) : run_(std::make_unique<LaunchRun>(std::move(options))) {}

Launch::~Launch() = default;

int Launch::run() { return run_->run(); }

LaunchRun::LaunchRun(LaunchOptions options) : o_(std::move(options)) {}

LaunchRun::~LaunchRun() = default;

int LaunchRun::run() {
  prepare();
  start();
  serve();
  stop();
  return conclude();
}

// ---------------------------------------------------------------- prepare

void LaunchRun::prepare() {
  read_inputs();
  check_identities(o_.network.secure, roles_, o_.dashboard != "off");
  resolve_discovery();
  prepare_files();
  open_network();
}

/// The scenario, the roles and the user's checks: a mistake in any is exit 2 before
/// anything starts, not a failed check after a long run.
void LaunchRun::read_inputs() {
  scenario_ = load_or_default(o_.scenario);
  if (o_.events) or_bad_usage([&] { add_replayed_events(scenario_, load_events_file(*o_.events, scenario_)); });
  policy_ = parse_restart_policy(o_.restart_policy);
  // The largest live network measured to run (BENCHMARKS.md, "Sensor count limit").
  if (scenario_.sensors.size() > kMaxLiveSensors)
    fail(ExitCode::bad_usage, "the scenario has " + std::to_string(scenario_.sensors.size()) +
                                  " sensors; a live network runs at most " + std::to_string(kMaxLiveSensors) +
                                  " (the largest measured to run; docs/operations.md, \"Failure behaviour\")");
  std::vector<int> sensor_ids;
  for (const auto& sensor : scenario_.sensors) sensor_ids.push_back(sensor.id);
  roles_ = or_bad_usage([&] { return parse_launch_roles(o_.only, sensor_ids); });
  scenario_hash_ = dds::scenario_hash(scenario_);
  std::vector<int> link_ids = sensor_ids;
  if (scenario_.actuation_link()) link_ids.push_back(kControlLinkId);
  for (const auto& text : o_.checks) checks_.push_back(or_bad_usage([&] { return parse_check(text, link_ids); }));
  if (o_.summary) summary_out_ = open_output_stream({"--summary", *o_.summary});
  model_ = std::make_unique<LiveModel>(scenario_);
  if (o_.summary || !checks_.empty()) summary_ = std::make_unique<RunSummaryBuilder>(*model_);
}

/// The localhost profile, or a Discovery Server (this launch's own with --serve-discovery:
/// it lives in this process and ends with it).
void LaunchRun::resolve_discovery() {
  or_bad_usage([&] {
    domain_ = dds::resolve_domain(o_.network.domain);
    naming_ = dds::resolve_naming(o_.network.naming, scenario_.naming);
    // ROS 2's readers are shared-ownership only, so under its names every topic is (topics.hpp,
    // naming_qos); the hot standby's failover needs exclusive ownership.
    if (naming_ == TopicNaming::ros2 && o_.standby)
      fail(ExitCode::bad_usage, "--standby needs exclusive ownership, which the ros2 naming cannot offer ROS 2's "
                                "readers (docs/ros2.md): launch with the netkf naming, or without --standby");
    discovery_ = dds::resolve_discovery_server(o_.network.discovery_server);
    if (!o_.serve_discovery) return;
    served_ = dds::parse_discovery_server(*o_.serve_discovery);
    if (discovery_ && discovery_->text() != served_->text())
      fail(ExitCode::bad_usage, "--serve-discovery " + served_->text() + " and --discovery-server " +
                                    discovery_->text() + " name different servers");
    discovery_ = served_;
  });
}

/// The launch's private files: the effective scenario the children read, the estimator's
/// checkpoint. A launch killed earlier left its directory and maybe Fast DDS shared-memory
/// files behind: both are cleaned here.
void LaunchRun::prepare_files() {
  files_ = or_bad_usage([] { return std::make_unique<LaunchFiles>(); });
  for (const auto& stale : files_->removed_stale())
    std::cerr << "netkf launch: removed the files of a launch that is no longer running (" << stale.string() << ")\n";
  remove_stale_shared_memory(domain_, "killed processes of earlier runs");
  scenario_path_ = files_->file("scenario.yaml");
  std::ofstream out(scenario_path_);
  out << scenario_to_yaml(scenario_);
  if (!out) fail(ExitCode::bad_usage, "cannot write " + scenario_path_.string());
  checkpoint_path_ = files_->file("estimator-checkpoint.json");
  if (!served_) return;
  dds::ParticipantOptions so;
  so.domain = domain_;
  so.name = "netkf-discovery-server";
  so.discovery_server = served_;
  so.serve_discovery = true;
  if (auto dir = dds::resolve_secure(o_.network.secure))
    so.security = dds::ParticipantOptions::Security{*dir, dds::Role::observer};
  discovery_server_ = or_bad_usage([&] { return std::make_unique<dds::Participant>(so); },
                                   "cannot serve discovery on " + served_->text() + ": ");
}

void LaunchRun::open_network() {
  recording_ = std::make_unique<Recording>(
      o_.record, o_.record_samples, scenario_,
      Recording::mcap_options("--record", o_.record, o_.mcap_profile, ros2::make_fastcdr_codec()), model_.get());
  open_console();
  // This run's id: every node stamps it on its samples and drops those of another run. A launch
  // of the whole network draws one; the launches of one network on several hosts (--only) share
  // one: given (--run-id), or derived alike from the scenario and the domain.
  run_id_ = o_.run_id ? *o_.run_id : !roles_.all ? derived_run_id(scenario_hash_, domain_) : random_run_id();
  open_bus();
}

/// The console first: a dashboard port that is taken fails the launch before anything starts.
/// The open-file limit is raised first: the dashboard's connections never take the descriptors
/// the launch needs for its children's pipes and DDS (connection_cap).
void LaunchRun::open_console() {
  const std::uint64_t open_files = raise_open_file_limit();
  console_options_.status_interval = o_.status_interval;
  const char* term = std::getenv("TERM");
  console_options_.status_screen =
      o_.status_interval > 0 && isatty(STDERR_FILENO) == 1 && term && std::string(term) != "dumb";
  if (o_.dashboard != "off") {
    DashboardOptions d;
    d.port = static_cast<unsigned short>(std::stoi(o_.dashboard));
    if (o_.dashboard_bind) {
      d.bind = *o_.dashboard_bind;
      d.token = random_token();  // listening beyond 127.0.0.1: every request needs it
    }
    d.allowed_origins = o_.dashboard_allow_origins;
    // Every link reports once a second, all within a few milliseconds: a client's queue holds
    // a few rounds of them before it drops (a subscription's latched state is never dropped).
    d.max_queued_frames = std::max(d.max_queued_frames, 3 * (scenario_.sensors.size() + 1));
    d.max_connections = connection_cap(o_.dashboard_max_connections, open_files);
    if (d.max_connections < o_.dashboard_max_connections)
      std::cerr << "netkf launch: the dashboard takes at most " << d.max_connections
                << " connections (half the open-file limit, " << open_files << ")\n";
    console_options_.dashboard = d;
  }
  console_ = or_bad_usage([&] {
    return std::make_unique<LiveConsole>(io_, *model_, console_options_,
                                         [this](std::uint64_t id, int sensor_id, const LinkKeys& keys) {
                                           return bus_ && bus_->send_link_control(id, sensor_id, keys);
                                         });
  });
}

void LaunchRun::open_bus() {
  BusHandlers handlers = recording_handlers(*recording_, model_.get(), console_.get(), summary_.get(), invalid_samples_);
  outages_ = std::make_unique<OutageWatch>(std::chrono::milliseconds(scenario_.period_ms));
  handlers.truth = [record = std::move(handlers.truth), this](Truth&& t) {
    outages_->truth(t.k, Clock::now());
    record(std::move(t));
  };
  handlers.estimate = [record = std::move(handlers.estimate), this](Estimate&& e) {
    if (e.revision == 0) {
      fused_periods_ += e.fused.empty() ? 0 : 1;
      outages_->estimate(static_cast<std::int64_t>(e.k), e.fused.size(), Clock::now());
    }
    // The checkpoint: the newest period's best estimate (a revision of an older period is not it).
    if (!last_estimate_ || e.k > last_estimate_->k || (e.k == last_estimate_->k && e.revision > last_estimate_->revision))
      last_estimate_ = e;
    record(std::move(e));
  };
  // The dashboard retunes links: a launch serving it needs the ctl identity.
  const auto role = console_options_.dashboard ? dds::Role::ctl : dds::Role::observer;
  BusOptions bus_options = o_.network.bus("netkf-launch", role);
  bus_options.run = run_id_;
  bus_options.estimate_history = true;  // a restarted estimator's first estimates (topics.hpp)
  if (discovery_) bus_options.discovery_server = discovery_->text();
  bus_options.naming = to_string(naming_);
  bus_options.presence = BusOptions::Presence{dds::presence_role::launch, scenario_hash_, describe_launch_roles(roles_)};
  bus_ = or_bad_usage(
      [&] {
        return std::make_unique<LiveBus>(io_, bus_options, std::move(handlers),
                                         /*link_control_writer=*/console_options_.dashboard.has_value());
      },
      "DDS: ");
}

// ---------------------------------------------------------------- start

void LaunchRun::start() {
  guard_domain(*bus_, {domain_, run_id_, scenario_hash_, roles_.all, o_.domain_check});
  SupervisorOptions so;
  so.policy = policy_;
  so.max_restarts = o_.max_restarts;
  supervisor_ = std::make_unique<Supervisor>(so);
  here_ = dds::this_host();
  start_children();
  write_pid_file();
  print_launch_line();
}

/// For scripts and tests: name and pid of every running child and spare, rewritten (whole, in
/// place) after every start, restart and death, so it always names the processes running now.
void LaunchRun::write_pid_file() {
  if (!o_.pid_file) return;
  std::string pids;
  for (const auto& c : supervisor_->children())
    if (c.running) pids += c.name + " " + std::to_string(c.pid) + "\n";
  try {
    write_output_file({"--pid-file", *o_.pid_file}, pids);
  } catch (const CommandError& e) {  // its path was checked before the start: the run goes on
    std::cerr << "netkf launch: WARNING: " << e.what() << "\n";
  }
}

void LaunchRun::start_children() {
  LaunchPlanInputs in;
  in.scenario_file = scenario_path_.string();
  in.checkpoint_file = checkpoint_path_.string();
  in.domain = domain_;
  in.log_level = o_.log_level;
  in.run_id = run_id_;
  if (discovery_) in.discovery_server = discovery_->text();
  in.naming = to_string(naming_);
  in.dds_profile = o_.network.profile;
  // Explicit (so a launch secured by $NETKF_SECURE secures its children too) and absolute.
  if (const auto secure = dds::resolve_secure(o_.network.secure)) in.secure_dir = secure->string();
  in.roles = roles_;
  in.sensors_per_process = o_.sensors_per_process == "auto"
                               ? auto_sensors_per_process(roles_.sensor_ids.size(), usable_cpus())
                               : std::stoi(o_.sensors_per_process);
  in.sensor_nice = o_.sensor_nice;
  in.ready_timeout_s = o_.ready_timeout;
  in.estimator_standby = o_.standby;
  in.warm_spares = o_.warm_spares;
  in.records_samples = recording_->wants_samples();
  if (o_.standby) estimator_generation_ = 1;
  plan_ = plan_launch(in);
  for (const auto& child : plan_.children) {
    // A restarted estimator resumes from the last estimate this launch saw (written just before
    // the restart, after the backoff, so no estimate of the previous life is still in flight).
    std::function<void(ChildSpec&)> before_restart;
    if (child.estimator)
      before_restart = [this](ChildSpec& spec) {
        write_checkpoint_for_restart();
        ++estimator_generation_;
        if (o_.standby) {
          // The new life is weaker than every estimator started before it: the standby that took
          // over keeps the plant (launch_plan.hpp).
          set_ownership_strength(spec.args, estimator_ownership_strength(estimator_generation_));
        } else {
          // No other estimator runs: the new life, and the spare started during it, outrank the
          // dead one at once (launch_plan.hpp).
          set_ownership_strength(spec.args, replacing_estimator_strength(estimator_generation_));
          if (!spec.spare_args.empty())
            set_ownership_strength(spec.spare_args, replacing_estimator_spare_strength(estimator_generation_));
        }
      };
    started_.push_back(supervisor_->start(child.spec, before_restart));
  }
  report(started_);
  if (!supervisor_->failed()) return;
  supervisor_->stop_all();
  // CI still gets its summary and a verdict per check (all unmeasured) before the failure.
  RunVerdict verdict;
  verdict.summary_end = "failure: " + supervisor_->failure_reason();
  if (summary_)
    conclude_run(summary_->summary(), checks_, scenario_.name, std::cout, summary_out_.get(),
                 o_.summary.value_or(""), verdict);
  fail(ExitCode::run_failed, supervisor_->failure_reason());
}

void LaunchRun::write_checkpoint_for_restart() {
  try {
    if (!last_estimate_) {
      std::filesystem::remove(checkpoint_path_);
      console_->announce(LiveEvent::Level::warning, "the estimator died before its first estimate: it starts afresh");
      return;
    }
    write_checkpoint(checkpoint_path_.string(), *last_estimate_);
  } catch (const std::exception& e) {
    console_->announce(LiveEvent::Level::warning, std::string("estimator checkpoint not written: ") + e.what());
  }
}

void LaunchRun::print_launch_line() {
  const bool auto_grouping = o_.sensors_per_process == "auto";
  const std::size_t per_process = plan_.sensor_groups.empty() ? 0 : plan_.sensor_groups.front().size();
  std::ostringstream line;
  line << "netkf launch: scenario '" << scenario_.name << "' on DDS domain " << domain_ << ", ";
  if (!roles_.all)
    line << "this host runs " << describe_launch_roles(roles_) << " (run " << hex_id(run_id_)
         << "; the rest of the network on other hosts), ";
  line << roles_.sensor_ids.size() << " sensors in " << plan_.sensor_groups.size() << " processes"
       << (auto_grouping && per_process > 1
               ? " (" + std::to_string(per_process) + " per process, auto: at most 2 sensor processes per CPU, " +
                     std::to_string(usable_cpus()) + " CPUs; --sensors-per-process 1 for one each)"
               : std::string())
       << ", period " << scenario_.period_ms << " ms"
       << (o_.duration > 0 ? ", for " + number_text(o_.duration) + " s" : ", Ctrl-C stops");
  if (served_) line << "\nnetkf launch: serving discovery on " << served_->text();
  else if (discovery_) line << "\nnetkf launch: discovery through the server at " << discovery_->text();
  if (const auto url = console_->dashboard_url()) line << "\nnetkf launch: dashboard: " << *url;
  std::cerr << line.str() << "\n" << std::flush;
  console_->set_header(line.str());
}

/// The processes of the run: this launch's children, then what the other hosts run (presence).
std::vector<dds::PresenceRecord> LaunchRun::refresh_processes() {
  auto presences = bus_->processes();
  std::vector<ProcessView> processes;
  std::set<int> children;
  for (const auto& c : supervisor_->children()) {
    processes.push_back({c.name, c.pid, c.running, c.restarts, here_});
    children.insert(c.pid);
  }
  for (const auto& p : presences) {
    if (p.run != run_id_ || (p.host == here_ && (children.count(p.pid) || p.pid == getpid()))) continue;
    std::string name = p.role;
    if (!p.sensor_ids.empty()) name = sensor_process_name(p.sensor_ids);
    processes.push_back({name, p.pid, p.running(), 0, p.host});
  }
  console_->set_processes(std::move(processes));
  return presences;
}

/// Trouble: a process that died unexpectedly, a restart, a failure to start; a clean exit
/// (the plant ending the run, or any exit during the stop) is not.
void LaunchRun::report(const std::vector<SupervisorEvent>& events, bool stopping) {
  for (const auto& e : events) {
    const bool clean_exit = e.kind == SupervisorEvent::Kind::exited && e.exit.clean();
    const bool trouble = !stopping && e.kind != SupervisorEvent::Kind::started &&
                         e.kind != SupervisorEvent::Kind::spare_started && !clean_exit;
    console_->announce(trouble ? LiveEvent::Level::warning : LiveEvent::Level::info, e.message());
    if (e.kind == SupervisorEvent::Kind::restart_scheduled || e.kind == SupervisorEvent::Kind::spare_activated)
      console_->count_restart(e.child);
  }
  if (!events.empty()) refresh_processes();
  if (!events.empty() && !stopping) write_pid_file();
}

// ---------------------------------------------------------------- serve

void LaunchRun::serve() {
  signals_ = std::make_unique<boost::asio::signal_set>(io_, SIGINT, SIGTERM);
  signals_->async_wait([this](const boost::system::error_code& ec, int) {
    if (!ec && facts_.end == RunEnd::running) facts_.end = RunEnd::signal;
  });
  start_ = Clock::now();
  last_presence_look_ = start_;
  run_end_ = RunEndWatch(run_id_, std::chrono::seconds(1));
  cli::serve(io_, std::chrono::milliseconds(50), [this] { return serve_step(); });
}

/// One step of the loop (every 50 ms): supervise, flush the recording, follow presence,
/// decide whether the run is over, refresh the console. False once it is over.
bool LaunchRun::serve_step() {
  report(supervisor_->poll());
  recording_->flush();
  const auto now = Clock::now();
  for (const auto& c : supervisor_->children())
    outages_->child(c.name, c.pid,
                    c.running           ? OutageWatch::ChildState::running
                    : c.restart_pending ? OutageWatch::ChildState::restarting
                                        : OutageWatch::ChildState::ended,
                    now);
  if (now - last_presence_look_ >= std::chrono::milliseconds(500)) {
    last_presence_look_ = now;
    const auto processes = refresh_processes();
    if (!roles_.plant) run_end_.look(processes, now);
  }
  if (facts_.end == RunEnd::running) {
    if (supervisor_->failed()) {
      facts_.end = RunEnd::process_failed;
      facts_.failure = supervisor_->failure_reason();
    } else if (recording_->write_error()) {
      facts_.end = RunEnd::recording_failed;
      facts_.failure = *recording_->write_error() + ": the run was stopped";
      console_->announce(LiveEvent::Level::error, facts_.failure);
    } else if (supervisor_->finished() || run_end_.over(now)) {
      facts_.end = RunEnd::finished;
    } else if (o_.duration > 0 && now - start_ >= std::chrono::duration<double>(o_.duration)) {
      facts_.end = RunEnd::duration;
    }
  }
  console_->tick(now);
  if (facts_.end != RunEnd::running) ended_at_ = now;
  return facts_.end == RunEnd::running;
}

// ---------------------------------------------------------------- stop

/// The children get SIGTERM (SIGKILL after the timeout); then take what DDS still delivered
/// so the recording ends with the last complete period.
void LaunchRun::stop() {
  console_->set_screen(false);  // from here on, plain lines
  report(supervisor_->stop_all(), /*stopping=*/true);
  io_.restart();
  io_.run_for(std::chrono::milliseconds(300));
  recording_->flush();
  recording_->finish();
  if (facts_.end != RunEnd::process_failed && facts_.end != RunEnd::recording_failed && recording_->write_error()) {
    facts_.end = RunEnd::recording_failed;
    facts_.failure = *recording_->write_error();
  }
  console_->stop();
  io_.restart();
  io_.run_for(std::chrono::milliseconds(50));  // let the dashboard's close frames go out
  signals_->cancel();
  if (facts_.end == RunEnd::finished) facts_.finished_why = run_end_.why().value_or(supervisor_->finished_reason());
  // A closed loop that left plant.state_bound (the plant's presence says so, on any host), and
  // who stalled in the seconds before: a diverged run names them (RunFacts::diverged).
  for (const auto& p : bus_->processes())
    if (p.run == run_id_ && p.diverged()) facts_.diverged = p.detail;
  outages_->finish(Clock::now());
  facts_.outages_before = outages_->describe_between(ended_at_ - std::chrono::seconds(5), ended_at_);
  facts_.allow_divergence = o_.allow_divergence;
  const std::uint64_t foreign_samples = bus_->foreign_samples();
  bus_->end_presence(end_text(facts_));
  bus_.reset();
  discovery_server_.reset();
  // A child killed during the run (kill -9, or SIGKILL after the stop timeout) left its Fast
  // DDS shared-memory files: every process of the run has ended, so remove them now.
  remove_stale_shared_memory(domain_, "killed processes of this run");
  std::cerr << "netkf launch: stopped (" << end_text(facts_) << "); " << model_->snapshot().estimates
            << " estimates seen";
  if (foreign_samples > 0) std::cerr << ", " << foreign_samples << " samples of another run on the domain dropped";
  if (o_.record)
    std::cerr << ", " << recording_->rows() << (is_mcap_path(*o_.record) ? " periods in " : " rows in ") << *o_.record;
  std::cerr << "\n";
  if (model_->saw_non_finite() || invalid_samples_ > 0)
    std::cerr << "netkf launch: WARNING: " << invalid_samples_ << " invalid samples were rejected\n";
}

// ---------------------------------------------------------------- conclude

/// Checks are judged after everything is recorded; a run that failed keeps its own failure.
int LaunchRun::conclude() {
  add_snapshot_facts(model_->snapshot(), facts_);
  facts_.fused_periods = fused_periods_;
  facts_.ran_for_s = std::chrono::duration<double>(Clock::now() - start_).count();
  RunVerdict verdict = judge_run(facts_);
  if (verdict.failure && facts_.end != RunEnd::process_failed && facts_.end != RunEnd::recording_failed)
    std::cerr << "netkf launch: ERROR: " << *verdict.failure << "\n";
  if (summary_)
    conclude_run(summary_->summary(), checks_, scenario_.name, std::cout, summary_out_.get(),
                 o_.summary.value_or(""), verdict);
  if (verdict.failure) fail(verdict.exit, *verdict.failure);
  return 0;
}

}  // namespace netkf::cli
