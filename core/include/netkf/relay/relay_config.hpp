#pragma once
// A `netkf relay` file (docs/relay.md, "A relay file"): the two domains and a link per topic.
//
//   relay:
//     from_domain: 1
//     to_domain: 2
//     seed: 7          # optional (1)
//     depth: 100       # optional: keep-last history of the relay's readers and writers
//     topics:
//       - name: rt/scan
//         type: sensor_msgs::msg::dds_::LaserScan_   # optional: relay only writers of this type
//         link: { model: gilbert_elliott, p: 0.05, r: 0.25 }
//       - name: rt/odom
//         link: { model: bernoulli, loss: 0.1, delay_ms: 5 }
//         per_writer: true   # optional: each writer of the topic its own link, a copy of this one
//   events:            # optional: a timeline of link changes, by the topic's sample index
//     - { at_sample: 200, topic: rt/scan, set: { loss: 1.0 } }
//     - { at_sample: 500, topic: rt/odom, ramp: { to: { loss: 0.5 }, over_samples: 100 } }
//
// Read by the scenario's YAML loader (core/src/model/scenario_loader.cpp): the same link keys, trace
// paths relative to the file, and errors as FILE:LINE:COL: message (ScenarioError).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "netkf/relay/relay_links.hpp"

namespace netkf {

struct RelayConfig {
  int from_domain = 0;
  int to_domain = 1;
  std::uint64_t seed = 1;
  int depth = 100;
  std::vector<RelayTopic> topics;
  std::vector<RelayEvent> events;  // in the file's order (RelayLinks applies them stable by at_sample)
};

/// Throws ScenarioError naming the line and column of the first problem.
RelayConfig parse_relay_config(const std::string& yaml_text, const std::string& source_name);
RelayConfig load_relay_config_file(const std::filesystem::path& path);

/// An events file for the relay `config` (what `--record FILE` journals as FILE.events.yaml:
/// `events:` with a list, or the bare list), checked as the relay file's own events are, from
/// the topics' links in `config`. Throws ScenarioError as FILE:LINE:COL: message.
std::vector<RelayEvent> parse_relay_events(const std::string& yaml_text, const RelayConfig& config,
                                           const std::string& source_name);
std::vector<RelayEvent> load_relay_events_file(const std::filesystem::path& path, const RelayConfig& config);
/// The events as YAML text in that format (every number exact: a replay is bit-identical).
std::string relay_events_to_yaml(const std::vector<RelayEvent>& events);

}  // namespace netkf
