#pragma once
// The links of `netkf relay` (docs/relay.md): one per relayed topic, each with its own seeded
// loss and delay streams, so the same seed and the same samples make the same decisions.
// DDS-free: which sample of a topic is dropped, how long a delivered one is held, what each
// link did. A topic's n-th sample (n = 0, 1, ...) plays the role a period plays for a sensor's
// link (a trace link replays row offset + n).
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "netkf/fit/recent_loss_fit.hpp"
#include "netkf/links/link.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/loss_model.hpp"
#include "netkf/model/scenario.hpp"  // LinkEvent::Kind
#include "netkf/records/link_change.hpp"
#include "netkf/records/link_status.hpp"

namespace netkf {

/// The link ids of relayed topics are below this one (-1 is the actuation link's).
inline constexpr int kRelayTopicLinkId = -2;
/// A link change for a relayed topic (`netkf ctl set-link rt/scan ...`) travels as an ordinary
/// link-control request with the topic's link id (relay_topic_link_id), its topic named by the
/// key `topic` (a word) before the link's own keys; the channel emulator ignores it, a relay
/// answers for its own topics.
inline constexpr const char* kRelayTopicKey = "topic";

/// The one id of a relayed topic's link: its requests, replies, status and journal carry it
/// (wire::LinkStatus is keyed by it); below kRelayTopicLinkId, from a hash of the topic's name,
/// so every relay and every reader gives a topic the same id; the topic itself travels beside it.
int relay_topic_link_id(const std::string& topic);
/// Whether a link id is one relay_topic_link_id makes.
inline bool is_relay_topic_link_id(int link_id) { return link_id < kRelayTopicLinkId; }

/// The name of one writer's link on a topic relayed per writer: `topic@writer` (rt/scan@robot1).
/// Status, journal and recording carry it where a topic's link carries the topic, and
/// relay_topic_link_id(name) is the link's id.
std::string relay_writer_link_name(const std::string& topic, const std::string& writer);

/// A topic to relay and its link.
struct RelayTopic {
  RelayTopic() = default;
  RelayTopic(std::string topic, LinkSpec topic_link, std::optional<std::string> type_name = std::nullopt,
             bool link_per_writer = false)
      : name(std::move(topic)), link(std::move(topic_link)), type(std::move(type_name)), per_writer(link_per_writer) {}
  std::string name;  // the DDS topic name, e.g. rt/scan
  LinkSpec link;
  std::optional<std::string> type;  // relay only writers of this type name (nullopt: any)
  /// Each writer of the topic has its own link, a copy of `link` (RelayLinks::add_writer_link).
  bool per_writer = false;
};

/// A change of one topic's link at one of its samples (a relay file's `events:`, a replayed
/// journal): `set` applies its keys from the topic's sample `at_sample` on; a ramp moves each
/// numeric key of `keys` linearly from its value at `at_sample` to the value given, one step
/// per sample, reaching it at at_sample + ramp_samples (a scenario's LinkEvent, by sample).
struct RelayEvent {
  std::uint64_t at_sample = 0;
  std::string topic;
  LinkEvent::Kind kind = LinkEvent::Kind::set;
  LinkKeys keys;
  std::uint64_t ramp_samples = 0;
  bool operator==(const RelayEvent&) const = default;
};

/// One entry of a relay's journal: a change of a topic's link and the index of the topic's
/// first sample under it.
/// A relayed link's journal entry: the change (sensor_id is relay_topic_link_id of its topic,
/// at_period the index of the topic's first sample it applied to) and what a replay needs to make
/// the same change at the same sample (the journal file's entry): a set of the whole link, or the
/// timeline's ramp as it started; nullopt for a ramp's end and a failure (a replay gets there by
/// itself).
struct RelayLinkChange : LinkChange {
  std::optional<RelayEvent> replay;
};

/// The decision for one relayed sample.
struct RelayFate {
  std::uint64_t index = 0;  // the sample's number on its topic (0 first)
  bool delivered = false;
  double delay_ms = 0.0;    // delivered: how long to hold it first
};

class RelayLinks {
 public:
  /// Topic i draws its losses from derive_seed(seed, "relay-link", hash of its name) and its
  /// delays from derive_seed(seed, "relay-link-delay", the same hash): a topic keeps its streams
  /// whatever other topics are relayed. Throws std::invalid_argument on a duplicate or empty
  /// topic name, or an event of a topic that is not relayed. `timeline`: the changes to make at
  /// given samples (in the order they apply: stable by at_sample); the traces it names are read
  /// here, never on the sample path. An event of a per-writer topic is every writer's link's
  /// (at that writer's sample); one of a writer's link (`topic@writer`, as a journal names it)
  /// waits for that writer.
  RelayLinks(const std::vector<RelayTopic>& topics, std::uint64_t seed, const std::vector<RelayEvent>& timeline = {});

