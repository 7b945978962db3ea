#include "netkf/cli/sweep/sweep.hpp"

#include <sys/wait.h>
#include <unistd.h>
#include <fcntl.h>

#include <cerrno>
#include <csignal>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <array>
#include <chrono>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <yaml-cpp/yaml.h>

#include "netkf/cli/common/progress_bar.hpp"
#include "netkf/cli/live/run_summary.hpp"
#include "sha256.hpp"
#include "sweep_report.hpp"
#include "sweep_runs.hpp"
#include "sweep_table.hpp"
#include "netkf/cli/common/exit_code.hpp"
#include "netkf/cli/common/output_file.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/support/input_file.hpp"

namespace netkf::cli::sweep {

std::atomic<bool> stop_requested{false};

namespace fs = std::filesystem;

namespace {

/// Bad input: the sweep ends with status 2 before any run.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Ctrl-C or SIGTERM during the validation: the sweep ends with status 1 before any run.
struct StoppedBeforeRuns : std::runtime_error {
  using std::runtime_error::runtime_error;
};

bool stopping() { return stop_requested.load(); }

// The process groups of the running live launches, one per job slot, for kill_live_runs() on
// the signal thread (0: none).
std::array<std::atomic<pid_t>, 64> live_groups{};

void note_live_group(int slot, pid_t pid) {
  if (slot >= 0 && static_cast<std::size_t>(slot) < live_groups.size()) live_groups[static_cast<std::size_t>(slot)] = pid;
}

std::string read_text(const fs::path& path) {
  try {
    return read_input_file(path, "scenario file", max_yaml_input_bytes);
  } catch (const InputFileError& e) {
    throw InputError(e.what());
  }
}

/// Everything fixed before the first run.
struct Plan {
  YAML::Node tree;                    // the scenario file's
  std::string sha256;
  std::vector<Point> grid;
  // Every point's scenario passed the loader (with the file's seed, as `netkf analyze` sees it);
  // only the first is kept (a grid of 10^5 points would hold 10^5 scenarios).
  std::optional<Scenario> first;
  std::vector<std::string> quantities;
  std::vector<Check> checks;
  double period_s = 0.0;
};

Plan make_plan(const SweepConfig& config) {
  Plan plan;
  const std::string text = read_text(config.scenario_path);
  plan.sha256 = sha256_hex(text);
  if (!config.expected_sha256.empty() && config.expected_sha256 != plan.sha256)
    throw InputError(config.scenario_path + " changed since the sweep started (sha256 " + plan.sha256 +
                     ", sweep.yaml has " + config.expected_sha256 + "): start a new sweep");
  try {
    plan.tree = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(config.scenario_path + ": " + e.what());
  }
  try {
    check_grid_size(config.vary, config.seeds);
    plan.grid = expand_grid(config.vary);
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  for (const auto& point : plan.grid) {
    if (stopping())
      throw StoppedBeforeRuns("stopped while checking the points (" + std::to_string(point.index) + " of " +
                              std::to_string(plan.grid.size()) + " checked); nothing was run");
    const std::string name = config.scenario_path + " (point " + std::to_string(point.index) + ": " +
                             point_label(config.vary, point) + ")";
    try {
      Scenario s = parse_scenario(run_scenario_yaml(plan.tree, config.vary, point, 0), name);
      if (!plan.first) plan.first = std::move(s);
    } catch (const std::exception& e) {
      // The loader's message names the field; the source name names the point.
      const std::string what = e.what();
      throw InputError(what.find(name) == std::string::npos ? name + ": " + what : what);
    }
  }
  std::vector<int> ids;
  for (const auto& s : plan.first->sensors) ids.push_back(s.id);
  if (plan.first->actuation_link()) ids.push_back(kControlLinkId);
  plan.quantities = summary_names(ids);
  try {
    for (const auto& c : config.checks) plan.checks.push_back(parse_check(c, ids));
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  plan.period_s = plan.first->period_s();
  return plan;
}

/// runs.csv opened for appending, holding the header and the rows kept from before.
std::vector<RunRow> open_runs_file(const SweepConfig& config, const Plan& plan, bool resume) {
  const fs::path path = fs::path(config.out) / "runs.csv";
  std::vector<RunRow> kept;
  if (resume && fs::exists(path)) {
    try {
      InputFile in(path, "runs.csv", std::numeric_limits<std::uintmax_t>::max());  // a regular file only
      for (auto& r : read_runs_csv(in.stream(), config.vary, plan.quantities))
        if (r.ok) kept.push_back(std::move(r));  // a failed run is run again
    } catch (const std::runtime_error& e) {
      throw InputError(path.string() + ": " + e.what());
    }
  } else if (!resume && fs::exists(path)) {
    throw InputError(config.out + " already holds a sweep: finish it with --resume " + config.out +
                     ", or give another --out");
  }
  std::ofstream out(path, std::ios::trunc);
  out << runs_header(config.vary, plan.quantities) << "\n";
  for (const auto& r : kept) out << runs_line(r, plan.grid[static_cast<std::size_t>(r.point)]) << "\n";
  if (!out) throw std::runtime_error("cannot write " + path.string());
  return kept;
}

/// Appends one finished run to runs.csv at once (a cut sweep keeps it).
void append_row(const SweepConfig& config, const Plan& plan, const RunRow& row) {
  std::ofstream out(fs::path(config.out) / "runs.csv", std::ios::app);
  out << runs_line(row, plan.grid[static_cast<std::size_t>(row.point)]) << "\n";
}

struct PendingRun {
  int point = 0;
  int seed = 0;
};

std::vector<PendingRun> pending_runs(const SweepConfig& config, const Plan& plan, const std::vector<RunRow>& kept) {
  const auto done = done_runs(kept);
  std::vector<PendingRun> pending;
  for (const auto& p : plan.grid)
    for (int seed = 1; seed <= config.seeds; ++seed)
      if (!done.count({p.index, seed})) pending.push_back({p.index, seed});
  return pending;
}

void run_offline(const SweepConfig& config, const Plan& plan, const std::vector<PendingRun>& pending,
                 std::vector<RunRow>& rows, ProgressBar& bar, std::size_t total, std::ostream& err) {
  const std::int64_t periods = run_periods(config, plan.period_s);
  for (const auto& run : pending) {
    if (stopping()) return;
    const Point& point = plan.grid[static_cast<std::size_t>(run.point)];
    RunRow row{run.point, run.seed, true, {}};
    try {
      const Scenario s = parse_scenario(run_scenario_yaml(plan.tree, config.vary, point, run.seed), config.scenario_path);
      row.values = summary_values(offline_summary(s, periods, stopping), plan.quantities);
    } catch (const RunStopped&) {
      return;  // not done: --resume runs it
    } catch (const std::exception& e) {
      row.ok = false;
      row.values.assign(plan.quantities.size(), std::nullopt);
      err << "netkf sweep: run " << run.point << "/" << run.seed << " (" << point_label(config.vary, point)
          << ") failed: " << e.what() << "\n";
    }
    append_row(config, plan, row);
    rows.push_back(std::move(row));
    bar.update(static_cast<std::int64_t>(rows.size()), static_cast<std::int64_t>(total));
  }
}

// ------------------------------------------------------------------ live runs

struct Child {
  pid_t pid = -1;
  PendingRun run;
  int slot = 0;
  fs::path summary;
};

fs::path run_file(const SweepConfig& config, const PendingRun& run, const char* ext) {
  return fs::path(config.out) / "runs" /
         ("p" + std::to_string(run.point) + "-s" + std::to_string(run.seed) + ext);
}

/// `netkf launch RUN.yaml --duration D --summary RUN.json --domain DOMAIN --dashboard off` in its own process
/// group (the terminal's Ctrl-C reaches the sweep only, which ends the child cleanly), its
/// output in RUN.log.
Child start_child(const SweepConfig& config, const Plan& plan, const PendingRun& run, int slot) {
  const fs::path yaml = run_file(config, run, ".yaml");
  {
    std::ofstream out(yaml);
    out << run_scenario_yaml(plan.tree, config.vary, plan.grid[static_cast<std::size_t>(run.point)], run.seed);
  }
  Child c{-1, run, slot, run_file(config, run, ".json")};
  fs::remove(c.summary);
  char duration[32];
  std::snprintf(duration, sizeof duration, "%.6g", run_duration_s(config, plan.period_s));
  std::vector<std::string> args = {config.netkf_exe, "launch", yaml.string(), "--duration", duration,
                                   "--summary", c.summary.string(), "--domain",
                                   std::to_string(live_domain(config, slot)), "--status-interval", "0",
                                   "--dashboard", "off",  // no port for parallel runs to fight over
                                   // A point beyond the critical rate diverges: a result, not a failed run.
                                   "--allow-divergence"};
  const std::string log = run_file(config, run, ".log").string();
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  c.pid = fork();
  if (c.pid < 0) throw std::runtime_error("cannot start a launch: fork failed");
  if (c.pid == 0) {
    setpgid(0, 0);
    // The sweep's thread blocks Ctrl-C and SIGTERM (its signal thread takes them); the launch
    // must get them.
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    // Appended: the log of a failed attempt stays when --resume runs it again.
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      dup2(fd, 1);
      dup2(fd, 2);
      close(fd);
    }
    execv(argv[0], argv.data());
    _exit(127);
  }
  setpgid(c.pid, c.pid);
  note_live_group(slot, c.pid);
  return c;
}

/// The run's row from its launch's summary; a launch that failed (or wrote no summary) is a
/// failed run, said on `err` with its log.
RunRow finished_row(const SweepConfig& config, const Child& c, int status, const std::vector<std::string>& quantities,
                    std::ostream& err) {
  RunRow row{c.run.point, c.run.seed, false, std::vector<std::optional<double>>(quantities.size())};
  std::string why;
  if (!WIFEXITED(status)) why = "the launch ended by signal " + std::to_string(WTERMSIG(status));
  else if (WEXITSTATUS(status) != 0) why = "the launch exited " + std::to_string(WEXITSTATUS(status));
  if (why.empty()) {
    try {
      std::ifstream in(c.summary);
      row.values = summary_values(nlohmann::json::parse(in), quantities);
      row.ok = true;
      return row;
    } catch (const std::exception& e) {
      why = std::string("its summary is unreadable: ") + e.what();
    }
  }
  err << "netkf sweep: run " << c.run.point << "/" << c.run.seed << " failed: " << why << " (log "
      << run_file(config, c.run, ".log").string() << ")\n";
  return row;
}

/// Ends the running launches as Ctrl-C would (SIGINT to each group), waits for them; their runs
/// are not done.
void stop_children(std::vector<Child>& running) {
  for (const auto& c : running) kill(-c.pid, SIGINT);
  for (const auto& c : running) {
    int status = 0;
    while (waitpid(c.pid, &status, 0) < 0 && errno == EINTR) {
    }
    note_live_group(c.slot, 0);
  }
  running.clear();
}

void run_live(const SweepConfig& config, const Plan& plan, const std::vector<PendingRun>& pending,
              std::vector<RunRow>& rows, ProgressBar& bar, std::size_t total, std::ostream& err) {
  fs::create_directories(fs::path(config.out) / "runs");
  std::vector<Child> running;
  std::size_t next = 0;
  while (next < pending.size() || !running.empty()) {
    if (stopping()) return stop_children(running);
    while (next < pending.size() && static_cast<int>(running.size()) < config.jobs) {
      std::set<int> used;
      for (const auto& c : running) used.insert(c.slot);
      int slot = 0;
      while (used.count(slot)) ++slot;
      running.push_back(start_child(config, plan, pending[next++], slot));
    }
    // Signals are taken by the signal thread, so no wait here is cut short by one: look often.
    int status = 0;
    const pid_t pid = waitpid(-1, &status, WNOHANG);
    if (pid <= 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    for (auto it = running.begin(); it != running.end(); ++it) {
      if (it->pid != pid) continue;
      note_live_group(it->slot, 0);
      RunRow row = finished_row(config, *it, status, plan.quantities, err);
      running.erase(it);
      append_row(config, plan, row);
      rows.push_back(std::move(row));
      bar.update(static_cast<std::int64_t>(rows.size()), static_cast<std::int64_t>(total));
      break;
    }
  }
}

// ------------------------------------------------------------------ outputs

bool holds(double v, const Check& c) {
  switch (c.op) {
    case CheckOp::less: return v < c.threshold;
    case CheckOp::less_equal: return v <= c.threshold;
    case CheckOp::greater: return v > c.threshold;
    case CheckOp::greater_equal: return v >= c.threshold;
  }
  return false;
}

/// Each check on each point's mean; prints the failed points; true when all passed.
bool check_points(const SweepConfig& config, const Plan& plan, const std::vector<RunRow>& rows, std::ostream& err) {
  bool all = true;
  for (const auto& check : plan.checks) {
    const auto q = static_cast<std::size_t>(
        std::find(plan.quantities.begin(), plan.quantities.end(), check.name) - plan.quantities.begin());
    for (const auto& point : plan.grid) {
      const Stats s = point_stats(point.index, q, rows);
      if (s.mean && holds(*s.mean, check)) continue;
      all = false;
      err << "netkf sweep: check '" << check.text << "' FAILED at point " << point.index << " ("
          << point_label(config.vary, point) << "): "
          << (s.mean ? "mean " + cell(s.mean) : std::string("not measured in any run")) << "\n";
    }
  }
  return all;
}

/// points.csv and report.html. The theory of each point is computed here: of every point, or
/// after a stop during the runs of the points with a finished run; a stop while this runs
/// leaves the remaining points' theory out. Returns the points whose theory was left out.
std::size_t write_outputs(const SweepConfig& config, const Plan& plan, const std::vector<RunRow>& rows,
                          const ReportAssets& assets) {
  const bool stopped_before = stopping();
  std::set<int> done;
  for (const auto& r : rows)
    if (r.ok) done.insert(r.point);
  std::vector<Theory> theory(plan.grid.size());  // empty cells: no analysis for the point
  std::size_t left_out = 0;
  for (const auto& p : plan.grid) {
    if (stopped_before && !done.count(p.index)) continue;
    if (!stopped_before && stopping()) {
      ++left_out;
      continue;
    }
    try {
      const Scenario s = parse_scenario(run_scenario_yaml(plan.tree, config.vary, p, 0), config.scenario_path);
      theory[static_cast<std::size_t>(p.index)] = point_theory(s);
    } catch (const std::exception&) {
    }
  }
  std::ostringstream points;
  points << points_header(config.vary, plan.quantities) << "\n";
  for (const auto& p : plan.grid)
    points << points_line(p, plan.quantities.size(), rows, theory[static_cast<std::size_t>(p.index)]) << "\n";
  ReportData data{config.scenario_path, config.live ? "live" : "offline", config.seeds, config.vary, plan.grid,
                  plan.quantities, rows, theory};
  try {
    write_output_file({"--out", (fs::path(config.out) / "points.csv").string()}, points.str());
    write_output_file({"--out", (fs::path(config.out) / "report.html").string()},
                      render_report(data, assets.uplot_js, assets.uplot_css));
  } catch (const CommandError& e) {  // after the runs: a failed write, not bad usage
    fail(ExitCode::run_failed, e.what());
  }
  return left_out;
}

}  // namespace

int live_domain(const SweepConfig& config, int slot) { return config.domain_base + 2 * slot; }

void kill_live_runs() {
  for (auto& group : live_groups)
    if (const pid_t pid = group.load(); pid > 0) kill(-pid, SIGKILL);
}

std::int64_t run_periods(const SweepConfig& config, double period_s) {
  if (config.periods) return *config.periods;
  const double d = config.duration_s.value_or(kDefaultDurationS);
  return std::max<std::int64_t>(1, static_cast<std::int64_t>(std::llround(d / period_s)));
}

double run_duration_s(const SweepConfig& config, double period_s) {
  if (config.duration_s) return *config.duration_s;
  if (config.periods) return static_cast<double>(*config.periods) * period_s;
  return kDefaultDurationS;
}

int run_sweep(const SweepConfig& config, bool resume, const ReportAssets& assets, std::ostream& err) {
  Plan plan;
  std::vector<RunRow> rows;
  try {
    plan = make_plan(config);
    if (config.live && config.netkf_exe.empty()) throw InputError("no netkf executable to launch the runs");
    fs::create_directories(config.out);
    rows = open_runs_file(config, plan, resume);
    write_output_file({"--out", (fs::path(config.out) / "sweep.yaml").string()}, sweep_yaml(config, plan.sha256));
  } catch (const StoppedBeforeRuns& e) {
    err << "netkf sweep: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    err << "netkf sweep: error: " << e.what() << "\n";
    return 2;
  }
  const auto pending = pending_runs(config, plan, rows);
  const std::size_t total = plan.grid.size() * static_cast<std::size_t>(config.seeds);
  {
    ProgressBar bar(err, config.live ? "sweep (live)" : "sweep (offline)", progress_bar_wanted(stderr_is_terminal(), false));
    bar.update(static_cast<std::int64_t>(rows.size()), static_cast<std::int64_t>(total));
    if (config.live) run_live(config, plan, pending, rows, bar, total, err);
    else run_offline(config, plan, pending, rows, bar, total, err);
  }
  const std::size_t theory_left_out = write_outputs(config, plan, rows, assets);
  int status = check_points(config, plan, rows, err) ? 0 : 1;
  const auto failed = static_cast<std::size_t>(std::count_if(rows.begin(), rows.end(), [](const RunRow& r) { return !r.ok; }));
  if (failed > 0) {
    err << "netkf sweep: " << failed << " run(s) could not run (status failed in runs.csv)\n";
    status = 1;
  }
  if (rows.size() < total) {
    err << "netkf sweep: stopped with " << rows.size() << " of " << total << " runs done; finish with netkf sweep --resume "
        << config.out << "\n";
    status = 1;
  } else if (theory_left_out > 0) {
    // Every run was done, but the stop came before the report had the theory of every point.
    err << "netkf sweep: stopped while writing the report: the theory of " << theory_left_out << " of "
        << plan.grid.size() << " points is left out of points.csv and report.html; netkf sweep --resume "
        << config.out << " writes them whole\n";
    status = 1;
  }
  return status;
}

}  // namespace netkf::cli::sweep
