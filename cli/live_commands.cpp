// `netkf launch`, `netkf ctl`, `netkf record`: the live network seen from the command line.
// launch spawns and supervises the node processes (launch_supervisor), records and shows
// status from DDS (live_bus, record_csv, live_status), and at the end of the run writes its
// summary and evaluates the user's pass/fail checks (run_summary). ctl tunes links at runtime.
#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <thread>
#include <unistd.h>

#include "commands.hpp"
#include "launch_files.hpp"
#include "launch_supervisor.hpp"
#include "live_bus.hpp"
#include "live_status.hpp"
#include "live_views.hpp"
#include "netkf/nodes/estimator_core.hpp"
#include "netkf/dds/node_support.hpp"
#include "netkf/dds/participant.hpp"
#include "netkf/dds/participant_slot.hpp"
#include "netkf/dds/presence.hpp"
#include "netkf/scenario.hpp"
#include "record_csv.hpp"
#include "record_mcap.hpp"
#include "run_summary.hpp"

namespace netkf::cli {

namespace {

using Clock = std::chrono::steady_clock;

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

/// The options every live command shares.
struct NetworkOptions {
  std::optional<int> domain;
  std::optional<std::string> profile;
  std::optional<std::string> secure;
  std::optional<std::string> discovery_server;
  void add_to(CLI::App* cmd) {
    cmd->add_option("--domain", domain, "DDS domain id (default: $NETKF_DOMAIN, else 0)")->check(CLI::Range(0, 232));
    cmd->add_option("--dds-profile", profile,
                    "Fast DDS XML profile (default: $NETKF_DDS_PROFILE, else built-in localhost-only)");
    cmd->add_option("--secure", secure,
                    "DDS Security: the directory made by `netkf security init` (default: $NETKF_SECURE, else none)");
    cmd->add_option("--discovery-server", discovery_server,
                    "Discover the network through the Fast DDS Discovery Server at ADDR:PORT, e.g. on another host "
                    "(default: $NETKF_DISCOVERY_SERVER, else the localhost-only profile; deploy/README.md)");
  }
  BusOptions bus(const std::string& name, dds::Role role) const {
    BusOptions b;
    b.domain = domain;
    b.profile = profile;
    b.name = name;
    b.secure = secure;
    b.role = role;
    b.discovery_server = discovery_server;
    return b;
  }
};

[[noreturn]] void fail(int code, const std::string& message) {
  std::cerr << "netkf: error: " << message << "\n";
  throw CLI::RuntimeError(code);
}

/// Record files written from the main thread: truth + estimates (a CSV, or an MCAP file
/// when the name ends with .mcap), and optionally every delivered sample.
class Recording {
 public:
  Recording(const std::optional<std::string>& periods_file, const std::optional<std::string>& samples_file,
            const Scenario& scenario)
      : periods_(scenario.state_dim()), samples_(max_measurement_dim(scenario)) {
    if (periods_file && is_mcap_path(*periods_file)) {
      mcap_out_.open(*periods_file, std::ios::trunc | std::ios::binary);
      if (!mcap_out_) fail(2, "cannot write " + *periods_file + ": " + std::strerror(errno));
      mcap_ = std::make_unique<McapRecorder>(mcap_out_, scenario, /*with_delivered=*/samples_file.has_value());
      mcap_out_.flush();
      events_file_ = *periods_file + ".events.yaml";
      write_events();
    } else if (periods_file) {
      periods_out_.open(*periods_file, std::ios::trunc);
      if (!periods_out_) fail(2, "cannot write " + *periods_file + ": " + std::strerror(errno));
      periods_out_ << PeriodCsvRecorder::header(scenario.state_dim()) << "\n";
      events_file_ = *periods_file + ".events.yaml";
      write_events();  // an empty journal too: a replay of a run without changes is valid
    }
    if (samples_file) {
      samples_out_.open(*samples_file, std::ios::trunc);
      if (!samples_out_) fail(2, "cannot write " + *samples_file + ": " + std::strerror(errno));
      samples_out_ << SampleCsvRecorder::header(max_measurement_dim(scenario)) << "\n";
    }
  }
  Recording(const Recording&) = delete;
  Recording& operator=(const Recording&) = delete;
  ~Recording() {
    try {
      finish();
    } catch (...) {
    }
  }
  /// Complete the MCAP file (DataEnd, Footer, magic): on every stop, SIGINT/SIGTERM included.
  void finish() {
    if (mcap_ && !mcap_->finished()) {
      mcap_->finish();
      mcap_out_.flush();
      if (!mcap_out_) std::cerr << "netkf: error: writing the MCAP recording failed\n";
    }
  }
  bool wants_link_status() const { return mcap_ != nullptr; }
  void link_status(const LinkStatusRecord& l) {
    if (mcap_) mcap_->link_status(l);
  }
  bool wants_samples() const { return samples_out_.is_open(); }
  /// Live changes (ctl, dashboard) with the period they applied from: written next to the
  /// periods file as FILE.events.yaml, which `netkf launch --events` replays.
  void link_change(const LinkChangeRecord& c) {
    if (mcap_) mcap_->link_change(c);
    if (!events_file_ || c.origin != "request") return;
    LinkEvent e;
    e.at_period = c.at_period;
    e.link = c.sensor_id;
    e.keys = link_keys(c.link);  // the whole link: a replay sets exactly what the run had
    for (const auto& seen : journal_)
      if (seen.request_id == c.request_id && seen.event == e) return;  // transient-local repeats
    journal_.push_back({c.request_id, std::move(e)});
    journal_changed_ = true;
  }
  std::optional<std::string> events_file() const { return events_file_; }
  void truth(const TruthRecord& t) {
    if (periods_out_.is_open()) periods_.add_truth(t);
    if (mcap_) mcap_->truth(t);
  }
  void estimate(const EstimateRecord& e) {
    if (periods_out_.is_open()) periods_.add_estimate(e);
    if (samples_out_.is_open()) samples_.add_estimate(e);
    if (mcap_) mcap_->estimate(e);
  }
  void delivered(const DeliveredRecord& d) {
    if (samples_out_.is_open()) samples_.add_delivered(d);
    if (mcap_) mcap_->delivered(d);
  }
  void flush() {
    if (periods_out_.is_open()) {
      periods_.flush(periods_out_);
      periods_out_.flush();
    }
    if (samples_out_.is_open()) {
      samples_.flush(samples_out_);
      samples_out_.flush();
    }
    if (mcap_) mcap_out_.flush();  // whole records: a reader of a killed launch gets all but the footer
    if (journal_changed_) write_events();
  }
  /// CSV: rows written; MCAP: estimates (periods) written.
  std::uint64_t rows() const { return mcap_ ? mcap_->estimates() : periods_.rows_written(); }