  /// A topic relayed per writer (RelayTopic::per_writer) has no link of its own: its link is the
  /// model of its writers' links, each added at run time, named relay_writer_link_name(topic,
  /// writer), a copy of the topic's current link and timeline with streams of its own, seeded
  /// from its name as a topic's are (so a writer of the same name makes the same decisions in
  /// every run). A writer's link made after a live change of the topic starts with a journal
  /// entry of its link at sample 0 (so a replay makes it alike). Returns the link's name (also
  /// when it exists already); nullopt for a topic not relayed per writer. Throws
  /// std::invalid_argument for an empty writer or a name a topic has.
  std::optional<std::string> add_writer_link(const std::string& topic, const std::string& writer);
  /// Whether `topic` is relayed with a link per writer.
  bool per_writer(const std::string& topic) const;
  /// The names of a per-writer topic's writers' links, in the order they were added.
  std::vector<std::string> writer_links(const std::string& topic) const;

  /// The fate of the next sample of a topic's or a writer's link (by its name); nullopt for a
  /// name that is not a link (a per-writer topic's own name included). First what
  /// is due at this sample applies (the timeline's events with at_sample <= its index, then a
  /// running ramp's step), then the loss draw, and for a delivered sample the delay draw.
  std::optional<RelayFate> on_sample(const std::string& name);

  /// Replace a link from its next sample on (statistics since the change restart, a running ramp
  /// ends), journaled as a request; false for an unknown name. A per-writer topic's name changes
  /// every one of its writers' links (each journaled) and the model of those to come. Throws
  /// LinkError on an invalid link (nothing changes). Made at sample n, it decides exactly as a
  /// timeline `set` of the whole link at_sample n: the streams keep their state either way.
  bool set_link(const std::string& name, const LinkSpec& link, std::uint64_t request_id = 0);

  /// The journal entries made since the previous call, in the order the changes applied.
  std::vector<RelayLinkChange> take_changes();
  bool has_changes() const { return !changes_.empty(); }
  /// The answer to a change request, as the channel's links keep it (the status shows it); for a
  /// per-writer topic, on each of its writers' links.
  void note_request(const std::string& name, std::uint64_t request_id, const std::string& reject_reason);

  /// A link's current spec (a per-writer topic's: the model of its writers' links); nullopt for
  /// a name that is not relayed.
  std::optional<LinkSpec> link(const std::string& name) const;

  /// A link's status (sensor_id relay_topic_link_id of its name, in_time 1: a relay has no
  /// deadline; `held` is the caller's) and where its topic's next sample is.
  struct Report : LinkStatus {
    std::uint64_t next_sample = 0;  // the index the topic's next sample gets (where a change applies)
  };
  /// A link's running statistics, since it was set and since the relay started (a relay's
  /// summary needs more of them than a status carries); nullopt for a name that is not a link.
  struct Statistics {
    LinkStatistics since_change;
    LinkStatistics lifetime;
  };
  std::optional<Statistics> statistics(const std::string& name) const;
  /// Every link's report: the topics' and the writers' links (not a per-writer topic's model).
  std::vector<Report> reports() const;
  /// One link's report; nullopt for a name that is not a link.
  std::optional<Report> report(const std::string& name) const;

 private:
  struct Ramp {
    std::uint64_t start = 0;    // the sample it started at
    std::uint64_t samples = 0;  // its length
    std::vector<std::pair<std::string, double>> from;  // each key's value at `start`
    LinkKeys to;
  };
  struct Link {
    Link(LinkSpec link, LinkLossProcess loss_process, LinkDelayProcess delay_process)
        : spec(std::move(link)), loss(std::move(loss_process)), delay(std::move(delay_process)) {}
    LinkSpec spec;
    LinkLossProcess loss;
    LinkDelayProcess delay;
    LinkStatistics stats;
    LinkStatistics lifetime;
    fit::RecentArrivals recent;  // emptied with `stats`
    std::uint64_t last_request_id = 0;
    std::string reject_reason;
    std::uint64_t samples = 0;      // every sample of the topic (the trace's row index)
    std::uint64_t trace_start = 0;  // the sample a trace link took effect at
    std::vector<RelayEvent> timeline;  // this topic's events in the order they apply
    std::size_t next_event = 0;
    std::optional<Ramp> ramp;
    bool per_writer = false;           // a per-writer topic's model: never samples, not reported
    bool changed_live = false;         // the model: a request changed it (its writers' links to come say so)
    std::vector<std::string> writers;  // a per-writer topic's writers' links
  };
  Link make_link(const std::string& name, const LinkSpec& spec) const;
  void add_event(const RelayEvent& event);
  // `reset_statistics`: false for a ramp's step (its statistics run from the ramp's start).
  void change(Link& link, const LinkSpec& spec, bool reset_statistics);
  void apply_due(const std::string& topic, Link& link);
  void step_ramp(const std::string& topic, Link& link);

  std::map<std::string, Link> links_;
  TraceRows timeline_traces_;  // the traces the timeline switches to, read at start
  std::vector<RelayLinkChange> changes_;
  std::map<std::string, std::vector<RelayEvent>> writer_events_;  // events of writers' links not yet seen
  std::uint64_t seed_;
};

}  // namespace netkf
