// sensor_node: turns the truth x_k into y_{i,k} = C_i x_k + v_{i,k} and publishes it on the
// raw measurement topic (the channel emulator decides whether it reaches the estimator).
// One process is one sensor by default; `--sensor-id` repeated hosts several sensors on one
// DDS participant. The wiring is SensorApp (sensor_app.hpp).
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/nodes/sensor_app.hpp"
#include "netkf/nodes/sensor_simulator.hpp"
#include "netkf/scenario.hpp"

int main(int argc, char** argv) {
  CLI::App app{"netkf sensor_node: measures y = C_i x_k + v_k each period and publishes it"};
  netkf::dds::CommonNodeFlags common;
  netkf::nodes::SensorAppOptions options;
  netkf::dds::add_common_node_flags(app, common);
  app.add_option("--sensor-id", options.sensor_ids,
                 "Id of a sensor of the scenario; repeat it to host several sensors in this process")
      ->required();
  app.add_option("--raw-readers", options.raw_readers,
                 "Before saying it is present (the plant starts period 0 when every process is), wait at most 5 s "
                 "for this many readers of its samples (the channel)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  const std::string ids = netkf::nodes::describe_sensor_ids(options.sensor_ids);
  try {
    netkf::dds::setup_node_logging("sensor-" + ids, common.log_level);
    // Checked before the participant exists (SensorApp checks them too), in the flag's words.
    if (std::set<int>(options.sensor_ids.begin(), options.sensor_ids.end()).size() != options.sensor_ids.size())
      throw std::invalid_argument("--sensor-id " + ids + " names a sensor twice");
    const netkf::Scenario scenario = netkf::load_scenario_file(common.scenario);
    for (int id : options.sensor_ids) {
      [[maybe_unused]] const netkf::nodes::SensorSimulator known(scenario, id);  // throws for an unknown id
    }
    netkf::dds::Participant participant(
        netkf::dds::node_participant_options(common, scenario, "netkf-sensor-" + ids, netkf::dds::Role::sensor));
    spdlog::info("sensor {} of scenario '{}', domain {}", ids, scenario.name, participant.domain());
    {
      netkf::nodes::SensorApp node(scenario, participant, options);
      const netkf::dds::StopOnSignal stop_on_signal(node.io(), [&](int) { node.stop(); });
      node.run();
      node.log_summary();
    }
    spdlog::info("left DDS domain {}", participant.domain());
    return 0;
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
}
