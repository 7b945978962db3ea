// sweep.yaml: what a sweep directory was made with (sweep.hpp).
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <yaml-cpp/yaml.h>

#include "netkf/cli/common/seconds.hpp"
#include "netkf/cli/sweep/sweep.hpp"
#include "netkf/support/input_file.hpp"

#ifndef NETKF_VERSION
#define NETKF_VERSION "unknown"
#endif

namespace netkf::cli::sweep {

std::string sweep_yaml(const SweepConfig& config, const std::string& scenario_sha256) {
  YAML::Emitter out;
  out << YAML::Comment("netkf sweep: how this directory was made (netkf sweep --resume DIR reads it)");
  out << YAML::BeginMap;
  out << YAML::Key << "command" << YAML::Value << YAML::Flow << config.command;
  out << YAML::Key << "netkf_version" << YAML::Value << NETKF_VERSION;
  out << YAML::Key << "scenario" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "path" << YAML::Value << std::filesystem::absolute(config.scenario_path).string();
  out << YAML::Key << "sha256" << YAML::Value << scenario_sha256 << YAML::EndMap;
  out << YAML::Key << "vary" << YAML::Value << YAML::BeginSeq;
  for (const auto& v : config.vary)
    out << YAML::BeginMap << YAML::Key << "key" << YAML::Value << v.key << YAML::Key << "values" << YAML::Value
        << YAML::Flow << v.values << YAML::EndMap;
  out << YAML::EndSeq;
  out << YAML::Key << "seeds" << YAML::Value << config.seeds;
  out << YAML::Key << "seed_derivation" << YAML::Value << "derive_seed(scenario seed, \"sweep\", seed index)";
  if (config.duration_s) out << YAML::Key << "duration_s" << YAML::Value << *config.duration_s;
  if (config.periods) out << YAML::Key << "periods" << YAML::Value << *config.periods;
  out << YAML::Key << "mode" << YAML::Value << (config.live ? "live" : "offline");
  out << YAML::Key << "jobs" << YAML::Value << config.jobs;
  out << YAML::Key << "domain_base" << YAML::Value << config.domain_base;
  out << YAML::Key << "checks" << YAML::Value << YAML::Flow << config.checks;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

SweepConfig read_sweep_yaml(const std::string& dir, std::string& scenario_sha256) {
  const auto path = std::filesystem::path(dir) / "sweep.yaml";
  if (!std::filesystem::exists(path)) throw std::runtime_error(path.string() + " is missing: not a sweep directory");
  SweepConfig c;
  try {
    const YAML::Node y = YAML::Load(read_input_file(path, "sweep.yaml", max_yaml_input_bytes));
    c.command = y["command"].as<std::vector<std::string>>();
    c.scenario_path = y["scenario"]["path"].as<std::string>();
    scenario_sha256 = y["scenario"]["sha256"].as<std::string>();
    for (const auto& v : y["vary"]) c.vary.push_back({v["key"].as<std::string>(), v["values"].as<std::vector<std::string>>()});
    c.seeds = y["seeds"].as<int>();
    if (y["duration_s"]) c.duration_s = y["duration_s"].as<double>();
    // As --duration is checked on the command line (a hand-edited file could say nan).
    if (c.duration_s) {
      const std::string problem = seconds_problem(*c.duration_s, 0.0, kMaxDurationSeconds, /*above_min=*/true);
      if (!problem.empty()) throw std::runtime_error(path.string() + ": duration_s " + problem);
    }
    if (y["periods"]) c.periods = y["periods"].as<std::int64_t>();
    c.live = y["mode"].as<std::string>() == "live";
    c.jobs = y["jobs"].as<int>();
    c.domain_base = y["domain_base"].as<int>();
    if (y["checks"]) c.checks = y["checks"].as<std::vector<std::string>>();
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
  c.out = dir;
  return c;
}

}  // namespace netkf::cli::sweep
