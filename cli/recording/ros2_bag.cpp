#include "netkf/cli/recording/ros2_bag.hpp"

#include <functional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "recording__msg_texts.hpp"

namespace netkf::cli {

McapProfile mcap_profile_from_string(std::string_view s) {
  if (s == "json") return McapProfile::json;
  if (s == "ros2") return McapProfile::ros2;
  throw std::invalid_argument("unknown MCAP profile '" + std::string(s) + "' (json or ros2)");
}

std::string to_string(McapProfile p) { return p == McapProfile::ros2 ? "ros2" : "json"; }

namespace ros2 {

TopicInfo topic_info(Channel c) {
  switch (c) {
    case Channel::truth:
      return {"/netkf/truth", kPackage, "Truth"};
    case Channel::estimate:
      return {"/netkf/estimate", kPackage, "Estimate"};
    case Channel::delivered:
      return {"/netkf/measurement/delivered", kPackage, "Measurement"};
    case Channel::link_status:
      return {"/netkf/link/status", kPackage, "LinkStatus"};
    case Channel::link_change:
      return {"/netkf/link/change", kPackage, "LinkChange"};
    case Channel::rosout:
      return {"/rosout", "rcl_interfaces", "Log"};
  }
  throw std::logic_error("unknown ROS 2 channel");
}

std::string TopicInfo::schema_name() const { return std::string(package) + "/msg/" + std::string(type); }

namespace {

bool is_primitive(const std::string& type) {
  static const std::set<std::string> primitives{"bool",  "byte",   "char",  "float32", "float64",
                                                "int8",  "uint8",  "int16", "uint16",  "int32",
                                                "uint32", "int64", "uint64", "string", "wstring"};
  return primitives.count(type) > 0;
}

// ROS 2's own types the events channel uses (rcl_interfaces/msg/Log and the Time it stamps
// with): their fields, in ROS 2's order, with the level constants.
constexpr std::string_view kLogMsg =
    "# A log message (ROS 2's rcl_interfaces/msg/Log): severity levels, then the fields.\n"
    "byte DEBUG=10\n"
    "byte INFO=20\n"
    "byte WARN=30\n"
    "byte ERROR=40\n"
    "byte FATAL=50\n"
    "\n"
    "builtin_interfaces/Time stamp  # when the message was made\n"
    "uint8 level                    # one of the levels above\n"
    "string name                    # the logger\n"
    "string msg                     # the message\n"
    "string file                    # source file, function and line (empty, 0 for netkf's events)\n"
    "string function\n"
    "uint32 line\n";
constexpr std::string_view kTimeMsg =
    "# Time (ROS 2's builtin_interfaces/msg/Time): seconds and nanoseconds.\n"
    "int32 sec\n"
    "uint32 nanosec\n";

std::string_view text_of(std::string_view package, std::string_view type) {
  std::string_view text;
  if (package == kPackage) text = msg_text(type);
  else if (package == "rcl_interfaces" && type == "Log") text = kLogMsg;
  else if (package == "builtin_interfaces" && type == "Time") text = kTimeMsg;
  if (text.empty()) throw std::logic_error("no .msg text for " + std::string(package) + "/" + std::string(type));
  return text;
}

}  // namespace

std::vector<std::string> msg_dependencies(std::string_view text, std::string_view package) {
  std::set<std::string> deps;  // rosbag2 keeps them in a std::set: name order
  std::istringstream lines{std::string(text)};
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream words(line.substr(0, line.find('#')));
    std::string type, name;
    if (!(words >> type >> name)) continue;         // blank or comment
    if (name.find('=') != std::string::npos) continue;  // a constant "TYPE NAME=VALUE" has a primitive type
    type = type.substr(0, type.find('['));           // float64[], Measurement[<=100]
    if (type.find("string<=") == 0) continue;         // a bounded string
    if (is_primitive(type)) continue;
    deps.insert(type.find('/') == std::string::npos ? std::string(package) + "/" + type : type);
  }
  return {deps.begin(), deps.end()};
}

std::string message_definition(std::string_view package, std::string_view type) {
  std::set<std::string> seen;
  const std::function<std::string(std::string_view, std::string_view)> append = [&](std::string_view pkg,
                                                                                    std::string_view name) {
    std::string result(text_of(pkg, name));
    for (const auto& dep : msg_dependencies(result, pkg)) {
      if (!seen.insert(dep).second) continue;
      const auto slash = dep.find('/');
      result += "\n" + std::string(80, '=') + "\nMSG: " + dep + "\n" + append(dep.substr(0, slash), dep.substr(slash + 1));
    }
    return result;
  };
  return append(package, type);
}

std::string offered_qos_profiles(const Qos& q) {
  // rmw_qos_profile_t's enums: history 1 keep_last; reliability 1 reliable, 2 best_effort;
  // durability 1 transient_local, 2 volatile; liveliness 1 automatic.
  std::ostringstream y;
  y << "- history: 1\n"
    << "  depth: " << q.depth << "\n"
    << "  reliability: " << (q.reliable ? 1 : 2) << "\n"
    << "  durability: " << (q.transient_local ? 1 : 2) << "\n"
    << "  deadline:\n    sec: 0\n    nsec: 0\n"
    << "  lifespan:\n    sec: 0\n    nsec: 0\n"
    << "  liveliness: 1\n"
    << "  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n"
    << "  avoid_ros_namespace_conventions: false";
  return y.str();
}

namespace {

/// A YAML double-quoted scalar.
std::string yaml_quoted(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += std::string("\\") + c;
    else if (c == '\n') out += "\\n";
    else out += c;
  }
  return out + "\"";
}

}  // namespace

std::string bag_metadata_yaml(const std::vector<BagTopic>& topics, const std::string& file_name,
                              std::uint64_t start_ns, std::uint64_t end_ns) {
  std::uint64_t messages = 0;
  for (const auto& t : topics) messages += t.messages;
  const std::uint64_t duration = end_ns >= start_ns ? end_ns - start_ns : 0;
  std::ostringstream y;
  y << "version: 8\n"
    << "storage_identifier: mcap\n"
    << "duration:\n  nanoseconds: " << duration << "\n"
    << "starting_time:\n  nanoseconds_since_epoch: " << start_ns << "\n"
    << "message_count: " << messages << "\n"
    << "topics_with_message_count:\n";
  for (const auto& t : topics) {
    y << "  - topic_metadata:\n"
      << "      name: " << t.name << "\n"
      << "      type: " << t.type << "\n"
      << "      serialization_format: cdr\n"
      << "      offered_qos_profiles: " << yaml_quoted(offered_qos_profiles(t.qos)) << "\n"
      << "      type_description_hash: \"\"\n"
      << "    message_count: " << t.messages << "\n";
  }
  y << "compression_format: \"\"\n"
    << "compression_mode: \"\"\n"
    << "relative_file_paths:\n  - " << yaml_quoted(file_name) << "\n"
    << "files:\n"
    << "  - path: " << yaml_quoted(file_name) << "\n"
    << "    starting_time:\n      nanoseconds_since_epoch: " << start_ns << "\n"
    << "    duration:\n      nanoseconds: " << duration << "\n"
    << "    message_count: " << messages << "\n"
    << "custom_data: {}\n"
    << "ros_distro: " << kRosDistro << "\n";
  return y.str();
}

}  // namespace ros2
}  // namespace netkf::cli
