#pragma once
// `netkf sweep`: a scenario run over a grid of key values × seeds, offline or live, with the
// files of sweep_table.hpp, sweep.yaml (what --resume needs) and report.html
// (docs/experiments.md, "Sweeps").
#include <atomic>
#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "netkf/cli/sweep/sweep_spec.hpp"

namespace netkf::cli::sweep {

struct SweepConfig {
  std::vector<std::string> command;  // argv as given (recorded in sweep.yaml)
  std::string scenario_path;
  std::vector<Vary> vary;
  int seeds = 1;                     // seed indexes 1..seeds
  std::optional<double> duration_s;  // one of the two; neither: kDefaultDurationS
  std::optional<std::int64_t> periods;
  bool live = false;
  int jobs = 1;                      // live runs at a time
  int domain_base = 0;               // live: job slot j runs on DDS domain live_domain(config, j)
  std::string out;                   // DIR
  std::vector<std::string> checks;
  std::string netkf_exe;             // live: the netkf executable that launches each run
  std::string expected_sha256;       // --resume: the scenario's hash in sweep.yaml (checked)
};

inline constexpr double kDefaultDurationS = 10.0;

/// The DDS domain of live job slot j: domain_base + 2 j. Adjacent domains are not apart on one
/// host: a participant's loopback discovery probes 128 participant ids, 2 ports each (dds/,
/// participant.cpp), past the 250 ports of its domain into the next one's, where the domain
/// guard of a launch saw the other job's launch.
int live_domain(const SweepConfig& config, int slot);

/// A run's periods (offline) from --periods or --duration / the period.
std::int64_t run_periods(const SweepConfig& config, double period_s);
/// A run's --duration (live) from --duration or --periods × the period.
double run_duration_s(const SweepConfig& config, double period_s);

/// sweep.yaml's text: the command, the scenario's path and sha256, the netkf version, the
/// varied keys with their values, seeds, duration or periods, mode, jobs, domain base, checks.
std::string sweep_yaml(const SweepConfig& config, const std::string& scenario_sha256);
/// The config of a sweep directory (for --resume), with its recorded scenario sha256. Throws
/// std::runtime_error for a missing or malformed sweep.yaml.
SweepConfig read_sweep_yaml(const std::string& dir, std::string& scenario_sha256);

/// The page's script and style, inlined into report.html (the dashboard's embedded uPlot).
struct ReportAssets {
  std::string_view uplot_js;
  std::string_view uplot_css;
};

/// Set on Ctrl-C or SIGTERM (by the signal thread of sweep_command.cpp): every phase looks at it
/// often (each point checked, every few thousand periods of an offline run, every 20 ms of the
/// live runs, each point's theory): stop starting runs, end the running ones, keep what is done.
extern std::atomic<bool> stop_requested;
/// SIGKILL the process groups of the running live launches (a second Ctrl-C: quit at once).
void kill_live_runs();

/// Runs the sweep (resuming: skips the ok runs already in DIR/runs.csv) and writes the files.
/// Returns the exit status: 0 done and every check passed, 1 a check failed on some point or the
/// sweep was stopped or a run failed, 2 bad input (a point's scenario the loader refuses, a bad
/// check, a DIR of another sweep). Messages go to `err`.
int run_sweep(const SweepConfig& config, bool resume, const ReportAssets& assets, std::ostream& err);

}  // namespace netkf::cli::sweep
