// sensor_node: turns the truth x_k into y_{i,k} = C_i x_k + v_{i,k} and publishes it on the
// raw measurement topic (the channel emulator decides whether it reaches the estimator).
// One process is one sensor by default; `--sensor-id` repeated hosts several sensors on one
// DDS participant (a gateway in front of many sensors, or a dense network on a small machine):
// each keeps its own C_i, R_i and noise stream and publishes its own samples.
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <set>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/nodes/sensor_simulator.hpp"
#include "netkf/scenario.hpp"

namespace wire = netkf::wire;

namespace {
std::string describe_ids(const std::vector<int>& ids) {
  std::string text;
  for (int id : ids) text += (text.empty() ? "" : ",") + std::to_string(id);
  return text;
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"netkf sensor_node: measures y = C_i x_k + v_k each period and publishes it"};
  netkf::dds::CommonNodeFlags common;
  std::vector<int> sensor_ids;
  netkf::dds::add_common_node_flags(app, common);
  app.add_option("--sensor-id", sensor_ids,
                 "Id of a sensor of the scenario; repeat it to host several sensors in this process")
      ->required();
  CLI11_PARSE(app, argc, argv);

  const std::string ids = describe_ids(sensor_ids);
  try {
    netkf::dds::setup_node_logging("sensor-" + ids, common.log_level);
    if (std::set<int>(sensor_ids.begin(), sensor_ids.end()).size() != sensor_ids.size())
      throw std::invalid_argument("--sensor-id " + ids + " names a sensor twice");
    const netkf::Scenario scenario = netkf::load_scenario_file(common.scenario);
    std::vector<netkf::nodes::SensorSimulator> sensors;
    for (int id : sensor_ids) sensors.emplace_back(scenario, id);
    const int n = scenario.state_dim();
    boost::asio::io_context io;
    netkf::dds::Participant participant(netkf::dds::node_participant_options(common, "netkf-sensor-" + ids, netkf::dds::Role::sensor));
    spdlog::info("sensor {} of scenario '{}', domain {}", ids, scenario.name, participant.domain());
    {
      netkf::dds::Writer<wire::Measurement> raw(participant, netkf::dds::topics::raw_measurement,
                                                static_cast<double>(sensors.size()) / scenario.period_s());
      // Runs on the DDS receive thread: a few multiply-adds and a write per sensor, cheaper than
      // the context switch a hand-off to the io thread would cost (endpoints.hpp).
      auto on_truth = [&](wire::Truth&& truth) {
        netkf::Vector x;
        try {
          x = netkf::dds::truth_state(truth, n);
        } catch (const std::exception& e) {
          spdlog::warn("truth for period {} rejected: {}", truth.k(), e.what());
          return;
        }
        for (auto& sensor : sensors) {
          std::string why;
          const auto y = sensor.measure(truth.k(), x, &why);
          if (!y) {
            spdlog::warn("sensor {}: period {} not measured: {}", sensor.id(), truth.k(), why);
            continue;
          }
          raw.write(netkf::dds::make_measurement(sensor.id(), truth.k(), netkf::dds::steady_now_ns(), *y));
        }
      };
      netkf::dds::Reader<wire::Truth> truth_reader(participant, netkf::dds::topics::truth, on_truth);
      const netkf::dds::StopOnSignal stop_on_signal(io);
      io.run();
    }  // the reader is gone: nothing measures any more
    for (const auto& sensor : sensors) spdlog::info("sensor {}: {} samples measured", sensor.id(), sensor.measured());
    spdlog::info("left DDS domain {}", participant.domain());
    return 0;
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
}
