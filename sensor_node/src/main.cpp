// sensor_node: turns the truth x_k into y_{i,k} = C_i x_k + v_{i,k} and publishes it on the
// raw measurement topic (the channel emulator decides whether it reaches the estimator).
// One process is one sensor by default; `--sensor-id` repeated hosts several sensors on one
// DDS participant. The wiring is SensorApp (sensor_app.hpp).
#include <set>
#include <stdexcept>
#include <string>

#include "netkf/node_main/run_node.hpp"
#include "netkf/nodes/sensor_app.hpp"
#include "netkf/nodes/sensor_simulator.hpp"

int main(int argc, char** argv) {
  CLI::App app{"netkf sensor_node: measures y = C_i x_k + v_k each period and publishes it"};
  netkf::nodes::SensorAppOptions options;
  app.add_option("--sensor-id", options.sensor_ids,
                 "Id of a sensor of the scenario; repeat it to host several sensors in this process")
      ->required();
  app.add_option("--raw-readers", options.raw_readers,
                 "Before saying it is present (the plant starts period 0 when every process is), wait at most 5 s "
                 "for this many readers of its samples (the channel)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  const auto ids = [&] { return netkf::nodes::describe_sensor_ids(options.sensor_ids); };
  using netkf::nodes::SensorApp;
  return netkf::node_main::run_node<SensorApp>(
      argc, argv, app,
      {.name = [&] { return "sensor-" + ids(); },
       .role = netkf::dds::Role::sensor,
       // Checked before the participant exists (SensorApp checks them too), in the flag's words.
       .check = [&](const netkf::Scenario& scenario) {
         if (std::set<int>(options.sensor_ids.begin(), options.sensor_ids.end()).size() != options.sensor_ids.size())
           throw std::invalid_argument("--sensor-id " + ids() + " names a sensor twice");
         for (int id : options.sensor_ids) {
           [[maybe_unused]] const netkf::nodes::SensorSimulator known(scenario, id);  // throws for an unknown id
         }
       },
       .describe = [&](const netkf::Scenario& scenario, const netkf::dds::Participant& participant) {
         return fmt::format("sensor {} of scenario '{}', domain {}", ids(), scenario.name, participant.domain());
       },
       .make = [&](const netkf::Scenario& scenario, netkf::dds::Participant& participant) {
         return std::make_unique<SensorApp>(scenario, participant, options);
       }});
}
