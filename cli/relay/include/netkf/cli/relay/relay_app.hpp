#pragma once
// `netkf relay` (docs/relay.md): every sample of the named topics that a writer on one DDS
// domain publishes is passed, through its topic's lossy link, to readers on another domain,
// under the same topic name and type name, its serialized payload untouched. The relay needs
// no IDL: a topic is relayed from the moment discovery shows a writer of it on the source
// domain, with that writer's reliability and durability.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "netkf/model/scenario.hpp"  // TopicNaming
#include "netkf/relay/relay_links.hpp"

namespace netkf::cli {

struct RelayOptions {
  int from_domain = 0;
  int to_domain = 1;
  std::vector<RelayTopic> topics;
  std::uint64_t seed = 1;
  /// Keep-last history of the relay's readers and writers (per instance).
  int depth = 100;
  /// Fast DDS XML profile of both participants (nullopt: the built-in localhost-only one).
  std::optional<std::filesystem::path> profile;
  /// The names of netkf's own topics it uses (link control, reply, status, journal: docs/ros2.md);
  /// the relayed topics keep theirs.
  TopicNaming naming = TopicNaming::netkf;
  /// A CSV line per sample (topic,index,sequence,bytes,fate,delay_ms), created by the relay;
  /// beside it the journal RECORD.events.yaml, every change of a topic's link with the sample
  /// it applied from, rewritten as changes happen (relay_journal_file).
  std::optional<std::filesystem::path> record;
  /// The changes to make at given samples: the relay file's `events:` or a replayed journal.
  std::vector<RelayEvent> timeline;
  /// Serve the topics' links on 127.0.0.1:PORT (0: any free port): GET /metrics (Prometheus) and
  /// the Foxglove WebSocket with netkf/link/status (`--dashboard`).
  std::optional<unsigned short> metrics_port;
};

/// What each topic's link did (a per-writer topic: each writer's link, and the topic their sum).
struct RelayTopicCounts {
  std::string topic;  // a topic, or a writer's link (topic@writer)
  std::string type;  // as discovered ("" while no writer was seen)
  std::uint64_t samples = 0, delivered = 0, dropped = 0, refused = 0;  // refused: DDS refused the write
  LinkStatistics lifetime;      // the link's, since the relay started
  LinkStatistics since_change;  // since the link was last set
};

/// The journal a relay recording `record` writes beside it (a launch's journal's name).
inline std::filesystem::path relay_journal_file(const std::filesystem::path& record) {
  return record.string() + ".events.yaml";
}

class RelayApp {
 public:
  /// Throws (DDS, the record file) with a clear message.
  explicit RelayApp(RelayOptions options);
  ~RelayApp();
  RelayApp(const RelayApp&) = delete;
  RelayApp& operator=(const RelayApp&) = delete;

  /// Runs the relay's thread (discovery's follow-up, delayed samples) until stop().
  void run();
  void stop();
  /// The port /metrics is served on (nullopt: none).
  std::optional<unsigned short> metrics_port() const;
  std::vector<RelayTopicCounts> counts() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace netkf::cli
