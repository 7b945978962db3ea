// `netkf analyze` and `netkf simulate`: the theory toolkit beside the live network
// (docs/architecture.md, "Contracts": the JSON keys are fixed there).
#include <cmath>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "commands.hpp"
#include "progress_bar.hpp"
#include "netkf/analysis/report.hpp"
#include "netkf/monte_carlo.hpp"
#include "netkf/scenario.hpp"
#include "theory_plot.hpp"

namespace netkf::cli {
namespace {

using nlohmann::json;

json number_or_null(const std::optional<double>& v) {
  if (!v || !std::isfinite(*v)) return nullptr;
  return *v;
}

json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

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

[[noreturn]] void fail(const std::string& command, const std::string& message) {
  std::cerr << "netkf " << command << ": error: " << message << "\n";
  throw CLI::RuntimeError(1);
}

json report_json(const analysis::AnalysisReport& r) {
  json j;
  j["spectral_radius"] = number_or_null(r.spectral_radius);
  j["stable"] = analysis::to_string(r.stable);
  j["expected_covariance"] = {{"lower_trace", number_or_null(r.lower_trace)},
                              {"upper_trace", number_or_null(r.upper_trace)}};
  if (r.critical_rate) {
    const auto& cr = *r.critical_rate;
    j["critical_rate"] = {{"lower", number_or_null(cr.lower)},
                          {"upper", number_or_null(cr.upper)},
                          {"upper_iteration", number_or_null(cr.upper_iteration)},
                          {"exact", number_or_null(cr.exact)}};
  } else {
    j["critical_rate"] = nullptr;
  }
  j["markov_criterion"] = number_or_null(r.markov_criterion);
  j["second_order_criterion"] = number_or_null(r.second_order_criterion);
  j["links"] = json::array();
  for (const auto& l : r.links)
    j["links"].push_back({{"sensor_id", l.sensor_id},
                          {"loss", number_or_null(l.loss)},
                          {"in_time", number_or_null(l.in_time)},
                          {"effective_arrival_rate", number_or_null(l.effective_arrival_rate)}});
  j["notes"] = r.notes;
  return j;
}

std::string show(const std::optional<double>& v, const char* missing = "unbounded") {
  if (!v) return missing;
  std::ostringstream os;
  os << std::setprecision(6) << *v;
  return os.str();
}

void print_report(const Scenario& s, const analysis::AnalysisReport& r) {
  std::cout << "scenario " << s.name << " (" << s.state_dim() << " states, " << s.sensors.size() << " sensors)\n";
  std::cout << "  spectral radius alpha      " << std::setprecision(6) << r.spectral_radius << "\n";
  std::cout << "  stable                     " << analysis::to_string(r.stable) << "\n";
  const char* missing = r.iid_bounds ? "unbounded" : "not reported (links not i.i.d., see notes)";
  std::cout << "  Tr S-bar (lower bound)     " << show(r.lower_trace, missing) << "\n";
  std::cout << "  Tr V-bar (upper bound)     " << show(r.upper_trace, missing) << "\n";
  std::cout << "  Markov criterion           " << show(r.markov_criterion, "n/a") << "\n";
  std::cout << "  links: id  loss  P(in time)  effective arrival rate (1 - loss) * P(in time)\n";
  for (const auto& l : r.links)
    std::cout << "    " << std::setw(4) << l.sensor_id << "  " << std::setw(9) << show(l.loss) << "  " << std::setw(9)
              << show(l.in_time) << "  " << std::setw(9) << show(l.effective_arrival_rate) << "\n";
  if (r.critical_rate) {
    const auto& cr = *r.critical_rate;
    std::cout << "  critical arrival rate      lower " << show(cr.lower) << ", upper (LMI) " << show(cr.upper, "none")
              << ", upper (iteration) " << show(cr.upper_iteration, "none") << ", exact " << show(cr.exact, "n/a")
              << "\n";
  }
  if (!r.region.empty()) {
    std::cout << "  stability region (Liu-Goldsmith): lambda1 -> lambda2 lower / upper / exact\n";
    for (const auto& p : r.region)
      std::cout << "    " << std::setw(5) << p.lambda1 << "  " << std::setw(9) << show(p.lambda2_lower) << "  "
                << std::setw(9) << show(p.lambda2_upper, "none") << "  " << std::setw(9) << show(p.lambda2_exact, "n/a")
                << "\n";
  }
  if (!r.sweep.empty()) {
    std::cout << "  sweep: lambda -> Tr S-bar / Tr V-bar\n";
    for (const auto& p : r.sweep)
      std::cout << "    " << std::setw(5) << p.lambda << "  " << std::setw(12) << show(p.lower_trace) << "  "
                << std::setw(12) << show(p.upper_trace) << "\n";
  }
  for (const auto& n : r.notes) std::cout << "  note: " << n << "\n";
}

}  // namespace

void add_analyze_command(CLI::App& app) {
  struct Args {
    std::string file;
    bool json = false, region = false, sweep = false, no_lmi = false, lmi_always = false;
    int points = 0;
    std::string plot;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("analyze", "What the papers predict for a scenario: bounds, critical rates, regions");
  cmd->add_option("scenario", args->file, "scenario YAML file")->required();
  cmd->add_flag("--json", args->json, "print one JSON object (keys: docs/architecture.md, 'Contracts')");
  cmd->add_flag("--region", args->region, "two sensors: stability region bounds over a grid of lambda1");
  cmd->add_flag("--sweep", args->sweep, "Tr S-bar and Tr V-bar over a grid of the shared arrival rate");
  cmd->add_option("--points", args->points, "grid points for --sweep / --region")->check(CLI::Range(2, 10001));
  cmd->add_flag("--no-lmi", args->no_lmi, "skip the CSDP LMI (upper bounds from the g iteration only)");
  cmd->add_flag("--lmi-always", args->lmi_always, "solve the LMI whatever its size (slow above ~50 rows)");
  cmd->add_option("--plot", args->plot, "write the figure (PNG or SVG) with gnuplot");
  cmd->callback([args] {
    const Scenario s = load_or_fail("analyze", args->file);
    check_plot_or_fail("analyze", args->plot);
    analysis::AnalyzeOptions o;
    o.region = args->region;
    o.sweep = args->sweep || (!args->plot.empty() && !args->region);
    o.use_lmi = !args->no_lmi;
    if (args->lmi_always) o.lmi_max_block = 0;
    if (args->points > 0) o.region_points = o.sweep_points = args->points;
    analysis::AnalysisReport r;
    try {
      // The region's grid is the long part of an analysis (an LMI bisection per point).
      ProgressBar bar(std::cerr, "analyze --region",
                      args->region && progress_bar_wanted(stderr_is_terminal(), args->json));
      o.progress = bar.callback();
      r = analysis::analyze(s, o);
    } catch (const std::exception& e) {
      fail("analyze", e.what());
    }
    if (args->json) {
      json j = report_json(r);
      if (args->region) {
        json region = json::array();
        for (const auto& p : r.region)
          region.push_back({{"lambda1", p.lambda1},
                            {"lambda2_lower", number_or_null(p.lambda2_lower)},
                            {"lambda2_upper", number_or_null(p.lambda2_upper)},
                            {"lambda2_upper_iteration", number_or_null(p.lambda2_upper_iteration)},
                            {"lambda2_exact", number_or_null(p.lambda2_exact)}});
        j["region"] = region;
      }
      if (args->sweep) {
        json sweep = json::array();
        for (const auto& p : r.sweep)
          sweep.push_back({{"lambda", p.lambda},
                           {"lower_trace", number_or_null(p.lower_trace)},
                           {"upper_trace", number_or_null(p.upper_trace)}});
        j["sweep"] = sweep;
      }
      std::cout << j.dump(2) << "\n";
    } else {
      print_report(s, r);
    }
    if (!args->plot.empty()) {
      try {
        if (args->region) {
          if (r.region.empty()) fail("analyze", "--region --plot needs a two-sensor scenario");
          plot_region(r, s.name + ": stability region (Liu-Goldsmith Thm 3)", args->plot);
        } else {
          plot_sweep(r, s.name + ": bounds on lim E[P_{k|k-1}] (Sinopoli Thm 4)", args->plot);
        }
      } catch (const CLI::RuntimeError&) {
        throw;
      } catch (const std::exception& e) {
        fail("analyze", e.what());
      }
      if (!args->json) std::cout << "wrote " << args->plot << "\n";
    }
  });
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
    if (args->json) {
      json j;
      auto put = [&](const char* key, const MeanSe& m) {
        j[key] = number_or_null(m.mean);
        j[std::string(key) + "_se"] = number_or_null(m.se);
      };
      put("mean_trace_P_pred", r.trace_P_pred);
      put("mean_trace_P_filt", r.trace_P_filt);
      put("mean_sq_error_pred", r.sq_error_pred);
      put("mean_sq_error_filt", r.sq_error_filt);
      j["diverged_fraction"] = r.diverged_fraction;
      j["runs"] = r.runs;
      j["steps"] = r.steps;
      j["seed"] = r.seed;
      j["kernel"] = r.used_fixed_size_kernel ? "fast" : "reference";
      std::cout << j.dump(2) << "\n";
    } else {
      std::cout << "scenario " << s.name << ": " << r.runs << " runs x " << r.steps << " steps, seed " << r.seed
                << " (" << (r.used_fixed_size_kernel ? "fixed-size" : "reference") << " kernel)\n"
                << std::setprecision(6) << "  at k = " << r.steps - 1 << " (mean +/- standard error):\n"
                << "  Tr P_{k|k-1}        " << r.trace_P_pred.mean << " +/- " << r.trace_P_pred.se << "\n"
                << "  Tr P_{k|k}          " << r.trace_P_filt.mean << " +/- " << r.trace_P_filt.se << "\n"
                << "  |x - x^_{k|k-1}|^2  " << r.sq_error_pred.mean << " +/- " << r.sq_error_pred.se << "\n"
                << "  |x - x^_{k|k}|^2    " << r.sq_error_filt.mean << " +/- " << r.sq_error_filt.se << "\n"
                << "  diverged fraction   " << r.diverged_fraction << "\n";
    }
    if (!args->plot.empty()) {
      try {
        analysis::AnalyzeOptions ao;
        ao.use_lmi = false;
        const auto bounds = analysis::analyze(s, ao);
        plot_monte_carlo(r, bounds, s.name + ": Monte Carlo of the filter", args->plot);
      } catch (const std::exception& e) {
        fail("simulate", e.what());
      }
      if (!args->json) std::cout << "wrote " << args->plot << "\n";
    }
  });
}

}  // namespace netkf::cli
