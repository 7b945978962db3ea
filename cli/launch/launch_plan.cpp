#include "launch_plan.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <set>
#include <sched.h>
#include <stdexcept>
#include <thread>

namespace netkf::cli {

std::vector<std::vector<int>> sensor_process_groups(const std::vector<int>& sensor_ids, int per_process) {
  if (per_process < 1) throw std::invalid_argument("sensors per process must be at least 1");
  std::vector<std::vector<int>> groups;
  for (std::size_t i = 0; i < sensor_ids.size(); ++i) {
    if (i % static_cast<std::size_t>(per_process) == 0) groups.emplace_back();
    groups.back().push_back(sensor_ids[i]);
  }
  return groups;
}

int auto_sensors_per_process(std::size_t sensors, unsigned cpus) {
  const std::size_t max_processes = 2 * static_cast<std::size_t>(std::max(1u, cpus));
  if (sensors <= max_processes) return 1;
  return static_cast<int>((sensors + max_processes - 1) / max_processes);
}

unsigned usable_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) return static_cast<unsigned>(std::max(1, CPU_COUNT(&set)));
  return std::max(1u, std::thread::hardware_concurrency());
}

LaunchRoles parse_launch_roles(const std::string& text, const std::vector<int>& scenario_sensor_ids) {
  LaunchRoles roles;
  roles.plant = roles.channel = roles.estimator = false;
  roles.all = false;
  bool all_sensors = false, in_sensor_list = false;
  std::set<int> chosen;
  std::string rest = text;
  std::vector<std::string> words;
  for (std::size_t start = 0;;) {
    const auto comma = rest.find(',', start);
    words.push_back(rest.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  auto sensor_id = [&](const std::string& w) {
    int id = 0;
    const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), id);
    if (ec != std::errc() || end != w.data() + w.size())
      throw std::invalid_argument("--only: '" + w + "' is not a sensor id");
    if (std::find(scenario_sensor_ids.begin(), scenario_sensor_ids.end(), id) == scenario_sensor_ids.end())
      throw std::invalid_argument("--only: the scenario has no sensor " + w);
    chosen.insert(id);
  };
  for (const auto& w : words) {
    if (w == "all") {
      roles.plant = roles.channel = roles.estimator = all_sensors = true;
      in_sensor_list = false;
    } else if (w == "plant") {
      roles.plant = true;
      in_sensor_list = false;
    } else if (w == "channel") {
      roles.channel = true;
      in_sensor_list = false;
    } else if (w == "estimator") {
      roles.estimator = true;
      in_sensor_list = false;
    } else if (w == "sensors") {
      all_sensors = true;
      in_sensor_list = false;
    } else if (w.rfind("sensors=", 0) == 0) {
      sensor_id(w.substr(8));
      in_sensor_list = true;
    } else if (in_sensor_list && !w.empty() && std::isdigit(static_cast<unsigned char>(w[0]))) {
      sensor_id(w);
    } else {
      throw std::invalid_argument("--only: unknown role '" + w +
                                  "' (give a comma list of plant, sensors, sensors=ID[,ID...], channel, estimator)");
    }
  }
  for (int id : scenario_sensor_ids)
    if (all_sensors || chosen.count(id)) roles.sensor_ids.push_back(id);
  if (!roles.plant && !roles.channel && !roles.estimator && roles.sensor_ids.empty())
    throw std::invalid_argument("--only '" + text + "' selects no process");
  roles.all = roles.plant && roles.channel && roles.estimator && roles.sensor_ids.size() == scenario_sensor_ids.size();
  return roles;
}

std::string describe_launch_roles(const LaunchRoles& roles) {
  std::string text;
  auto add = [&text](const std::string& w) { text += (text.empty() ? "" : ", ") + w; };
  if (roles.plant) add("plant");
  if (!roles.sensor_ids.empty()) {
    std::string ids;
    for (int id : roles.sensor_ids) ids += (ids.empty() ? "" : ",") + std::to_string(id);
    add("sensors " + ids);
  }
  if (roles.channel) add("channel");
  if (roles.estimator) add("estimator");
  return text;
}

std::uint64_t derived_run_id(std::uint64_t scenario_hash, int domain) {
  // splitmix64 of the two: a different scenario or domain gives an unrelated run id.
  std::uint64_t z = scenario_hash ^ (0x9e3779b97f4a7c15ULL * static_cast<std::uint64_t>(domain + 1));
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return z == 0 ? 1 : z;
}

std::uint32_t estimator_ownership_strength(int generation) {
  constexpr std::uint32_t kPrimary = 1000000;
  return kPrimary - static_cast<std::uint32_t>(generation);
}

std::uint32_t replacing_estimator_strength(int generation) {
  return estimator_ownership_strength(0) + 2 * static_cast<std::uint32_t>(generation);
}

