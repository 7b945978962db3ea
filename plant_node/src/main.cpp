// plant_node: the stand-in for the physical world (docs/architecture.md). Each period T it steps
// x_{k+1} = A x_k + B u_k + w_k and publishes the truth (netkf/truth) and the sample
// clock with the applied input (netkf/tick). The wiring is PlantApp (plant_app.hpp).
#include "netkf/node_main/run_node.hpp"
#include "netkf/nodes/plant_app.hpp"

int main(int argc, char** argv) {
  CLI::App app{"netkf plant_node: simulates x_{k+1} = A x_k + B u_k + w_k and publishes truth and sample clock"};
  netkf::nodes::PlantAppOptions options;
  app.add_option("--max-periods", options.max_periods, "Stop after this many periods (0 = unlimited)")
      ->capture_default_str();
  app.add_option("--startup-wait-ms", options.startup_wait_ms,
                 "Wait at most this long for the sensors and the estimator to match before period 0")
      ->capture_default_str();
  app.add_option("--truth-readers", options.truth_readers,
                 "Truth readers to wait for before period 0 (default: one per sensor; with sensors grouped "
                 "in processes, one per sensor process; a launcher that also records the truth adds 1)");
  app.add_option("--tick-readers", options.tick_readers,
                 "Tick readers (estimators) to wait for before period 0 (2 with a hot standby)")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  app.add_flag("--wait-for-presence", options.wait_for_presence,
               "Start when netkf/presence shows every sensor, the channel and the estimator of this run (and the "
               "truth has matched every present reader); fail naming the missing after --startup-wait-ms");
  using netkf::nodes::PlantApp;
  return netkf::node_main::run_node<PlantApp>(
      argc, argv, app,
      {.name = [] { return std::string("plant"); },
       .role = netkf::dds::Role::plant,
       .describe = [](const netkf::Scenario& scenario, const netkf::dds::Participant& participant) {
         return fmt::format("scenario '{}' period {} ms, domain {}", scenario.name, scenario.period_ms,
                            participant.domain());
       },
       .make = [&](const netkf::Scenario& scenario, netkf::dds::Participant& participant) {
         return std::make_unique<PlantApp>(scenario, participant, options);
       }});
}
