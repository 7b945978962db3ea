// channel_emulator: relays raw measurements to the delivered topic through one link per
// sensor (loss, then an optional delay, seeded from the scenario), tunable at runtime through
// netkf/link/control. The wiring, and its threads, are ChannelApp (channel_app.hpp).
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/nodes/channel_app.hpp"
#include "netkf/scenario.hpp"

int main(int argc, char** argv) {
  CLI::App app{"netkf channel_emulator: drops samples per link model and relays the rest; tunable at runtime"};
  netkf::dds::CommonNodeFlags common;
  netkf::nodes::ChannelAppOptions options;
  netkf::dds::add_common_node_flags(app, common);
  app.add_option("--status-period-ms", options.status_period_ms, "Publish link status this often")
      ->check(CLI::Range(10, 3600000))
      ->capture_default_str();
  app.add_option("--delivered-readers", options.delivered_readers,
                 "Before saying it is present (the plant starts period 0 when every process is), wait at most 5 s "
                 "for this many readers of the delivered samples (the estimator, the launch's recorder)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  netkf::dds::SpareGate spare(common.spare);  // before any thread

  try {
    netkf::dds::setup_node_logging("channel", common.log_level);
    const netkf::Scenario scenario = netkf::load_scenario_file(common.scenario);
    // Checked before the participant exists (ChannelApp builds its own links the same way).
    const netkf::nodes::ChannelLinks check_links(scenario);
    netkf::dds::Participant participant(
        netkf::dds::node_participant_options(common, scenario, "netkf-channel", netkf::dds::Role::channel));
    spdlog::info("scenario '{}': {} links, domain {}", scenario.name, scenario.sensors.size(), participant.domain());
    if (!spare.wait_until_needed()) return 0;
    {
      netkf::nodes::ChannelApp node(scenario, participant, options);  // logs each link and the timeline
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
