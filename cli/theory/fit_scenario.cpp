#include "netkf/cli/theory/fit_scenario.hpp"

#include <cstdio>
#include <stdexcept>
#include <yaml-cpp/yaml.h>

#include "netkf/links/link.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/support/input_file.hpp"

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

ScenarioCopy::ScenarioCopy(const std::filesystem::path& scenario, int link_id)
    : path_(scenario.string()), text_(read_input_file(scenario, "scenario file", max_yaml_input_bytes)),
      link_id_(link_id) {
  parse_scenario(text_, path_);  // a valid scenario to start from (its own FILE:LINE:COL errors)
  YAML::Node root = YAML::Load(text_);
  find_sensor(root, link_id_, path_);
}

std::string ScenarioCopy::with_link(const nlohmann::json& link, const std::string& note, const std::string& name) const {
  YAML::Node root = YAML::Load(text_);
  YAML::Node sensor = find_sensor(root, link_id_, path_);
  sensor["link"] = link_node(link);
  YAML::Emitter emitter;
  emitter << YAML::Comment(note) << YAML::Newline << root;
  std::string text = std::string(emitter.c_str()) + "\n";
  parse_scenario(text, name);  // a copy that would not load is never written
  return text;
}

}  // namespace netkf::cli
