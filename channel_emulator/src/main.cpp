// channel_emulator: relays raw measurements to the delivered topic through one link per
// sensor (loss, then an optional delay, seeded from the scenario), tunable at runtime through
// netkf/link/control. The wiring, and its threads, are ChannelApp (channel_app.hpp).
#include "netkf/node_main/run_node.hpp"
#include "netkf/nodes/channel_app.hpp"
#include "netkf/nodes/channel_links.hpp"

int main(int argc, char** argv) {
  CLI::App app{"netkf channel_emulator: drops samples per link model and relays the rest; tunable at runtime"};
  netkf::nodes::ChannelAppOptions options;
  app.add_option("--status-period-ms", options.status_period_ms, "Publish link status this often")
      ->check(CLI::Range(10, 3600000))
      ->capture_default_str();
  app.add_option("--delivered-readers", options.delivered_readers,
                 "Before saying it is present (the plant starts period 0 when every process is), wait at most 5 s "
                 "for this many readers of the delivered samples (the estimator, the launch's recorder)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  using netkf::nodes::ChannelApp;
  return netkf::node_main::run_node<ChannelApp>(
      argc, argv, app,
      {.name = [] { return std::string("channel"); },
       .role = netkf::dds::Role::channel,
       // Checked before the participant exists (ChannelApp builds its own links the same way).
       .check = [](const netkf::Scenario& scenario) { const netkf::nodes::ChannelLinks check_links(scenario); },
       .describe = [](const netkf::Scenario& scenario, const netkf::dds::Participant& participant) {
         return fmt::format("scenario '{}': {} links, domain {}", scenario.name, scenario.sensors.size(),
                            participant.domain());
       },
       // Logs each link and the timeline.
       .make = [&](const netkf::Scenario& scenario, netkf::dds::Participant& participant) {
         return std::make_unique<ChannelApp>(scenario, participant, options);
       }});
}
