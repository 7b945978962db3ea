// `netkf fit TRACE.csv`: which loss model explains a measured link (docs/cli.md, "netkf fit").
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "netkf/cli/commands/commands.hpp"
#include "netkf/cli/common/output_file.hpp"
#include "netkf/cli/theory/fit_scenario.hpp"
#include "netkf/cli/theory/fit_text.hpp"
#include "netkf/cli/theory/theory_plot.hpp"
#include "netkf/fit/loss_fit.hpp"
#include "netkf/links/link_trace.hpp"

namespace netkf::cli {
namespace {

struct FitArgs {
  std::string trace, model = "auto", plot, scenario, output;
  std::optional<int> link;
  std::uint64_t seed = 1;
  bool json = false;
};

[[noreturn]] void fail(int status, const std::string& message) {
  std::cerr << "netkf fit: error: " << message << "\n";
  throw CLI::RuntimeError(status);
}

// The options that go together, the output files, the scenario and its link: checked before
// the fit (which takes a minute on a long trace), status 2.
std::optional<ScenarioCopy> check_usage(const FitArgs& a) {
  const int given = !a.scenario.empty() + a.link.has_value() + !a.output.empty();
  if (given != 0 && given != 3) fail(2, "--scenario, --link and -o go together (write the fitted link into a copy)");
  std::optional<ScenarioCopy> copy;
  try {
    std::vector<FileArg> outputs;
    if (!a.output.empty()) outputs.push_back({"-o", a.output});
    if (!a.plot.empty()) outputs.push_back({"--plot", a.plot});
    std::vector<FileArg> inputs{{"the trace", a.trace}};
    if (!a.scenario.empty()) inputs.push_back({"--scenario", a.scenario});
    check_output_files(outputs, inputs);
    if (!a.plot.empty()) check_plot_output(a.plot);
    if (!a.scenario.empty()) copy.emplace(a.scenario, *a.link);
  } catch (const std::exception& e) {
    fail(2, e.what());
  }
  return copy;
}

fit::TraceFit fit_trace(const FitArgs& a, const LinkTrace& trace) {
  fit::LossFitOptions o;
  if (a.model != "auto") o.family = fit::parse_loss_family(a.model);
  o.seed = a.seed;
  try {
    return fit::fit_loss_model(trace.delivered, o);
  } catch (const std::exception& e) {
    fail(2, a.trace + ": " + e.what());
  }
}

void write_outputs(const FitArgs& a, const std::optional<ScenarioCopy>& copy, const fit::TraceFit& r,
                   const std::optional<fit::DelaySummary>& delay) {
  const auto& f = r.fit();
  if (!a.plot.empty()) {
    try {
      plot_burst_histogram(f, a.trace + ": burst lengths against the fitted " + fit::to_string(f.family), a.plot);
    } catch (const std::exception& e) {
      fail(1, e.what());
    }
    if (!a.json) std::cout << "wrote " << a.plot << "\n";
  }
  if (!copy) return;
  const std::string note = "link " + std::to_string(*a.link) + " fitted by `netkf fit` from " + a.trace + ": " +
                           fit::to_string(f.family) + ", log-likelihood " + std::to_string(f.log_likelihood) +
                           ", AIC " + std::to_string(f.aic);
  try {
    write_output_file({"-o", a.output}, copy->with_link(fitted_link_json(f, delay), note, a.output));
  } catch (const std::exception& e) {
    fail(2, e.what());
  }
  if (!a.json) std::cout << "wrote " << a.output << " (link " << *a.link << " fitted)\n";
}

}  // namespace

void add_fit_command(CLI::App& app) {
  auto a = std::make_shared<FitArgs>();
  auto* cmd = app.add_subcommand("fit", "Fit a loss model (bernoulli, Gilbert, Gilbert-Elliott) to a link's arrival trace");
  cmd->add_option("trace", a->trace, "trace CSV: k,delivered[,delay_ms] (docs/scenario-format.md, 'Link traces')")
      ->required();
  cmd->add_option("--model", a->model, "family to fit, or auto (every family, chosen by AIC)")
      ->check(CLI::IsMember({"auto", "bernoulli", "simple_gilbert", "gilbert", "gilbert_elliott"}));
  cmd->add_flag("--json", a->json, "print one JSON object (keys: docs/cli.md, 'netkf fit')");
  cmd->add_option("--plot", a->plot, "write the burst-length histogram against the model's (PNG or SVG) with gnuplot");
  cmd->add_option("--scenario", a->scenario, "scenario to copy with the fitted link (with --link and -o)");
  cmd->add_option("--link", a->link, "the link (sensor id) of --scenario that gets the fitted model");
  cmd->add_option("-o,--output", a->output, "where the scenario copy goes");
  cmd->add_option("--seed", a->seed, "seed of the EM's random starts (default 1)");
  cmd->callback([a] {
    const std::optional<ScenarioCopy> copy = check_usage(*a);
    LinkTrace trace;
    try {
      trace = read_link_trace_file(a->trace);
    } catch (const std::exception& e) {
      fail(2, e.what());
    }
    const fit::TraceFit r = fit_trace(*a, trace);
    const auto delay = trace.has_delay ? fit::summarize_delays(trace.delay_ms) : std::nullopt;
    if (a->json) std::cout << fit_json(a->trace, r, delay).dump(2) << "\n";
    else print_fit(std::cout, a->trace, r, delay);
    write_outputs(*a, copy, r, delay);
  });
}

}  // namespace netkf::cli