std::uint32_t replacing_estimator_spare_strength(int generation) { return replacing_estimator_strength(generation) + 1; }

void set_ownership_strength(std::vector<std::string>& args, std::uint32_t strength) {
  for (std::size_t i = 0; i + 1 < args.size(); ++i)
    if (args[i] == "--ownership-strength") args[i + 1] = std::to_string(strength);
}

std::string sensor_process_name(const std::vector<int>& sensor_ids) {
  std::string name = "sensor_node[";
  for (std::size_t i = 0; i < sensor_ids.size();) {
    std::size_t j = i;  // the run of consecutive ids from i
    while (j + 1 < sensor_ids.size() && sensor_ids[j + 1] == sensor_ids[j] + 1) ++j;
    name += (i ? "," : "") + std::to_string(sensor_ids[i]);
    if (j >= i + 2) {
      name += "-" + std::to_string(sensor_ids[j]);
      i = j + 1;
    } else {
      ++i;
    }
  }
  return name + "]";
}

namespace {

std::vector<std::string> common_args(const LaunchPlanInputs& in) {
  std::vector<std::string> a{"--scenario", in.scenario_file, "--domain",  std::to_string(in.domain),
                             "--log-level", in.log_level,    "--run-id", std::to_string(in.run_id),
                             "--naming",    in.naming};
  if (in.discovery_server) a.insert(a.end(), {"--discovery-server", *in.discovery_server});
  if (in.dds_profile) a.insert(a.end(), {"--dds-profile", *in.dds_profile});
  if (in.secure_dir) a.insert(a.end(), {"--secure", *in.secure_dir});
  return a;
}

}  // namespace

LaunchPlan plan_launch(const LaunchPlanInputs& in,
                       const std::function<std::string(const std::string&)>& executable_of) {
  LaunchPlan plan;
  // Consumers first, the plant (the clock) last, so period 0 finds its readers.
  if (in.roles.channel) {
    // Present once the readers of what it relays matched (so period 0 is recorded): this launch's
    // sample recorder and this host's estimators (another host's readers are not counted).
    auto args = common_args(in);
    const int delivered_readers = (in.records_samples ? 1 : 0) + (in.roles.estimator ? (in.estimator_standby ? 2 : 1) : 0);
    if (delivered_readers > 0) args.insert(args.end(), {"--delivered-readers", std::to_string(delivered_readers)});
    ChildSpec channel{"channel_emulator", executable_of("channel_emulator"), args};
    channel.warm_spare = in.warm_spares;
    plan.children.push_back({channel, false});
  }
  if (in.roles.estimator) {
    auto args = common_args(in);
    args.insert(args.end(), {"--resume-from", in.checkpoint_file, "--ownership-strength",
                             std::to_string(estimator_ownership_strength(0))});
    ChildSpec estimator{"estimator_node", executable_of("estimator_node"), args};
    // A hot standby covers a death of the primary better than a spare (no blind window at all).
    estimator.warm_spare = in.warm_spares && !in.estimator_standby;
    if (estimator.warm_spare) {
      estimator.spare_args = args;
      set_ownership_strength(estimator.spare_args, replacing_estimator_spare_strength(0));
    }
    plan.children.push_back({estimator, true});
    if (in.estimator_standby) {
      set_ownership_strength(args, estimator_ownership_strength(1));
      plan.children.push_back({{"estimator_node[standby]", executable_of("estimator_node"), args}, true});
    }
  }
  plan.sensor_groups = sensor_process_groups(in.roles.sensor_ids, in.sensors_per_process);
  for (const auto& group : plan.sensor_groups) {
    auto args = common_args(in);
    for (int id : group) args.insert(args.end(), {"--sensor-id", std::to_string(id)});
    // Present once this host's channel can hear it (a channel on another host is not waited
    // for: the plant names it missing, not the sensors that are here).
    if (in.roles.channel) args.insert(args.end(), {"--raw-readers", "1"});
    plan.children.push_back(
        {{sensor_process_name(group), executable_of("sensor_node"), args, false, in.sensor_nice}, false});
  }
  // The plant starts when presence shows the whole network, on every host, and its truth has
  // matched every sensor process, launch and recorder present (so recordings start at k = 0).
  if (in.roles.plant) {
    auto args = common_args(in);
    // This host's sensor processes and this launch read the truth: counted before their
    // presence arrives (presence adds other hosts' launches and recorders).
    if (in.estimator_standby) args.insert(args.end(), {"--tick-readers", "2"});
    args.insert(args.end(), {"--wait-for-presence", "--truth-readers", std::to_string(plan.sensor_groups.size() + 1),
                             "--startup-wait-ms", std::to_string(static_cast<long long>(in.ready_timeout_s * 1000.0))});
    plan.children.push_back({{"plant_node", executable_of("plant_node"), args, /*critical=*/true}, false});
  }
  return plan;
}

}  // namespace netkf::cli
