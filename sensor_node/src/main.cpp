// sensor_node: turns the truth x_k into y_{i,k} = C_i x_k + v_{i,k} and publishes it on the
// raw measurement topic (the channel emulator decides whether it reaches the estimator).
#include <utility>  // before Asio (Boost 1.74 + GCC 12, dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/nodes/sensor_simulator.hpp"
#include "netkf/scenario.hpp"

namespace wire = netkf::wire;

int main(int argc, char** argv) {
  CLI::App app{"netkf sensor_node: measures y = C_i x_k + v_k each period and publishes it"};
  netkf::dds::CommonNodeFlags common;
  int sensor_id = 0;
  netkf::dds::add_common_node_flags(app, common);
  app.add_option("--sensor-id", sensor_id, "Id of this sensor in the scenario")->required();
  CLI11_PARSE(app, argc, argv);

  try {
    netkf::dds::setup_node_logging("sensor-" + std::to_string(sensor_id), common.log_level);
    const netkf::Scenario scenario = netkf::load_scenario_file(common.scenario);
    netkf::nodes::SensorSimulator sensor(scenario, sensor_id);
    const int n = scenario.state_dim();
    boost::asio::io_context io;
    netkf::dds::Participant participant(
        netkf::dds::node_participant_options(common, "netkf-sensor-" + std::to_string(sensor_id)));
    spdlog::info("sensor {} of scenario '{}' ({} outputs), domain {}", sensor_id, scenario.name,
                 sensor.output_dim(), participant.domain());
    {
      netkf::dds::Writer<wire::Measurement> raw(participant, netkf::dds::topics::raw_measurement);
      auto on_truth = [&](wire::Truth truth) {
        try {
          const netkf::Vector x = netkf::dds::truth_state(truth, n);
          std::string why;
          auto y = sensor.measure(truth.k(), x, &why);
          if (!y) {
            spdlog::warn("period {} not measured: {}", truth.k(), why);
            return;
          }
          raw.write(netkf::dds::make_measurement(sensor_id, truth.k(), netkf::dds::steady_now_ns(), *y));
        } catch (const std::exception& e) {
          spdlog::warn("truth for period {} rejected: {}", truth.k(), e.what());
        }
      };
      netkf::dds::Reader<wire::Truth> truth_reader(participant, netkf::dds::topics::truth,
                                                   netkf::dds::post_to<wire::Truth>(io.get_executor(), on_truth));
      const netkf::dds::StopOnSignal stop_on_signal(
          io, [&](int) { spdlog::info("{} samples measured", sensor.measured()); });
      io.run();
    }
    spdlog::info("left DDS domain {}", participant.domain());
    return 0;
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
}
