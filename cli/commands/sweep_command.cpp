// `netkf sweep`: a scenario over a grid of key values × seeds, offline or live, into a directory
// of CSV files, sweep.yaml and report.html (cli/sweep/, docs/experiments.md "Sweeps").
#include <pthread.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "command_options.hpp"
#include "netkf/cli/commands/commands.hpp"
#include "netkf/cli/dashboard/assets.hpp"
#include "netkf/cli/sweep/sweep.hpp"

namespace netkf::cli {
namespace {

struct SweepArgs {
  std::string scenario;
  std::vector<std::string> vary;
  int seeds = 1;
  std::optional<double> duration;
  std::optional<std::int64_t> periods;
  bool live = false, offline = false;
  int jobs = 1;
  std::optional<int> domain;
  std::string out, resume;
  std::vector<std::string> checks;
};

void on_stop_signal(int) { sweep::stop_requested = true; }

/// Runs `work` on a thread of its own while this thread takes Ctrl-C and SIGTERM (blocked in
/// the worker, sigtimedwait here): no slow work ever stands between a signal and the stop. The
/// first signal asks the sweep to stop (each phase looks at sweep::stop_requested often); a
/// second one quits at once, killing the running launches. A handler is installed too, in case
/// the signal reaches a thread that does not block it.
int run_stoppable(const std::function<int()>& work) {
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGINT);
  sigaddset(&stop, SIGTERM);
  struct sigaction sa {}, old_int {}, old_term {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);
  sigset_t old_mask;
  pthread_sigmask(SIG_BLOCK, &stop, &old_mask);
  std::atomic<bool> done{false};
  int status = 1;
  std::exception_ptr error;  // rethrown here, as if the work had run on this thread
  std::thread worker([&] {
    try {
      status = work();
    } catch (...) {
      error = std::current_exception();
    }
    done = true;
  });
  int signals = 0;
  while (!done) {
    const timespec tick{0, 50'000'000};
    const int sig = sigtimedwait(&stop, nullptr, &tick);
    if (sig <= 0) continue;
    sweep::stop_requested = true;
    if (++signals == 1) {
      std::cerr << "\nnetkf sweep: " << (sig == SIGINT ? "Ctrl-C" : "SIGTERM")
                << ": stopping (the running runs are ended, what is done is kept); again to quit at once\n"
                << std::flush;
    } else {
      sweep::kill_live_runs();
      std::cerr << "\nnetkf sweep: quit at once: runs.csv keeps the finished runs; points.csv and report.html may be "
                   "missing or incomplete (netkf sweep --resume DIR writes them)\n"
                << std::flush;
      std::_Exit(1);
    }
  }
  worker.join();
  // A signal that came as the work ended is taken here, not by the default action on unblocking.
  const timespec now{0, 0};
  while (sigtimedwait(&stop, nullptr, &now) > 0) {
  }
  pthread_sigmask(SIG_SETMASK, &old_mask, nullptr);
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  if (error) std::rethrow_exception(error);
  return status;
}

[[noreturn]] void usage_error(const std::string& message) {
  std::cerr << "netkf sweep: error: " << message << "\n";
  throw CLI::RuntimeError(2);
}

namespace fs = std::filesystem;

int default_domain() {
  const char* env = std::getenv("NETKF_DOMAIN");
  return env ? std::atoi(env) : 0;
}

/// The config from the flags (a new sweep) or from DIR/sweep.yaml (--resume DIR).
sweep::SweepConfig make_config(const SweepArgs& a, const std::vector<std::string>& argv) {
  sweep::SweepConfig c;
  if (!a.resume.empty()) {
    if (!a.scenario.empty() || !a.vary.empty() || !a.out.empty())
      usage_error("--resume DIR takes everything from DIR/sweep.yaml: give no scenario, --vary or --out");
    try {
      c = sweep::read_sweep_yaml(a.resume, c.expected_sha256);
    } catch (const std::exception& e) {
      usage_error(e.what());
    }
  } else {
    if (a.scenario.empty() || a.out.empty()) usage_error("give a scenario and --out DIR (or --resume DIR)");
    if (a.live && a.offline) usage_error("--live and --offline exclude each other");
    c.command = argv;
    c.scenario_path = a.scenario;
    try {
      for (const auto& v : a.vary) c.vary.push_back(sweep::parse_vary(v));
    } catch (const std::exception& e) {
      usage_error(e.what());
    }
    c.seeds = a.seeds;
    c.duration_s = a.duration;
    c.periods = a.periods;
    c.live = a.live;
    c.jobs = a.jobs;
    c.domain_base = a.domain.value_or(default_domain());
    c.out = a.out;
    c.checks = a.checks;
    std::error_code ec;
    if (fs::exists(fs::symlink_status(c.out, ec)) && !fs::is_directory(c.out, ec))
      usage_error("--out " + c.out + " is not a directory (the sweep writes its files into DIR)");
  }
  if (c.live && sweep::live_domain(c, c.jobs - 1) > 232)
    usage_error("the live runs' DDS domains pass 232: lower --domain or --jobs");
  std::error_code ec;
  c.netkf_exe = std::filesystem::read_symlink("/proc/self/exe", ec).string();
  return c;
}

}  // namespace

