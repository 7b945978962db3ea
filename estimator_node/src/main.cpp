// estimator_node: fuses each period once (all samples in, or the deadline, whichever is
// first), publishes x̂_{k|k}, P_{k|k} every period (never NaN), and in a closed-loop
// scenario sends u_k = -L x̂_{k|k} to the plant. It never sees the truth: the plant's tick
// (k, t_k, applied input) is its only clock. The wiring is EstimatorApp (estimator_app.hpp).
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <filesystem>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/nodes/estimator_app.hpp"
#include "netkf/scenario.hpp"

int main(int argc, char** argv) {
  CLI::App app{"netkf estimator_node: fuses the delivered samples of each period and publishes the estimate"};
  netkf::dds::CommonNodeFlags common;
  netkf::nodes::EstimatorAppOptions options;
  std::string resume_from;
  netkf::dds::add_common_node_flags(app, common);
  app.add_option("--status-period-ms", options.status_period_ms, "Log a summary this often")
      ->check(CLI::Range(10, 3600000))
      ->capture_default_str();
  app.add_option("--resume-from", resume_from,
                 "Checkpoint to continue from when the file exists (a restart; `netkf launch` writes it)");
  app.add_option("--ownership-strength", options.ownership_strength,
                 "Strength of its estimate and control writers: of several estimators (a hot standby) the plant "
                 "and every reader take the strongest live one's")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  netkf::dds::SpareGate spare(common.spare);  // before any thread

  try {
    netkf::dds::setup_node_logging("estimator", common.log_level);
    const netkf::Scenario scenario = netkf::load_scenario_file(common.scenario);
    netkf::dds::Participant participant(
        netkf::dds::node_participant_options(common, scenario, "netkf-estimator", netkf::dds::Role::estimator));
    // A spare reads the checkpoint the launch wrote just before activating it.
    if (!spare.wait_until_needed()) return 0;
    if (!resume_from.empty() && std::filesystem::exists(resume_from))
      options.resume = netkf::nodes::read_checkpoint(resume_from);
    spdlog::info("scenario '{}': {} sensors, period {} ms, deadline {} ms, {} loop, domain {}", scenario.name,
                 scenario.sensors.size(), scenario.period_ms, scenario.deadline_ms(),
                 scenario.plant.control ? "closed" : "open", participant.domain());
    {
      netkf::nodes::EstimatorApp node(scenario, participant, options);
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
