#pragma once
// What every node's main is (docs/architecture.md, "Layers"): the common flags and the node's
// own, logging on stderr, the scenario, the participant, a warm spare's wait (--spare), and the
// node's app run until SIGINT/SIGTERM. With netkf's `commands` room, the only library that links
// CLI11: a node's `main.cpp` adds its flags and says how to build its app.
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "netkf/dds/node_support.hpp"
#include "netkf/dds/participant.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::node_main {

struct CommonNodeFlags {
  std::string scenario;                   // --scenario FILE (required)
  std::optional<int> domain;              // --domain N (default $NETKF_DOMAIN, else 0)
  std::optional<std::string> dds_profile; // --dds-profile FILE (default $NETKF_DDS_PROFILE, else built-in localhost-only)
  std::optional<std::string> secure;      // --secure DIR (default $NETKF_SECURE, else no DDS Security)
  std::string log_level = "info";         // --log-level trace|debug|info|warn|error
  std::uint64_t run_id = 0;               // --run-id N (given by `netkf launch`; 0: accept every run)
  std::optional<std::string> discovery_server;  // --discovery-server ADDR:PORT (default $NETKF_DISCOVERY_SERVER)
  std::optional<std::string> naming;      // --naming netkf|ros2 (default $NETKF_NAMING, else the scenario's)
  bool spare = false;                     // --spare: join the network, then wait for SIGUSR1 (dds::SpareGate)
};

/// Register the common flags on `app`.
void add_common_node_flags(CLI::App& app, CommonNodeFlags& flags);

/// Log to stderr with the node's name in every line, at `level` (validated by the flags).
void setup_node_logging(const std::string& node_name, const std::string& level);

/// Resolve domain, profile, security directory and naming (flag, then environment, then the
/// scenario or the default); `role`: the identity the node uses when security is on. Throws DdsError.
dds::ParticipantOptions node_participant_options(const CommonNodeFlags& flags, const Scenario& scenario,
                                                 const std::string& participant_name, dds::Role role);

/// One node: its name and role, and the steps that are its own. `App` has io(), run(), stop()
/// and log_summary() (PlantApp, SensorApp, ChannelApp, EstimatorApp).
template <class App>
struct Node {
  /// The node's name once its flags are parsed ("plant", "sensor-1,2"): its log lines carry it,
  /// its participant is "netkf-" + name.
  std::function<std::string()> name;
  dds::Role role = dds::Role::plant;
  /// Checks before the participant exists, in the flags' words (throws on a mistake).
  std::function<void(const Scenario&)> check = {};
  /// The line logged once the participant exists.
  std::function<std::string(const Scenario&, const dds::Participant&)> describe;
  /// The app, built after a spare's wait.
  std::function<std::unique_ptr<App>(const Scenario&, dds::Participant&)> make;
};

/// Parse `app` (its own flags added, the common ones added here) and run `node`: exit code 0
/// after a clean stop (or a spare told to end), 1 after an error (logged), CLI11's for bad flags.
template <class App>
int run_node(int argc, char** argv, CLI::App& app, const Node<App>& node) {
  CommonNodeFlags common;
  add_common_node_flags(app, common);
  CLI11_PARSE(app, argc, argv);
  dds::SpareGate spare(common.spare);  // before any thread
  try {
    const std::string name = node.name();
    setup_node_logging(name, common.log_level);
    const Scenario scenario = load_scenario_file(common.scenario);
    if (node.check) node.check(scenario);
    dds::Participant participant(node_participant_options(common, scenario, "netkf-" + name, node.role));
    spdlog::info("{}", node.describe(scenario, participant));
    if (!spare.wait_until_needed()) return 0;
    {
      const std::unique_ptr<App> app_of_node = node.make(scenario, participant);
      // Before run(): a start-up wait runs on the io thread, so a signal ends it at once.
      const dds::StopOnSignal stop_on_signal(app_of_node->io(), [&](int) { app_of_node->stop(); });
      app_of_node->run();
      app_of_node->log_summary();
    }
    spdlog::info("left DDS domain {}", participant.domain());
    return 0;
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
}

}  // namespace netkf::node_main