 private:
  struct Journaled {
    std::uint64_t request_id;
    LinkEvent event;
  };
  void write_events() {
    // Rewritten whole (it is small) so that the file is complete whenever the launch stops.
    std::vector<LinkEvent> events;
    for (const auto& j : journal_) events.push_back(j.event);
    std::ofstream out(*events_file_, std::ios::trunc);
    out << "# Live link changes of a netkf run, with the period each applied from.\n"
           "# Replay: netkf launch SCENARIO --events THIS_FILE (same scenario and seed).\n"
        << events_to_yaml(events);
    if (!out) fail(2, "cannot write " + *events_file_ + ": " + std::strerror(errno));
    journal_changed_ = false;
  }

  static int max_measurement_dim(const Scenario& s) {
    int m = 0;
    for (const auto& sensor : s.sensors) m = std::max(m, static_cast<int>(sensor.C.rows()));
    return m;
  }
  PeriodCsvRecorder periods_;
  SampleCsvRecorder samples_;
  std::ofstream periods_out_;
  std::ofstream samples_out_;
  std::ofstream mcap_out_;
  std::unique_ptr<McapRecorder> mcap_;  // declared after its stream: destroyed first
  std::optional<std::string> events_file_;
  std::vector<Journaled> journal_;
  bool journal_changed_ = false;
};

/// Handlers that feed a recording and, when given, the launch's live views and its run summary.
BusHandlers recording_handlers(Recording& recording, LiveViews* views, RunSummaryBuilder* summary,
                               std::uint64_t& invalid) {
  BusHandlers h;
  h.truth = [&recording, views, summary](TruthRecord&& t) {
    recording.truth(t);
    if (views) views->truth(t);
    if (summary) summary->add_truth(t);
  };
  h.estimate = [&recording, views, summary](EstimateRecord&& e) {
    recording.estimate(e);
    if (views) views->estimate(e);
    if (summary) summary->add_estimate(e);
  };
  if (recording.wants_samples()) h.delivered = [&recording](DeliveredRecord&& d) { recording.delivered(d); };
  if (recording.events_file() || views) {
    h.link_change = [&recording, views](LinkChangeRecord&& c) {
      recording.link_change(c);
      if (views) views->link_change(c);
    };
  }
  if (views || summary || recording.wants_link_status()) {
    h.link_status = [&recording, views, summary](LinkStatusRecord&& l) {
      recording.link_status(l);
      if (summary) summary->add_link_status(l);
      if (views) views->link_status(l);
    };
  }
  if (views) h.link_reply = [views](LinkReplyRecord&& r) { views->link_reply(r); };
  h.invalid = [views, &invalid](const std::string& what) {
    ++invalid;
    if (views) views->invalid_sample(what);
    else std::cerr << "netkf: rejected a sample: " << what << "\n";
  };
  return h;
}

/// True when every link is set to lose every sample (then an estimate without samples is right).
bool all_links_drop_everything(const LiveSnapshot& s) {
  for (const auto& l : s.links)
    if (stationary_loss(l.link.loss) < 1.0) return false;
  return true;
}

/// The checkpoint a restarted estimator resumes from: the last estimate it published.
nodes::EstimatorCheckpoint checkpoint_of(const EstimateRecord& e) {
  nodes::EstimatorCheckpoint c;
  const auto n = static_cast<Eigen::Index>(e.xhat.size());
  c.k = static_cast<std::uint64_t>(e.k);
  c.t = e.t;
  c.x_hat = Eigen::Map<const Vector>(e.xhat.data(), n);
  if (e.P.size() != e.xhat.size() * e.xhat.size()) throw std::runtime_error("the last estimate carries no full P");
  c.P = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(e.P.data(), n, n);
  c.restarts = e.restarts + 1;
  c.late_total = e.late_total;
  c.rejected_total = e.rejected;
  return c;
}

Scenario load_or_default(const std::optional<std::string>& file) {
  if (!file) return default_scenario();
  try {
    return load_scenario_file(*file);
  } catch (const std::exception& e) {
    fail(2, e.what());
  }
  return {};
}

// ---------------------------------------------------------------- launch

/// Sensors a live network runs at most (see run_launch).
constexpr std::size_t kMaxLiveSensors = 512;

struct LaunchOptions {
  std::optional<std::string> scenario;
  double duration = 0.0;  // 0: until Ctrl-C
  std::optional<std::string> record;
  std::optional<std::string> record_samples;
  std::optional<std::string> events;  // replay: an events file (what --record journaled)
  NetworkOptions network;
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
  std::vector<std::string> checks;  // "NAME<VALUE", evaluated at the end of the run
  std::optional<std::string> summary;
  double domain_check = 1.5;  // seconds to look for another network on the domain before starting
  std::string only = "all";   // --only: the roles this launch runs (LaunchRoles)
  std::optional<std::uint64_t> run_id;       // --run-id: shared by every host's launch
  std::optional<std::string> serve_discovery;  // --serve-discovery ADDR:PORT
  double ready_timeout = 30.0;  // the plant's wait for the whole network (presence)
};

/// The end of the run for a process that does not run the plant (a launch of part of the
/// network, a recorder): once the plant of `run` (0: any) was seen running, its presence saying
/// it ended — or its leaving — ends this process `linger` later, when the last periods' samples
/// and estimates have arrived.
class RunEndWatch {
 public:
  RunEndWatch(std::uint64_t run, Clock::duration linger) : run_(run), linger_(linger) {}

  void look(const std::vector<dds::PresenceRecord>& processes, Clock::time_point now) {
    if (why_) return;
    bool running = false;
    const dds::PresenceRecord* gone = nullptr;  // a plant of the run that ended or left
    for (const auto& p : processes) {
      if (p.role != dds::presence_role::plant || (run_ != 0 && p.run != run_)) continue;
      if (p.running()) running = true;
      else gone = &p;
    }
    plant_seen_ = plant_seen_ || running;
    if (!plant_seen_ || running || gone == nullptr) return;
    const std::string plant = "the plant (pid " + std::to_string(gone->pid) + " on " + gone->host + ")";
    why_ = gone->ended ? plant + " ended the run" + (gone->detail.empty() ? "" : ": " + gone->detail)
                       : plant + " left the network";
    end_at_ = now + linger_;
  }
  bool over(Clock::time_point now) const { return now >= end_at_; }
  /// Why the run ended (nullopt while it runs).
  const std::optional<std::string>& why() const { return why_; }

