#include "fit_scenario.hpp"

#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <yaml-cpp/yaml.h>

#include "netkf/link.hpp"
#include "netkf/scenario.hpp"

namespace netkf::cli {
namespace {

// A number as six significant digits: the plain scalar the scenario loader reads back.
std::string g6(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

YAML::Node link_node(const nlohmann::json& link) {
  YAML::Node node(YAML::NodeType::Map);
  for (const auto& key : link_key_names()) {  // in the documented order, model first
    if (!link.contains(key)) continue;
    const auto& value = link.at(key);
    if (value.is_string()) node[key] = value.get<std::string>();
    else node[key] = g6(value.get<double>());
  }
  return node;
}

YAML::Node find_sensor(YAML::Node& root, int link_id, const std::string& name) {
  YAML::Node sensors = root["sensors"];
  if (!sensors || !sensors.IsSequence()) throw std::runtime_error(name + ": no sensors list");
  std::string ids;
  for (std::size_t i = 0; i < sensors.size(); ++i) {
    const YAML::Node id = sensors[i]["id"];
    if (!id) continue;
    if (id.as<int>() == link_id) return sensors[i];
    ids += (ids.empty() ? "" : ", ") + id.as<std::string>();
  }
  throw std::runtime_error("--link " + std::to_string(link_id) + ": no such link in " + name +
                           " (its links: " + ids + ")");
}

}  // namespace

void write_scenario_with_link(const std::filesystem::path& scenario, int link_id, const nlohmann::json& link,
                              const std::string& note, const std::filesystem::path& out) {
  load_scenario_file(scenario);  // a valid scenario to start from (its own FILE:LINE:COL errors)
  std::error_code ec;
  if (std::filesystem::exists(out, ec) && std::filesystem::equivalent(scenario, out, ec))
    throw std::runtime_error("-o " + out.string() + " is the scenario itself: the fit writes a copy");
  YAML::Node root = YAML::LoadFile(scenario.string());
  YAML::Node sensor = find_sensor(root, link_id, scenario.string());
  sensor["link"] = link_node(link);
  YAML::Emitter emitter;
  emitter << YAML::Comment(note) << YAML::Newline << root;
  {
    std::ofstream file(out);
    file << emitter.c_str() << "\n";
    if (!file) throw std::runtime_error("cannot write " + out.string());
  }
  try {
    load_scenario_file(out);
  } catch (...) {
    std::filesystem::remove(out, ec);
    throw;
  }
}

}  // namespace netkf::cli