void add_sweep_command(CLI::App& app, const std::vector<std::string>& argv) {
  auto a = std::make_shared<SweepArgs>();
  auto* cmd = app.add_subcommand("sweep", "Run a scenario over a grid of key values x seeds; CSV files and an HTML report");
  cmd->add_option("scenario", a->scenario, "scenario YAML file");
  cmd->add_option("--vary", a->vary,
                  "KEY=V1,V2,... or KEY=FROM:TO:N (repeatable; the grid is their product). KEY: a scenario path, "
                  "e.g. sensors.2.link.loss (sensor id 2), sensors.*.link.mean_burst, estimator.deadline_ms, plant.A.0.0");
  cmd->add_option("--seeds", a->seeds, "seeds per point (1..N, derived from the scenario's seed)")->check(CLI::Range(1, 100000));
  auto* duration = cmd->add_option("--duration", a->duration, "seconds per run (default 10)")
                       ->check(seconds_in(0.0, kMaxDurationSeconds, /*above_min=*/true));
  cmd->add_option("--periods", a->periods, "periods per run (instead of --duration)")
      ->check(CLI::Range(std::int64_t{1}, std::int64_t{100000000}))
      ->excludes(duration);
  cmd->add_flag("--live", a->live, "each run a real `netkf launch` (DDS, the channel emulator)");
  cmd->add_flag("--offline", a->offline, "each run the core filter and loss models, no DDS (the default; fast)");
  cmd->add_option("--jobs", a->jobs, "live runs at a time (default 1)")->check(CLI::Range(1, 64));
  cmd->add_option("--domain", a->domain, "first DDS domain of the live runs: job j uses DOMAIN + 2j (default $NETKF_DOMAIN, else 0)")
      ->check(CLI::Range(0, 232));
  cmd->add_option("--out", a->out, "directory to write (runs.csv, points.csv, sweep.yaml, report.html)");
  cmd->add_option("--check", a->checks, "NAME<VALUE etc. on every point's mean (repeatable; as launch --check)");
  cmd->add_option("--resume", a->resume, "finish the sweep in DIR, skipping its done runs");
  cmd->callback([a, argv] {
    const sweep::SweepConfig config = make_config(*a, argv);
    const auto* js = dashboard::find_asset("/uPlot.iife.min.js");
    const auto* css = dashboard::find_asset("/uPlot.min.css");
    const sweep::ReportAssets assets{js ? js->body : "", css ? css->body : ""};
    const int status = run_stoppable([&] { return sweep::run_sweep(config, !a->resume.empty(), assets, std::cerr); });
    if (status == 0) std::cout << "wrote " << config.out << "/{runs.csv,points.csv,sweep.yaml,report.html}\n";
    if (status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace netkf::cli