 private:
  std::uint64_t run_;
  Clock::duration linger_;
  bool plant_seen_ = false;
  std::optional<std::string> why_;
  Clock::time_point end_at_ = Clock::time_point::max();
};

/// "sensors 1,3 (pid 12 on host-a) scenario 1a2b..." for messages about another run.
std::string describe_other_run(const dds::PresenceRecord& p, std::uint64_t our_hash) {
  if (p.scenario_hash != our_hash) return p.who() + " " + p.other_scenario_text(our_hash, "this launch");
  char text[48];
  std::snprintf(text, sizeof text, " belongs to run %016llx", static_cast<unsigned long long>(p.run));
  return p.who() + text;
}

/// "8", "2.5", "1e+03": a number as a person writes it.
std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

/// 128 random bits as hex: the dashboard's token when it listens beyond 127.0.0.1.
std::string random_token() {
  std::random_device rd;  // the kernel's random source
  char buf[33];
  std::snprintf(buf, sizeof buf, "%08x%08x%08x%08x", rd(), rd(), rd(), rd());
  return buf;
}

/// The end of a run that asked for checks or a summary, once everything is recorded: the
/// checks' table on stdout, the summary's JSON in its file. Returns why the run fails its
/// checks (a check failed, the summary could not be written), or nothing.
std::optional<std::string> conclude_run(const RunSummaryBuilder& builder, const std::vector<Check>& checks,
                                        const Scenario& scenario, const std::string& end,
                                        const std::optional<std::string>& summary_file, std::ofstream& summary_out) {
  const auto results = evaluate_checks(checks, builder.summary());
  if (!results.empty()) std::cout << render_check_table(results) << std::flush;
  std::optional<std::string> failure;
  if (!all_passed(results)) {
    std::size_t failed = 0;
    for (const auto& r : results) failed += !r.passed;
    failure = std::to_string(failed) + " of " + std::to_string(results.size()) + " checks failed";
  }
  if (summary_file) {
    nlohmann::ordered_json j{{"scenario", scenario.name}, {"end", end}};
    const auto body = summary_json(builder.summary(), results);
    for (const auto& item : body.items()) j[item.key()] = item.value();
    summary_out << j.dump(2) << "\n";
    summary_out.flush();
    if (!summary_out) {
      const std::string why = "cannot write the summary to " + *summary_file + ": " + std::strerror(errno);
      failure = failure ? *failure + "; " + why : why;
    }
  }
  return failure;
}

int run_launch(const LaunchOptions& o) {
  const Scenario scenario = [&] {
    Scenario s = load_or_default(o.scenario);
    if (o.events) {
      try {
        add_replayed_events(s, load_events_file(*o.events, s));
      } catch (const std::exception& e) {
        fail(2, e.what());
      }
    }
    return s;
  }();
  const RestartPolicy policy = parse_restart_policy(o.restart_policy);
  // The largest live network measured to run (BENCHMARKS.md, "Sensor count limit"); a larger
  // one started, matched partly and fused nothing.
  if (scenario.sensors.size() > kMaxLiveSensors)
    fail(2, "the scenario has " + std::to_string(scenario.sensors.size()) + " sensors; a live network runs at most " +
                std::to_string(kMaxLiveSensors) + " (the largest measured to run; README, \"Failure behaviour\")");
  std::vector<int> scenario_sensor_ids;
  for (const auto& sensor : scenario.sensors) scenario_sensor_ids.push_back(sensor.id);
  LaunchRoles roles;
  try {
    roles = parse_launch_roles(o.only, scenario_sensor_ids);
  } catch (const std::invalid_argument& e) {
    fail(2, e.what());
  }
  const std::uint64_t scenario_hash = dds::scenario_hash(scenario);
  // Discovery: the localhost profile, or a Discovery Server (this launch's own with
  // --serve-discovery: it lives in this process and ends with it).
  std::optional<dds::DiscoveryServerAddress> served, discovery;
  int domain = 0;
  try {
    domain = dds::resolve_domain(o.network.domain);
    discovery = dds::resolve_discovery_server(o.network.discovery_server);
    if (o.serve_discovery) {
      served = dds::parse_discovery_server(*o.serve_discovery);
      if (discovery && discovery->text() != served->text())
        fail(2, "--serve-discovery " + served->text() + " and --discovery-server " + discovery->text() +
                    " name different servers");
      discovery = served;
    }
  } catch (const dds::DdsError& e) {
    fail(2, e.what());
  }

  // Checks and the summary file are the user's input: a mistake in them is exit 2 before
  // anything starts, not a failed check after a long run.
  std::vector<Check> checks;
  {
    std::vector<int> link_ids;
    for (const auto& sensor : scenario.sensors) link_ids.push_back(sensor.id);
    for (const auto& text : o.checks) {
      try {
        checks.push_back(parse_check(text, link_ids));
      } catch (const std::invalid_argument& e) {
        fail(2, e.what());
      }
    }
  }
  std::ofstream summary_out;
  if (o.summary) {
    summary_out.open(*o.summary, std::ios::trunc);
    if (!summary_out) fail(2, "cannot write " + *o.summary + ": " + std::strerror(errno));
  }
  // Only a run that asks for it keeps the summary's records (a latency per period).
  std::unique_ptr<RunSummaryBuilder> summary;
  if (o.summary || !checks.empty()) summary = std::make_unique<RunSummaryBuilder>(scenario);

  // The launch's private files: the effective scenario the children read, the estimator's
  // checkpoint. A launch killed earlier left its directory and maybe Fast DDS shared-memory
  // files behind: both are cleaned here.
  std::unique_ptr<LaunchFiles> files;
  try {
    files = std::make_unique<LaunchFiles>();
  } catch (const std::exception& e) {
    fail(2, e.what());
  }
  for (const auto& stale : files->removed_stale())
    std::cerr << "netkf launch: removed the files of a launch that is no longer running (" << stale.string() << ")\n";
  remove_stale_shared_memory(domain, "killed processes of earlier runs");
  const auto scenario_path = files->file("scenario.yaml");
  {
    std::ofstream out(scenario_path);
    out << scenario_to_yaml(scenario);
    if (!out) fail(2, "cannot write " + scenario_path.string());
  }
  const auto checkpoint_path = files->file("estimator-checkpoint.json");

  std::unique_ptr<dds::Participant> discovery_server;
  if (served) {
    dds::ParticipantOptions so;
    so.domain = domain;
    so.name = "netkf-discovery-server";
    so.discovery_server = served;
    so.serve_discovery = true;
    if (auto dir = dds::resolve_secure(o.network.secure))
      so.security = dds::ParticipantOptions::Security{*dir, dds::Role::observer};
    try {
      discovery_server = std::make_unique<dds::Participant>(so);
    } catch (const std::exception& e) {
      fail(2, "cannot serve discovery on " + served->text() + ": " + e.what());
    }
  }

  boost::asio::io_context io;
  Recording recording(o.record, o.record_samples, scenario);
  std::unique_ptr<LiveBus> bus;

  // The views first: a dashboard port that is taken fails the launch before anything starts.
  LiveViewsOptions view_options;
  view_options.status_interval = o.status_interval;
  const char* term = std::getenv("TERM");
  view_options.status_screen = o.status_interval > 0 && isatty(STDERR_FILENO) == 1 && term &&
                               std::string(term) != "dumb";
  if (o.dashboard != "off") {
    DashboardOptions d;
    d.port = static_cast<unsigned short>(std::stoi(o.dashboard));
    if (o.dashboard_bind) {
      d.bind = *o.dashboard_bind;
      d.token = random_token();  // listening beyond 127.0.0.1: every request needs it
    }
    d.allowed_origins = o.dashboard_allow_origins;
    view_options.dashboard = d;
  }
  std::unique_ptr<LiveViews> views;
  try {
    views = std::make_unique<LiveViews>(io, scenario, view_options,
                                        [&bus](std::uint64_t id, int sensor_id, const LinkKeys& keys) {
                                          return bus && bus->send_link_control(id, sensor_id, keys);
                                        });
  } catch (const std::exception& e) {
    fail(2, e.what());
  }
  std::uint64_t invalid_samples = 0;
  // This run's id: every node stamps it on its samples and drops those of another run. A launch
  // of the whole network draws one; the launches of one network on several hosts (--only) share
  // one: given (--run-id), or derived alike from the scenario and the domain.
  const std::uint64_t run_id = [&] {
    if (o.run_id) return *o.run_id;
    if (!roles.all) return derived_run_id(scenario_hash, domain);
    std::random_device rd;  // the kernel's random source: an identifier, not part of the experiment
    std::uint64_t id = 0;
    while (id == 0) id = (static_cast<std::uint64_t>(rd()) << 32) | rd();
    return id;
  }();
  // The last estimate seen (io thread): the checkpoint a restarted estimator resumes from.
  std::optional<EstimateRecord> last_estimate;
  std::uint64_t fused_periods = 0;  // estimates that fused at least one sample
  try {
    BusHandlers handlers = recording_handlers(recording, views.get(), summary.get(), invalid_samples);
    handlers.estimate = [record = std::move(handlers.estimate), &last_estimate, &fused_periods](EstimateRecord&& e) {
      fused_periods += e.fused.empty() ? 0 : 1;
      last_estimate = e;
      record(std::move(e));
    };
    // The dashboard retunes links: a launch serving it needs the ctl identity.
    const auto role = view_options.dashboard ? dds::Role::ctl : dds::Role::observer;
    BusOptions bus_options = o.network.bus("netkf-launch", role);
    bus_options.run = run_id;
    if (discovery) bus_options.discovery_server = discovery->text();
    bus_options.presence = BusOptions::Presence{dds::presence_role::launch, scenario_hash, describe_launch_roles(roles)};
    bus = std::make_unique<LiveBus>(io, bus_options, std::move(handlers),
                                    /*link_control_writer=*/view_options.dashboard.has_value());
  } catch (const std::exception& e) {
    fail(2, std::string("DDS: ") + e.what());
  }
  // Another network on this domain (another launch, or nodes started by hand) would mix its
  // samples with ours: before starting anything, look for processes of another run (presence)
  // and, for a launch of the whole network, for writers of the network's topics (nothing of
  // ours writes them yet, so any writer found is someone else's). The launches of one network
  // on several hosts share the run and write from several hosts: only presence tells them apart.
  if (o.domain_check > 0) {
    const auto until = Clock::now() + std::chrono::duration<double>(o.domain_check);
    std::vector<std::pair<std::string, int>> writers;
    std::vector<dds::PresenceRecord> others;
    while (Clock::now() < until) {
      others = dds::other_runs(bus->processes(), run_id);
      if (roles.all) writers = bus->network_writers();
      if (!others.empty() || !writers.empty()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (!others.empty()) {
      const bool other_scenario = others.front().scenario_hash != scenario_hash;
      fail(2, "DDS domain " + std::to_string(domain) + " already carries a netkf network of another run: " +
                  describe_other_run(others.front(), scenario_hash) +
                  (other_scenario ? "; every host of a network must run the same scenario file"
                                  : "; give this run its own domain with --domain N (or NETKF_DOMAIN), or stop the "
                                    "other one (hosts of one network: the same --run-id, or none)"));
    }
    if (!writers.empty()) {
      std::string found;
      for (const auto& [topic, n] : writers) found += (found.empty() ? "" : ", ") + topic + " (" + std::to_string(n) + ")";
      fail(2, "DDS domain " + std::to_string(domain) + " already carries a netkf network (writers on " + found +
                  "), e.g. another `netkf launch`: give this run its own domain with --domain N (or NETKF_DOMAIN), "
                  "or stop the other one");
    }
  }

  auto common_args = [&] {
    std::vector<std::string> a{"--scenario", scenario_path.string(), "--domain", std::to_string(domain),
                               "--log-level", o.log_level, "--run-id", std::to_string(run_id)};
    if (discovery) {
      a.push_back("--discovery-server");
      a.push_back(discovery->text());
    }
    if (o.network.profile) {
      a.push_back("--dds-profile");
      a.push_back(*o.network.profile);
    }
    // Explicit (so a launch secured by $NETKF_SECURE secures its children too) and absolute.
    if (const auto secure = dds::resolve_secure(o.network.secure)) {
      a.push_back("--secure");
      a.push_back(secure->string());
    }
    return a;
  };

  SupervisorOptions so;
  so.policy = policy;
  so.max_restarts = o.max_restarts;
  Supervisor supervisor(so);
  // Trouble: a process that died unexpectedly, a restart, a failure to start; a clean exit
  // (the plant ending the run, or any exit during the stop) is not.
  // The processes of the run: this launch's children, then what the other hosts run (presence).
  const std::string here = dds::this_host();
  auto refresh_processes = [&] {
    auto presences = bus->processes();
    std::vector<ProcessView> processes;
    std::set<int> children;
    for (const auto& c : supervisor.children()) {
      processes.push_back({c.name, c.pid, c.running, c.restarts, here});
      children.insert(c.pid);
    }
    for (const auto& p : presences) {
      if (p.run != run_id || (p.host == here && (children.count(p.pid) || p.pid == getpid()))) continue;
      std::string name = p.role;
      if (!p.sensor_ids.empty()) name = sensor_process_name(p.sensor_ids);
      processes.push_back({name, p.pid, p.running(), 0, p.host});
    }
    views->set_processes(std::move(processes));
    return presences;
  };
  auto report = [&](const std::vector<SupervisorEvent>& events, bool stopping = false) {
    for (const auto& e : events) {
      const bool clean_exit = e.kind == SupervisorEvent::Kind::exited && e.exit.clean();
      const bool trouble = !stopping && e.kind != SupervisorEvent::Kind::started && !clean_exit;
      views->announce(trouble ? LiveEvent::Level::warning : LiveEvent::Level::info, e.message());
      if (e.kind == SupervisorEvent::Kind::restart_scheduled) views->count_restart(e.child);
    }
    if (!events.empty()) refresh_processes();
  };
  std::vector<SupervisorEvent> started;
  // Consumers first, the plant (the clock) last, so period 0 finds its readers.
  if (roles.channel)
    started.push_back(supervisor.start({"channel_emulator", node_executable("channel_emulator"), common_args(), false}));
  if (roles.estimator) {
    // A restarted estimator resumes from the last estimate this launch saw (written just before
    // the restart, after the backoff, so no estimate of the previous life is still in flight).
    auto args = common_args();
    args.push_back("--resume-from");
    args.push_back(checkpoint_path.string());
    auto write_checkpoint_for_restart = [&last_estimate, &checkpoint_path, &views] {
      try {
        if (!last_estimate) {
          std::filesystem::remove(checkpoint_path);
          views->announce(LiveEvent::Level::warning, "the estimator died before its first estimate: it starts afresh");
          return;
        }
        write_checkpoint(checkpoint_path.string(), checkpoint_of(*last_estimate));
      } catch (const std::exception& e) {
        views->announce(LiveEvent::Level::warning, std::string("estimator checkpoint not written: ") + e.what());
      }
    };
    started.push_back(supervisor.start({"estimator_node", node_executable("estimator_node"), args, false, 0},
                                       write_checkpoint_for_restart));
  }
  const std::vector<int>& sensor_ids = roles.sensor_ids;
  const bool auto_grouping = o.sensors_per_process == "auto";
  const unsigned cpus = usable_cpus();
  const int per_process =
      auto_grouping ? auto_sensors_per_process(sensor_ids.size(), cpus) : std::stoi(o.sensors_per_process);
  const auto sensor_groups = sensor_process_groups(sensor_ids, per_process);
  for (const auto& group : sensor_groups) {
    auto args = common_args();
    for (int id : group) {
      args.push_back("--sensor-id");
      args.push_back(std::to_string(id));
    }
    started.push_back(supervisor.start(
        {sensor_process_name(group), node_executable("sensor_node"), args, false, o.sensor_nice}));
  }
  // The plant starts when presence shows the whole network, on every host, and its truth has
  // matched every sensor process, launch and recorder present (so recordings start at k = 0).
  if (roles.plant) {
    auto plant_args = common_args();
    plant_args.push_back("--wait-for-presence");
    // This host's sensor processes and this launch read the truth: counted before their
    // presence arrives (presence adds other hosts' launches and recorders).
    plant_args.push_back("--truth-readers");
    plant_args.push_back(std::to_string(sensor_groups.size() + 1));
    plant_args.push_back("--startup-wait-ms");
    plant_args.push_back(std::to_string(static_cast<long long>(o.ready_timeout * 1000.0)));
    started.push_back(supervisor.start({"plant_node", node_executable("plant_node"), plant_args, true}));
  }
  report(started);
  if (supervisor.failed()) {
    supervisor.stop_all();
    // CI still gets its summary and a verdict per check (all unmeasured) before the failure.
    if (summary) conclude_run(*summary, checks, scenario, "failure: " + supervisor.failure_reason(), o.summary, summary_out);
    fail(1, supervisor.failure_reason());
  }
  if (o.pid_file) {
    // For scripts and tests: name and pid of every child.
    std::ofstream pids(*o.pid_file);
    for (const auto& e : started) pids << e.child << " " << e.pid << "\n";
  }
  std::ostringstream launch_line;
  launch_line << "netkf launch: scenario '" << scenario.name << "' on DDS domain " << domain << ", ";
  if (!roles.all) {
    char run_text[24];
    std::snprintf(run_text, sizeof run_text, "%016llx", static_cast<unsigned long long>(run_id));
    launch_line << "this host runs " << describe_launch_roles(roles) << " (run " << run_text << "; the rest of the "
                << "network on other hosts), ";
  }
  launch_line << sensor_ids.size() << " sensors in " << sensor_groups.size() << " processes"
              << (auto_grouping && per_process > 1
                      ? " (" + std::to_string(per_process) + " per process, auto: at most 2 sensor processes per CPU, " +
                            std::to_string(cpus) + " CPUs; --sensors-per-process 1 for one each)"
                      : std::string())
              << ", period " << scenario.period_ms << " ms"
              << (o.duration > 0 ? ", for " + number_text(o.duration) + " s" : ", Ctrl-C stops");
  if (served) launch_line << "\nnetkf launch: serving discovery on " << served->text();
  else if (discovery) launch_line << "\nnetkf launch: discovery through the server at " << discovery->text();
  if (const auto url = views->dashboard_url()) launch_line << "\nnetkf launch: dashboard: " << *url;
  std::cerr << launch_line.str() << "\n" << std::flush;
  views->set_header(launch_line.str());

  enum class End { running, duration, signal, failed, finished } end = End::running;
  boost::asio::signal_set signals(io, SIGINT, SIGTERM);
  signals.async_wait([&](const boost::system::error_code& ec, int) {
    if (!ec && end == End::running) end = End::signal;
  });
  const auto start = Clock::now();
  boost::asio::steady_timer timer(io);
  RunEndWatch run_end(run_id, std::chrono::seconds(1));  // without the plant: its end is ours
  auto last_presence_look = start;
  std::function<void()> tick = [&] {
    report(supervisor.poll());
    recording.flush();
    const auto now = Clock::now();
    if (now - last_presence_look >= std::chrono::milliseconds(500)) {
      last_presence_look = now;
      const auto processes = refresh_processes();
      if (!roles.plant) run_end.look(processes, now);
    }
    if (end == End::running) {
      if (supervisor.failed()) end = End::failed;
      else if (supervisor.finished() || run_end.over(now)) end = End::finished;
      else if (o.duration > 0 && now - start >= std::chrono::duration<double>(o.duration)) end = End::duration;
    }
    views->tick(now);
    if (end != End::running) {
      io.stop();
      return;
    }
    timer.expires_after(std::chrono::milliseconds(50));
    timer.async_wait([&](const boost::system::error_code& ec) {
      if (!ec) tick();
    });
  };
  tick();
  io.run();

  // Stop: the children get SIGTERM (SIGKILL after the timeout); then take what DDS
  // still delivered so the recording ends with the last complete period.
  views->set_screen(false);  // from here on, plain lines
  report(supervisor.stop_all(), /*stopping=*/true);
  io.restart();
  io.run_for(std::chrono::milliseconds(300));
  recording.flush();
  recording.finish();
  views->stop();
  io.restart();
  io.run_for(std::chrono::milliseconds(50));  // let the dashboard's close frames go out
  signals.cancel();
  const std::string end_text = end == End::duration   ? "duration reached"
                               : end == End::signal   ? "signal"
                               : end == End::finished ? run_end.why().value_or(supervisor.finished_reason())
                                                      : "failure";
  const std::uint64_t foreign_samples = bus->foreign_samples();
  bus->end_presence(end_text);
  bus.reset();
  discovery_server.reset();
  // A child killed during the run (kill -9, or SIGKILL after the stop timeout) left its Fast
  // DDS shared-memory files: every process of the run has ended, so remove them now.
  remove_stale_shared_memory(domain, "killed processes of this run");

  std::cerr << "netkf launch: stopped (" << end_text << "); " << views->model().snapshot().estimates
            << " estimates seen";
  if (foreign_samples > 0) std::cerr << ", " << foreign_samples << " samples of another run on the domain dropped";
  if (o.record)
    std::cerr << ", " << recording.rows() << (is_mcap_path(*o.record) ? " periods in " : " rows in ") << *o.record;
  std::cerr << "\n";
  if (views->model().saw_non_finite() || invalid_samples > 0)
    std::cerr << "netkf launch: WARNING: " << invalid_samples << " invalid samples were rejected\n";
  // A run in which a sensor never sent anything (its process never started, never matched, or
  // the plant ran without it) or in which no estimate arrived is not a run of the scenario: it
  // fails loudly rather than ending "ok" (judged once the run had time: 10 estimates).
  std::optional<std::string> incomplete;
  {
    const auto& snap = views->model().snapshot();
    std::string silent;
    for (const auto& l : snap.links)
      if (l.samples_total == 0) silent += (silent.empty() ? "" : ", ") + std::to_string(l.sensor_id);
    const auto ran_for = std::chrono::duration<double>(Clock::now() - start).count();
    if (end != End::failed && snap.estimates == 0 && ran_for >= 5)
      incomplete = "no estimate arrived during the run: the network never ran";
    else if (end != End::failed && snap.estimates >= 10 && !silent.empty())
      incomplete = "sensors " + silent + " never sent a sample to the channel: the run did not include them";
    else if (end != End::failed && snap.estimates >= 100 && fused_periods == 0 && !all_links_drop_everything(snap))
      incomplete = "no sample was fused in " + std::to_string(snap.estimates) +
                   " periods although the links deliver: the estimator never heard the channel";
  }
  if (incomplete) std::cerr << "netkf launch: ERROR: " << *incomplete << "\n";
  // Checks are judged after everything is recorded; a run that failed keeps its own failure.
  std::optional<std::string> checks_failure;
  if (summary)
    checks_failure = conclude_run(*summary, checks, scenario,
                                  end == End::failed ? "failure: " + supervisor.failure_reason()
                                  : incomplete       ? "failure: " + *incomplete
                                                     : end_text,
                                  o.summary, summary_out);
  if (end == End::failed) fail(1, supervisor.failure_reason());
  if (incomplete) fail(1, *incomplete);
  if (checks_failure) fail(1, *checks_failure);
  return 0;
}

// ---------------------------------------------------------------- record

struct RecordOptions {
  std::optional<std::string> scenario;
  double duration = 0.0;
  std::string out;
  std::optional<std::string> samples;
  NetworkOptions network;
};

int run_record(const RecordOptions& o) {
  const Scenario scenario = load_or_default(o.scenario);
  boost::asio::io_context io;
  Recording recording(o.out, o.samples, scenario);
  std::uint64_t invalid_samples = 0;
  std::unique_ptr<LiveBus> bus;
  try {
    // Present as a recorder: a plant waits for it, so the recording starts at period 0. Its
    // scenario only sizes the recording (hash 0: it conflicts with no network's scenario).
    BusOptions bus_options = o.network.bus("netkf-record", dds::Role::observer);
    bus_options.presence = BusOptions::Presence{dds::presence_role::record, 0, {}};
    bus = std::make_unique<LiveBus>(io, bus_options, recording_handlers(recording, nullptr, nullptr, invalid_samples),
                                    false);
  } catch (const std::exception& e) {
    fail(2, std::string("DDS: ") + e.what());
  }
  bool stop = false;
  boost::asio::signal_set signals(io, SIGINT, SIGTERM);
  signals.async_wait([&](const boost::system::error_code& ec, int) { stop = !ec; });
  const auto start = Clock::now();
  boost::asio::steady_timer timer(io);
  // The recording ends with the run (any run's plant: a recorder has no run id), a little after
  // the launches without the plant, so that it also takes their last estimates.
  RunEndWatch run_end(0, std::chrono::milliseconds(1500));
  auto last_presence_look = start;
  std::function<void()> tick = [&] {
    recording.flush();
    if (Clock::now() - last_presence_look >= std::chrono::milliseconds(500)) {
      last_presence_look = Clock::now();
      run_end.look(bus->processes(), last_presence_look);
    }
    if (stop || run_end.over(Clock::now()) ||
        (o.duration > 0 && Clock::now() - start >= std::chrono::duration<double>(o.duration))) {
      io.stop();
      return;
    }
    timer.expires_after(std::chrono::milliseconds(100));
    timer.async_wait([&](const boost::system::error_code& ec) {
      if (!ec) tick();
    });
  };
  tick();
  io.run();
  recording.flush();
  recording.finish();
  signals.cancel();
  const int domain = bus->domain();
  bus->end_presence(run_end.why().value_or("stopped"));
  bus.reset();
  if (run_end.why()) std::cerr << "netkf record: " << *run_end.why() << "\n";
  std::cerr << "netkf record: " << recording.rows() << (is_mcap_path(o.out) ? " periods" : " rows")
            << " written to " << o.out << "\n";
  if (recording.rows() == 0)
    fail(3, "nothing was recorded: no network answered on DDS domain " + std::to_string(domain) +
                " (is a network running? netkf launch; the same --domain)");
  return 0;
}

// ---------------------------------------------------------------- ctl

/// Run `io` until `done()` or the deadline; true when done.
bool run_until(boost::asio::io_context& io, const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  while (!done()) {
    if (Clock::now() >= deadline) return false;
    io.restart();
    io.run_for(std::chrono::milliseconds(20));
  }
  return true;
}

nlohmann::json link_json(const LinkStatusRecord& l) {
  nlohmann::json j{{"sensor_id", l.sensor_id},
                   {"samples_in", l.samples_in},
                   {"delivered", l.delivered},
                   {"dropped", l.dropped},
                   {"observed_loss", l.observed_loss},
                   {"mean_burst_length", l.mean_burst_length},
                   {"samples_total", l.samples_total},
                   {"delivered_total", l.delivered_total},
                   {"dropped_total", l.dropped_total},
                   {"held", l.held},
                   {"past_deadline", l.past_deadline},
                   {"last_request_id", l.last_request_id}};
  for (const auto& k : link_keys(l.link)) {
    if (const auto* word = std::get_if<std::string>(&k.value)) j[k.name] = *word;
    else j[k.name] = std::get<double>(k.value);
  }
  j["stationary_loss"] = stationary_loss(l.link.loss);
  if (std::holds_alternative<GilbertElliottLink>(l.link.loss)) j["mean_burst"] = mean_burst_length(l.link.loss);
  j["in_time"] = l.in_time;
  j["arrival_rate"] = (1.0 - stationary_loss(l.link.loss)) * l.in_time;  // what reaches the estimator in time
  if (!l.rejection_reason.empty()) j["last_rejection"] = l.rejection_reason;
  return j;
}

struct CtlOptions {
  NetworkOptions network;
  double timeout = 10.0;
  int sensor_id = 0;
  std::optional<double> bernoulli;
  std::vector<double> gilbert_elliott;
  std::optional<std::string> model;
  std::optional<double> loss;
  std::optional<double> mean_burst;
  std::optional<double> delay;
  std::optional<double> jitter;
  std::optional<std::string> distribution;
  std::vector<std::string> set;  // KEY=VALUE
  bool json = false;
};

/// The link keys a `ctl set-link` asks for. Names and number syntax are checked here (exit 2);
/// whether they make a valid link with the link's current state is the channel's answer.
LinkKeys ctl_link_keys(const CtlOptions& o) {
  LinkKeys keys;
  if (o.bernoulli) {
    keys.push_back({"model", std::string("bernoulli")});
    keys.push_back({"loss", *o.bernoulli});
  }
  if (!o.gilbert_elliott.empty()) {
    if (o.gilbert_elliott.size() != 2 && o.gilbert_elliott.size() != 4)
      fail(2, "--gilbert-elliott takes P R [LOSS_GOOD LOSS_BAD] (2 or 4 numbers), got " +
                  std::to_string(o.gilbert_elliott.size()));
    keys.push_back({"model", std::string("gilbert_elliott")});
    keys.push_back({"p", o.gilbert_elliott[0]});
    keys.push_back({"r", o.gilbert_elliott[1]});
    if (o.gilbert_elliott.size() == 4) {
      keys.push_back({"loss_good", o.gilbert_elliott[2]});
      keys.push_back({"loss_bad", o.gilbert_elliott[3]});
    }
  }
  if (o.model) keys.push_back({"model", *o.model});
  if (o.loss) keys.push_back({"loss", *o.loss});
  if (o.mean_burst) keys.push_back({"mean_burst", *o.mean_burst});
  if (o.delay) keys.push_back({"delay_ms", *o.delay});
  if (o.jitter) keys.push_back({"jitter_ms", *o.jitter});
  if (o.distribution) keys.push_back({"delay_distribution", *o.distribution});
  for (const auto& kv : o.set) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) fail(2, "--set takes KEY=VALUE, got '" + kv + "'");
    const std::string name = kv.substr(0, eq);
    const std::string text = kv.substr(eq + 1);
    if (link_key_is_word(name)) {
      keys.push_back({name, text});
      continue;
    }
    std::size_t used = 0;
    double value = 0.0;
    try {
      value = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != text.size()) fail(2, "--set " + name + ": '" + text + "' is not a number");
    keys.push_back({name, value});
  }
  if (keys.empty())
    fail(2, "give what to change: --bernoulli LOSS, --gilbert-elliott P R [LOSS_GOOD LOSS_BAD], --loss, "
            "--mean-burst, --delay, --jitter, --distribution, --model or --set KEY=VALUE");
  // Names, duplicates and word/number kinds: the link type's own check, on a link of the
  // model asked for (or of each model) so that only the current state is left to the channel.
  std::string first_problem;
  for (const LinkSpec& probe : {LinkSpec(BernoulliLink{0.5}), LinkSpec(GilbertElliottLink{0.1, 0.5, 0.0, 1.0})}) {
    try {
      (void)apply_link_keys(probe, keys);
      return keys;
    } catch (const LinkError& e) {
      if (first_problem.empty()) first_problem = e.what();
    }
  }
  fail(2, "invalid link change: " + first_problem);
}

int run_ctl_status(const CtlOptions& o) {
  boost::asio::io_context io;
  std::map<int, LinkStatusRecord> links;
  BusHandlers h;
  h.link_status = [&](LinkStatusRecord&& l) { links[l.sensor_id] = std::move(l); };
  std::unique_ptr<LiveBus> bus;
  try {
    BusOptions bus_options = o.network.bus("netkf-ctl", dds::Role::observer);
    bus_options.presence = BusOptions::Presence{};  // watch who takes part, without announcing
    bus = std::make_unique<LiveBus>(io, bus_options, h, false);
  } catch (const std::exception& e) {
    fail(2, std::string("DDS: ") + e.what());
  }
  const auto timeout = std::chrono::milliseconds(static_cast<int>(o.timeout * 1000));
  if (!run_until(io, [&] { return !links.empty(); }, timeout))
    fail(3, "no link status received within " + number_text(o.timeout) + " s on DDS domain " +
                std::to_string(bus->domain()) + " (is a network running? netkf launch)");
  // Link status is transient-local: the other links arrive in the same burst right
  // after the first; a short grace period collects them.
  run_until(io, [] { return false; }, std::chrono::milliseconds(400));
  std::vector<LinkStatusRecord> list;
  for (auto& [id, l] : links) list.push_back(l);
  // The processes of the network, on every host (presence), running ones first.
  std::vector<dds::PresenceRecord> processes;
  for (const auto& p : bus->processes())
    if (p.running()) processes.push_back(p);
  if (o.json) {
    nlohmann::json j{{"domain", bus->domain()}, {"links", nlohmann::json::array()},
                     {"processes", nlohmann::json::array()}};
    for (const auto& l : list) j["links"].push_back(link_json(l));
    for (const auto& p : processes) {
      char run_text[24];
      std::snprintf(run_text, sizeof run_text, "%016llx", static_cast<unsigned long long>(p.run));
      j["processes"].push_back({{"role", p.role}, {"sensor_ids", p.sensor_ids}, {"host", p.host}, {"pid", p.pid},
                                {"run", run_text}, {"detail", p.detail}});
    }
    std::cout << j.dump(2) << "\n";
  } else {
    std::cout << render_link_table(list);
    if (!processes.empty()) {
      std::cout << "\nprocesses (" << processes.size() << "):\n";
      for (const auto& p : processes)
        std::cout << "  " << p.who() << (p.detail.empty() ? "" : ": " + p.detail) << "\n";
    }
  }
  return 0;
}

int run_ctl_set_link(const CtlOptions& o) {
  const LinkKeys keys = ctl_link_keys(o);

  boost::asio::io_context io;
  std::optional<LinkReplyRecord> reply;
  std::optional<LinkStatusRecord> acknowledged;
  std::uint64_t request_id = 0;
  {
    std::random_device rd;  // a request id unlikely to collide with another ctl's
    request_id = (static_cast<std::uint64_t>(rd()) << 20) ^ static_cast<std::uint64_t>(getpid()) ^
                 static_cast<std::uint64_t>(Clock::now().time_since_epoch().count());
    request_id &= 0x7fffffffffffffffULL;
    if (request_id == 0) request_id = 1;
  }
  BusHandlers h;
  h.link_reply = [&](LinkReplyRecord&& r) {
    if (r.request_id == request_id) reply = r;
  };
  h.link_status = [&](LinkStatusRecord&& l) {
    if (l.last_request_id == request_id) acknowledged = l;
  };
  std::unique_ptr<LiveBus> bus;
  try {
    bus = std::make_unique<LiveBus>(io, o.network.bus("netkf-ctl", dds::Role::ctl), h, true);
  } catch (const std::exception& e) {
    fail(2, std::string("DDS: ") + e.what());
  }
  const auto timeout = std::chrono::milliseconds(static_cast<int>(o.timeout * 1000));
  const auto start = Clock::now();
  if (!run_until(io, [&] { return bus->link_control_readers() > 0 && bus->link_reply_writers() > 0; }, timeout))
    fail(3, "no channel emulator found on DDS domain " + std::to_string(bus->domain()) + " within " +
                number_text(o.timeout) + " s (is a network running? netkf launch)");
  if (!bus->send_link_control(request_id, o.sensor_id, keys)) fail(3, "DDS refused to send the link change");
  const auto left = timeout - std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start);
  if (!run_until(io, [&] { return reply.has_value(); }, std::max(left, std::chrono::milliseconds(1000))))
    fail(3, "the channel emulator did not answer request " + std::to_string(request_id) + " within " +
                number_text(o.timeout) + " s");
  if (!reply->applied) fail(4, "link " + std::to_string(o.sensor_id) + ": change rejected: " + reply->reason);
  // Show the status that acknowledges the request (published right after applying).
  run_until(io, [&] { return acknowledged.has_value(); }, std::chrono::milliseconds(2000));
  if (acknowledged) {
    const auto& l = *acknowledged;
    std::cout << "link " << o.sensor_id << ": applied " << describe_link(l.link) << " (request " << request_id
              << ", effective arrival rate " << (1.0 - stationary_loss(l.link.loss)) * l.in_time << ")\n";
    std::cout << render_link_table({l});
  } else {
    std::cout << "link " << o.sensor_id << ": applied (request " << request_id << ")\n";
  }
  return 0;
}

}  // namespace

