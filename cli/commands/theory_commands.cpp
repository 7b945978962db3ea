// `netkf analyze` and `netkf simulate`: the theory toolkit beside the live network
// (docs/architecture.md, "Contracts": the JSON keys are fixed there).
#include <cmath>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "netkf/cli/commands/commands.hpp"
#include "netkf/cli/common/progress_bar.hpp"
#include "netkf/cli/theory/measured_links.hpp"
#include "netkf/cli/theory/theory_plot.hpp"
#include "netkf/cli/theory/theory_text.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/sim/monte_carlo.hpp"
#include "netkf/theory/report.hpp"

namespace netkf::cli {
namespace {

using nlohmann::json;

// Loads the scenario or prints one clear error and ends the command with status 2.
Scenario load_or_fail(const std::string& command, const std::string& path) {
  try {
    return load_scenario_file(path);
  } catch (const std::exception& e) {
    std::cerr << "netkf " << command << ": error: " << e.what() << "\n";
    throw CLI::RuntimeError(2);
  }
}

// A --plot path that cannot be written: one clear error before any work, status 2.
void check_plot_or_fail(const std::string& command, const std::string& path) {
  if (path.empty()) return;
  try {
    check_plot_output(path);
  } catch (const std::exception& e) {
    std::cerr << "netkf " << command << ": error: " << e.what() << "\n";
    throw CLI::RuntimeError(2);
  }
}

// `analyze --link ID=TRACE`: the traces fitted into the scenario, or one clear error, status 2.
std::vector<MeasuredLink> fit_links_or_fail(Scenario& s, const std::vector<std::string>& specs) {
  try {
    return fit_measured_links(s, specs);
  } catch (const std::exception& e) {
    std::cerr << "netkf analyze: error: " << e.what() << "\n";
    throw CLI::RuntimeError(2);
  }
}

[[noreturn]] void fail(const std::string& command, const std::string& message) {
  std::cerr << "netkf " << command << ": error: " << message << "\n";
  throw CLI::RuntimeError(1);
}

struct AnalyzeArgs {
  std::string file;
  bool json = false, region = false, sweep = false, no_lmi = false, lmi_always = false;
  int points = 0;
  std::optional<int> region_sensor;
  std::string plot;
  std::vector<std::string> links;
};

void add_analyze_options(CLI::App& cmd, AnalyzeArgs& args) {
  cmd.add_option("scenario", args.file, "scenario YAML file")->required();
  cmd.add_flag("--json", args.json, "print one JSON object (keys: docs/architecture.md, 'Contracts')");
  cmd.add_flag("--region", args.region,
               "two sensors: stability region bounds over a grid of lambda1; one sensor (or --region-sensor) and an "
               "actuation link: the (gamma, nu) region");
  cmd.add_option("--region-sensor", args.region_sensor,
                 "with --region and an actuation link: the sensor ID of the (gamma, nu) region");
  cmd.add_flag("--sweep", args.sweep, "Tr S-bar and Tr V-bar over a grid of the shared arrival rate");
  cmd.add_option("--points", args.points, "grid points for --sweep / --region")->check(CLI::Range(2, 10001));
  cmd.add_flag("--no-lmi", args.no_lmi, "skip the CSDP LMI (upper bounds from the g iteration only)");
  cmd.add_flag("--lmi-always", args.lmi_always, "solve the LMI whatever its size (slow above ~50 rows)");
  cmd.add_option("--plot", args.plot, "write the figure (PNG or SVG) with gnuplot");
  cmd.add_option("--link", args.links,
                 "ID=TRACE.csv: fit the link's measured trace, analyse with it, give its verdict and margins (repeatable)");
}

// --region-sensor names a sensor of the scenario's (gamma, nu) region, or one clear error, status 2.
void check_region_sensor_or_fail(const Scenario& s, const AnalyzeArgs& args) {
  if (!args.region_sensor) return;
  std::string why;
  if (!args.region) why = "--region-sensor needs --region";
  else if (!s.actuation_link()) why = "--region-sensor needs an actuation link (plant.control.link)";
  else if (!s.find_sensor(*args.region_sensor))
    why = "--region-sensor: the scenario has no sensor " + std::to_string(*args.region_sensor);
  if (!why.empty()) {
    std::cerr << "netkf analyze: error: " << why << "\n";
    throw CLI::RuntimeError(2);
  }
}

theory::AnalyzeOptions analyze_options(const AnalyzeArgs& args) {
  theory::AnalyzeOptions o;
  o.region = args.region;
  o.sweep = args.sweep || (!args.plot.empty() && !args.region);  // a plot without --region is the sweep's
  o.use_lmi = !args.no_lmi;
  if (args.lmi_always) o.lmi_max_block = 0;
  o.region_sensor = args.region_sensor;
  if (args.points > 0) o.region_points = o.sweep_points = args.points;
  return o;
}

// --plot: the (gamma, nu) region, the (lambda1, lambda2) region, or the sweep's bounds.
void plot_analysis(const Scenario& s, const theory::AnalysisReport& r, const AnalyzeArgs& args) {
  try {
    if (args.region && r.actuation_region) {
      plot_actuation_region(r, s.name + ": closed-loop stability region (sensor " +
                                   std::to_string(r.actuation_region->sensor_id) + " x actuation link)",
                            args.plot);
    } else if (args.region) {
      if (r.region.empty())
        fail("analyze", "--region --plot needs a two-sensor scenario, or one sensor (or --region-sensor) and an "
                        "actuation link");
      plot_region(r, s.name + ": stability region (Liu-Goldsmith Thm 3)", args.plot);
    } else {
      plot_sweep(r, s.name + ": bounds on lim E[P_{k|k-1}] (Sinopoli Thm 4)", args.plot);
    }
  } catch (const CLI::RuntimeError&) {
    throw;
  } catch (const std::exception& e) {
    fail("analyze", e.what());
  }
  if (!args.json) std::cout << "wrote " << args.plot << "\n";
}

void run_analyze(const AnalyzeArgs& args) {
  Scenario s = load_or_fail("analyze", args.file);
  check_plot_or_fail("analyze", args.plot);
  check_region_sensor_or_fail(s, args);
  std::vector<MeasuredLink> measured = fit_links_or_fail(s, args.links);
  theory::AnalyzeOptions o = analyze_options(args);
  theory::AnalysisReport r;
  try {
    // The region's grid is the long part of an analysis (an LMI bisection per point).
    ProgressBar bar(std::cerr, "analyze --region", args.region && progress_bar_wanted(stderr_is_terminal(), args.json));
    o.progress = bar.callback();
    r = theory::analyze(s, o);
    judge_measured_links(s, measured);
  } catch (const std::exception& e) {
    fail("analyze", e.what());
  }
  if (args.json) {
    json j = analysis_json(r, args.region, args.sweep);
    if (!measured.empty()) j["measured_links"] = measured_links_json(measured);
    std::cout << j.dump(2) << "\n";
  } else {
    print_analysis(std::cout, s, r);
    print_measured_links(std::cout, measured);
  }
  if (!args.plot.empty()) plot_analysis(s, r, args);
}

}  // namespace

void add_analyze_command(CLI::App& app) {
  auto args = std::make_shared<AnalyzeArgs>();
  auto* cmd = app.add_subcommand("analyze", "What the papers predict for a scenario: bounds, critical rates, regions");
  add_analyze_options(*cmd, *args);
  cmd->callback([args] { run_analyze(*args); });
}

void add_simulate_command(CLI::App& app) {
  struct Args {
    std::string file;
    int runs = 1000, steps = 300, threads = 0;
    std::optional<std::uint64_t> seed;
    bool json = false;
    std::string plot, kernel = "auto";
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("simulate", "Offline Monte Carlo of the filter over the scenario's lossy links (no DDS)");
  cmd->add_option("scenario", args->file, "scenario YAML file")->required();
  cmd->add_option("--runs", args->runs, "independent runs N")->check(CLI::Range(1, 100000000));
  cmd->add_option("--steps", args->steps, "steps T per run")->check(CLI::Range(1, 100000000));
  cmd->add_option("--seed", args->seed, "override the scenario's seed (0 .. 2^64-1)")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            try {
              parse_seed(v);  // the scenario file's rule
              return {};
            } catch (const std::exception& e) {
              return e.what();
            }
          },
          "SEED"));
  cmd->add_option("--threads", args->threads, "worker threads (0: all cores)")->check(CLI::Range(0, 1024));
  cmd->add_option("--kernel", args->kernel, "auto | reference (the core filter) | fast (fixed-size)")
      ->check(CLI::IsMember({"auto", "reference", "fast"}));
  cmd->add_flag("--json", args->json, "print one JSON object (keys: docs/architecture.md, 'Contracts')");
  cmd->add_option("--plot", args->plot, "write mean Tr P and squared error against k (PNG or SVG) with gnuplot");
  cmd->callback([args] {
    const Scenario s = load_or_fail("simulate", args->file);
    check_plot_or_fail("simulate", args->plot);
    MonteCarloOptions o;
    o.runs = args->runs;
    o.steps = args->steps;
    o.seed = args->seed;
    o.threads = args->threads;
    o.record_series = !args->plot.empty();
    o.kernel = args->kernel == "reference" ? MonteCarloOptions::Kernel::reference
               : args->kernel == "fast"    ? MonteCarloOptions::Kernel::fixed_size
                                           : MonteCarloOptions::Kernel::automatic;
    MonteCarloResult r;
    try {
      ProgressBar bar(std::cerr, "simulate", progress_bar_wanted(stderr_is_terminal(), args->json));
      o.progress = bar.callback();
      r = run_monte_carlo(s, o);
    } catch (const std::exception& e) {
      fail("simulate", e.what());
    }
    if (args->json) std::cout << monte_carlo_json(r).dump(2) << "\n";
    else print_monte_carlo(std::cout, s, r);
    if (!args->plot.empty()) {
      try {
        theory::AnalyzeOptions ao;
        ao.use_lmi = false;
        const auto bounds = theory::analyze(s, ao);
        plot_monte_carlo(r, bounds, s.name + ": Monte Carlo of the filter", args->plot);
      } catch (const std::exception& e) {
        fail("simulate", e.what());
      }
      if (!args->json) std::cout << "wrote " << args->plot << "\n";
    }
  });
}

}  // namespace netkf::cli
