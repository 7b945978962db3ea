// estimator_node: fuses each period once (all samples in, or the deadline, whichever is
// first), publishes x̂_{k|k}, P_{k|k} every period (never NaN), and in a closed-loop
// scenario sends u_k = -L x̂_{k|k} to the plant. It never sees the truth: the plant's tick
// (k, t_k, applied input) is its only clock. The wiring is EstimatorApp (estimator_app.hpp).
#include <filesystem>
#include <string>

#include "netkf/node_main/run_node.hpp"
#include "netkf/nodes/estimator_app.hpp"
#include "netkf/records/checkpoint.hpp"

int main(int argc, char** argv) {
  CLI::App app{"netkf estimator_node: fuses the delivered samples of each period and publishes the estimate"};
  netkf::nodes::EstimatorAppOptions options;
  std::string resume_from;
  app.add_option("--status-period-ms", options.status_period_ms, "Log a summary this often")
      ->check(CLI::Range(10, 3600000))
      ->capture_default_str();
  app.add_option("--resume-from", resume_from,
                 "Checkpoint to continue from when the file exists (a restart; `netkf launch` writes it)");
  app.add_option("--ownership-strength", options.ownership_strength,
                 "Strength of its estimate and control writers: of several estimators (a hot standby) the plant "
                 "and every reader take the strongest live one's")
      ->capture_default_str();
  using netkf::nodes::EstimatorApp;
  return netkf::node_main::run_node<EstimatorApp>(
      argc, argv, app,
      {.name = [] { return std::string("estimator"); },
       .role = netkf::dds::Role::estimator,
       .describe = [](const netkf::Scenario& scenario, const netkf::dds::Participant& participant) {
         return fmt::format("scenario '{}': {} sensors, period {} ms, deadline {} ms, {} loop, domain {}",
                            scenario.name, scenario.sensors.size(), scenario.period_ms, scenario.deadline_ms(),
                            scenario.plant.control ? "closed" : "open", participant.domain());
       },
       .make = [&](const netkf::Scenario& scenario, netkf::dds::Participant& participant) {
         // A spare reads the checkpoint the launch wrote just before activating it.
         if (!resume_from.empty() && std::filesystem::exists(resume_from))
           options.resume = netkf::read_checkpoint(resume_from);
         return std::make_unique<EstimatorApp>(scenario, participant, options);
       }});
}