/// A wait in seconds: finite, more than 0, at most an hour (NaN, -1 and 1e300 are refused).
CLI::Validator timeout_seconds() {
  return CLI::Validator(
      [](std::string& v) -> std::string {
        try {
          std::size_t used = 0;
          const double s = std::stod(v, &used);
          if (used == v.size() && std::isfinite(s) && s > 0.0 && s <= 3600.0) return {};
        } catch (const std::exception&) {
        }
        return "must be a number of seconds in (0, 3600], got '" + v + "'";
      },
      "SECONDS");
}

void add_launch_command(CLI::App& app) {
  auto o = std::make_shared<LaunchOptions>();
  auto* cmd = app.add_subcommand("launch", "Start and supervise all processes of a scenario on localhost");
  cmd->add_option("scenario", o->scenario, "Scenario YAML (default: built-in three-sensor scenario)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--duration", o->duration, "Stop after S seconds (default: until Ctrl-C)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--record", o->record,
                  "Write one CSV row per period: k,t,x..,xhat..,trace_P,fused,late,state; and the live link changes "
                  "to FILE.events.yaml (replay with --events). FILE.mcap: an MCAP file instead (truth, estimates, "
                  "link status and changes, delivered samples with --record-samples; JSON, for Foxglove/PlotJuggler)");
  cmd->add_option("--events", o->events,
                  "Replay link changes: an events file (as --record writes FILE.events.yaml); at the same period "
                  "they apply before the scenario's own events")
      ->check(CLI::ExistingFile);
  cmd->add_option("--record-samples", o->record_samples,
                  "Write every delivered measurement: k,sensor_id,stamp,fused,y..");
  o->network.add_to(cmd);
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
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
  cmd->add_option("--domain-check", o->domain_check,
                  "Seconds to look for another netkf network on the DDS domain before starting (0: skip)")
      ->check(CLI::Range(0.0, 60.0))
      ->capture_default_str();
  cmd->add_option("--sensor-nice", o->sensor_nice,
                  "CPU priority (nice 0..19) of the sensor processes: they stand in for separate devices; a "
                  "positive value lets the channel and the estimator go first on a small machine")
      ->check(CLI::Range(0, 19))
      ->capture_default_str();
  cmd->add_option("--status-interval", o->status_interval, "Seconds between status updates on stderr (0: none)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--pid-file", o->pid_file, "Write 'name pid' of each started process to FILE");
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
  // One value per --check: a check must never swallow the scenario file that follows it.
  cmd->add_option("--check", o->checks,
                  "Pass/fail check at the end of the run on a summary quantity: NAME<VALUE (or <=, >, >=), e.g. "
                  "'rms_error<0.8', 'link.2.observed_loss<0.35'; repeatable; exit 1 when one fails")
      ->allow_extra_args(false);
  cmd->add_option("--summary", o->summary,
                  "Write the run's summary (rms_error, late_fraction, per-link counts, latency, every check's "
                  "verdict) as JSON to FILE at the end of the run");
  cmd->callback([o] {
    if (const int rc = run_launch(*o); rc != 0) throw CLI::RuntimeError(rc);
  });
}

