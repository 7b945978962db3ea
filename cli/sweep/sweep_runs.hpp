#pragma once
// One run of a sweep, and the theory of one point (docs/experiments.md, "Sweeps").
//   offline  the core's offline run (netkf/sim/offline_run.hpp) summed into the launch's RunSummary,
//            so every quantity has the launch's definition (run_summary.hpp); what an offline run
//            cannot measure (pipeline latency) has no value, and nothing is late.
//   live     a real `netkf launch` child writes its --summary JSON; its values are read back.
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <optional>
#include <string>
#include <vector>
#include <yaml-cpp/yaml.h>

#include "netkf/cli/live/run_summary.hpp"
#include "netkf/cli/sweep/sweep_spec.hpp"
#include "sweep_table.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::cli::sweep {

/// The scenario of one run: the file's YAML tree with the point's values and `seed` set to
/// run_seed(the scenario's seed, seed_index), as YAML text for the loader (or a child process).
/// seed_index 0: the file's own seed (the point's scenario as `netkf analyze` would see it).
std::string run_scenario_yaml(const YAML::Node& file_tree, const std::vector<Vary>& vary, const Point& point,
                              int seed_index);

/// An offline run given up because `stop` said so (Ctrl-C): it has no summary.
struct RunStopped : std::runtime_error {
  RunStopped() : std::runtime_error("stopped") {}
};

/// The summary of an offline run of `periods` periods with the scenario's seed. `stop` is asked
/// every few thousand periods (a run of 10^8 periods takes minutes); true throws RunStopped.
RunSummary offline_summary(const Scenario& scenario, std::int64_t periods, const std::function<bool()>& stop = {});

/// Each of `names` (summary_names) from a summary, nullopt where not measured.
std::vector<std::optional<double>> summary_values(const RunSummary& summary, const std::vector<std::string>& names);
/// The same from the launch's --summary JSON (a name `link.ID.q` is the path link/ID/q).
std::vector<std::optional<double>> summary_values(const nlohmann::json& summary, const std::vector<std::string>& names);

/// The core analysis of a point's scenario (the default options, as `netkf analyze`).
Theory point_theory(const Scenario& scenario);

}  // namespace netkf::cli::sweep
