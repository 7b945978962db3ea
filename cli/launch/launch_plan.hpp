#pragma once
// The plan of one `netkf launch`, without DDS and without processes: which roles this host
// runs (--only), how its sensors are grouped into processes, the run id, and every child's
// name, program and arguments in start order (consumers first, the plant last). Launch
// starts exactly this plan; the unit tests check it.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "launch_supervisor.hpp"

namespace netkf::cli {

/// The sensor processes of a launch: the sensor ids in scenario order, `per_process` to a
/// process (the last takes the rest). Throws std::invalid_argument for per_process < 1.
std::vector<std::vector<int>> sensor_process_groups(const std::vector<int>& sensor_ids, int per_process);
/// Sensors per process chosen by `netkf launch --sensors-per-process auto` (the default):
/// one process per sensor while there are at most 2 x `cpus` sensors, else the fewest per
/// process that keep the sensor processes within 2 x `cpus`. Every sensor process wakes on
/// the same tick; more simultaneous wake-ups than cores queue up in front of the channel and
/// the estimator (BENCHMARKS.md, 2 cores: 8 sensors as 8 processes had a pipeline p50 of
/// 300-400 µs, as 4 processes of 2, 240-310 µs; 64 sensors as 64 processes fell behind for
/// good, as 4 of 16 they kept up). Grouping changes no sample and no estimate (e2e sensor_groups).
int auto_sensors_per_process(std::size_t sensors, unsigned cpus);
/// CPUs this process may run on (its affinity mask; at least 1).
unsigned usable_cpus();
/// The supervisor's name of a sensor process: "sensor_node[3]", "sensor_node[1,2]", runs of three
/// or more ids as ranges: "sensor_node[1-1024]" (not a line of 5000 characters in every log).
std::string sensor_process_name(const std::vector<int>& sensor_ids);

/// The roles one `netkf launch` runs (`--only`): on several hosts, each runs its part.
struct LaunchRoles {
  bool plant = true;
  bool channel = true;
  bool estimator = true;
  std::vector<int> sensor_ids;  // in scenario order
  /// All of the scenario: plant, channel, estimator and every sensor.
  bool all = true;
};
/// `--only` text: a comma list of plant, sensors (all of them), sensors=ID (then further bare
/// ids belong to it: "sensors=1,3"), channel, estimator, or "all". Throws std::invalid_argument
/// naming the bad word, an id the scenario does not have, or an empty selection.
LaunchRoles parse_launch_roles(const std::string& text, const std::vector<int>& scenario_sensor_ids);
/// "plant, sensors 1,3, channel" (for the launch line and the presence detail).
std::string describe_launch_roles(const LaunchRoles& roles);
/// The run id that every host's launch derives alike when none is given: the scenario's hash and
/// the domain mixed (never 0), so hosts with the same scenario and domain join the same run.
std::uint64_t derived_run_id(std::uint64_t scenario_hash, int domain);

/// What a plan is made of: the launch's options after validation and its private files.
struct LaunchPlanInputs {
  std::string scenario_file;    // the effective scenario every child reads
  std::string checkpoint_file;  // where a restarted estimator resumes from
  int domain = 0;
  std::string log_level = "warn";
  std::uint64_t run_id = 0;
  std::optional<std::string> discovery_server;  // ADDR:PORT of the Discovery Server in use
  std::string naming = "netkf";                  // --naming of every node
  std::optional<std::string> dds_profile;
  std::optional<std::string> secure_dir;  // absolute: the children of a secured launch are secured
  LaunchRoles roles;
  int sensors_per_process = 1;
  int sensor_nice = 0;
  double ready_timeout_s = 30.0;  // the plant's wait for the whole network
  bool estimator_standby = false;  // a second, hot-standby estimator (--standby)
  bool warm_spares = true;         // the channel and the estimator (without a standby) keep a warm spare
  bool records_samples = false;    // this launch reads the delivered samples (--record-samples)
};

struct PlannedChild {
  ChildSpec spec;
  bool estimator = false;  // resumes from the checkpoint file when restarted
};

/// With a standby: ownership strength of the estimator started `generation`-th (0: the primary,
/// 1: the standby, then each restart): every later one is weaker, so a restarted estimator comes
/// back as the standby of the one that took over, never taking the plant back from it.
std::uint32_t estimator_ownership_strength(int generation);
/// Without a standby no other estimator runs, and the one that replaces a dead one must be
/// *stronger* than it: a reader keeps the dead writer as the owner until its liveliness lease
/// expires (dds::kOwnershipLease, later under load) and drops the samples of a weaker or equally
/// strong newcomer (the GUIDs decide a tie) — the missed periods a warm spare publishes at once
/// were lost so (e2e fault_estimator: `none` rows before the restart). Life `generation` (0: the
/// first estimator) runs with the first strength when started afresh; a warm spare started
/// during it runs with the second, so that every life outranks the one before it.
std::uint32_t replacing_estimator_strength(int generation);        // primary + 2 generation
std::uint32_t replacing_estimator_spare_strength(int generation);  // one more
/// Set the value of `--ownership-strength` in an estimator's argv.
void set_ownership_strength(std::vector<std::string>& args, std::uint32_t strength);

struct LaunchPlan {
  std::vector<std::vector<int>> sensor_groups;  // sensor ids per sensor process
  std::vector<PlannedChild> children;           // in start order
};

/// The children of a launch: channel, estimator (with --resume-from the checkpoint file),
/// the sensor processes, and the plant last (it waits for presence, then counts this host's
/// truth readers: its sensor processes and this launch). `executable_of` maps a node name
/// ("plant_node") to its program (node_executable; the tests keep the name).
LaunchPlan plan_launch(const LaunchPlanInputs& in,
                       const std::function<std::string(const std::string&)>& executable_of = node_executable);

}  // namespace netkf::cli