void add_ctl_command(CLI::App& app) {
  auto o = std::make_shared<CtlOptions>();
  auto* cmd = app.add_subcommand("ctl", "Tune links of a running network and show their status");
  cmd->require_subcommand(1);
  auto* set = cmd->add_subcommand(
      "set-link", "Change one link from its next sample on: only what is given changes (e.g. --delay keeps the loss)");
  set->add_option("id", o->sensor_id, "Sensor id of the link")->required();
  auto* b = set->add_option("--bernoulli", o->bernoulli, "i.i.d. drops with probability LOSS");
  auto* ge = set->add_option("--gilbert-elliott", o->gilbert_elliott,
                             "Gilbert-Elliott P R [LOSS_GOOD LOSS_BAD] (defaults 0 and 1)")
                 ->expected(2, 4);
  b->excludes(ge);
  set->add_option("--model", o->model, "bernoulli or gilbert_elliott (with the keys of that model)");
  set->add_option("--loss", o->loss,
                  "Loss: a bernoulli link's P(drop), or a gilbert_elliott link's stationary loss (with --mean-burst)");
  set->add_option("--mean-burst", o->mean_burst,
                  "gilbert_elliott by the user's form: mean length of a run of drops (>= 1), with --loss");
  set->add_option("--delay", o->delay, "Base delay of a delivered sample, ms");
  set->add_option("--jitter", o->jitter, "Spread of the delay, ms (half-width, sd or scale: see --distribution)");
  set->add_option("--distribution", o->distribution, "Delay distribution: uniform, normal, pareto, paretonormal");
  set->add_option("--set", o->set, "Any link key: KEY=VALUE (docs/scenario-format.md, \"Links\"); repeatable");
  o->network.add_to(set);
  set->add_option("--timeout", o->timeout, "Seconds to wait for the channel emulator's answer")->check(timeout_seconds());
  set->callback([o] {
    if (const int rc = run_ctl_set_link(*o); rc != 0) throw CLI::RuntimeError(rc);
  });
  auto* status = cmd->add_subcommand("status", "Table of links (model, counts, observed loss)");
  status->add_flag("--json", o->json, "One JSON object on stdout");
  o->network.add_to(status);
  status->add_option("--timeout", o->timeout, "Seconds to wait for the first link status")->check(timeout_seconds());
  status->callback([o] {
    if (const int rc = run_ctl_status(*o); rc != 0) throw CLI::RuntimeError(rc);
  });
}

void add_record_command(CLI::App& app) {
  auto o = std::make_shared<RecordOptions>();
  auto* cmd = app.add_subcommand("record", "Record truth and estimates of a running network to CSV");
  cmd->add_option("scenario", o->scenario, "Scenario the network runs (for the state size; default: built-in)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", o->out,
                  "CSV file: k,t,x..,xhat..,trace_P,fused,late,state; or FILE.mcap: an MCAP file (truth, estimates, "
                  "link status and changes; delivered samples with --samples)")
      ->required();
  cmd->add_option("--samples", o->samples, "Also write every delivered measurement to this CSV");
  cmd->add_option("--duration", o->duration, "Stop after S seconds (default: until Ctrl-C)")->check(CLI::NonNegativeNumber);
  o->network.add_to(cmd);
  cmd->callback([o] {
    if (const int rc = run_record(*o); rc != 0) throw CLI::RuntimeError(rc);
  });
}

}  // namespace netkf::cli
