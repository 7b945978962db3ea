#pragma once
// The summary of a `netkf relay` run and its checks (`--summary FILE.json`,
// `--check 'link.rt/chatter.observed_loss<0.35'`, docs/relay.md): a launch's checks
// (run_summary.hpp: the same syntax, table and verdicts) on what each relayed topic's link did.
// No DDS: the relay hands over its links' counts at its end.
//
// The quantities, per topic as `link.TOPIC.NAME` (TOPIC the topic's name, e.g. rt/chatter):
//   samples, delivered, dropped   the link's counts since the relay started (never reset by a change)
//   refused                       delivered samples the destination's DDS writer refused
//   observed_loss                 dropped / samples
//   mean_burst                    mean length of the runs of consecutive drops (0 without a drop)
//   observed_arrival_rate_since_change   delivered / samples since the link was last set
// A quantity with nothing to measure (a topic without samples) has no value: null in the
// JSON, and a check on it fails, saying why.
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "netkf/cli/live/run_summary.hpp"
#include "netkf/links/loss_model.hpp"

namespace netkf::cli {

/// One relayed topic's link at the relay's end.
struct RelayTopicSummary {
  std::string topic;
  LinkStatistics lifetime;      // since the relay started
  LinkStatistics since_change;  // since the link was last set
  std::uint64_t refused = 0;
};

/// The per-topic quantity names above, in their order.
std::vector<std::string> relay_quantity_names();

/// Parses a check (run_summary.hpp's syntax) on `link.TOPIC.NAME` for one of `topics`, or for a
/// writer's link `link.TOPIC@WRITER.NAME` of one of `per_writer_topics`; throws
/// std::invalid_argument naming what is wrong (the topics and names there are).
Check parse_relay_check(const std::string& text, const std::vector<std::string>& topics,
                        const std::vector<std::string>& per_writer_topics = {});

/// The value of `link.TOPIC.NAME`; not measured (the check fails, saying so) for a writer's link
/// no writer of that name made; throws std::invalid_argument for a name that is none.
Measured measure_relay(const std::vector<RelayTopicSummary>& topics, const std::string& name);

/// The summary as JSON: "link": {"TOPIC": {every quantity}}, "checks", "passed".
nlohmann::ordered_json relay_summary_json(const std::vector<RelayTopicSummary>& topics,
                                          const std::vector<CheckResult>& results);

}  // namespace netkf::cli
