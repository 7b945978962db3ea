#include "netkf/relay/relay_links.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string_view>

#include "netkf/links/link_trace.hpp"
#include "netkf/support/random.hpp"

namespace netkf {
namespace {

// FNV-1a 64: a topic's stream index from its name (stable across runs and platforms).
std::uint64_t name_hash(std::string_view name) {
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : name) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

// A journal entry of the link `name` made at its topic's sample `n`.
RelayLinkChange journal_entry(const std::string& name, std::uint64_t n, LinkChange::Origin origin,
                              std::uint64_t request_id, const LinkSpec& link, std::string failure,
                              std::optional<RelayEvent> replay) {
  RelayLinkChange entry;
  entry.sensor_id = relay_topic_link_id(name);
  entry.at_period = static_cast<std::int64_t>(n);
  entry.origin = origin;
  entry.request_id = request_id;
  entry.link = link;
  entry.topic = name;
  entry.failure = std::move(failure);
  entry.replay = std::move(replay);
  return entry;
}

}  // namespace

int relay_topic_link_id(const std::string& topic) {
  // 2^30 ids below -1000: far from the sensors' (>= 0) and control's (-1).
  return -1000 - static_cast<int>(name_hash(topic) % (1ull << 30));
}

std::string relay_writer_link_name(const std::string& topic, const std::string& writer) { return topic + "@" + writer; }

RelayLinks::RelayLinks(const std::vector<RelayTopic>& topics, std::uint64_t seed,
                       const std::vector<RelayEvent>& timeline)
    : seed_(seed) {
  for (const auto& t : topics) {
    if (t.name.empty()) throw std::invalid_argument("a relayed topic needs a name");
    Link link = make_link(t.name, t.link);
    link.per_writer = t.per_writer;
    if (!links_.emplace(t.name, std::move(link)).second)
      throw std::invalid_argument("topic " + t.name + " is relayed twice");
  }
  std::vector<const RelayEvent*> ordered;
  for (const auto& e : timeline) ordered.push_back(&e);
  std::stable_sort(ordered.begin(), ordered.end(),
                   [](const RelayEvent* a, const RelayEvent* b) { return a->at_sample < b->at_sample; });
  for (const RelayEvent* e : ordered) add_event(*e);
}

// A topic's event, or one of a writer's link of a per-writer topic (kept until the writer comes);
// the traces it names are read now.
void RelayLinks::add_event(const RelayEvent& e) {
  if (const auto it = links_.find(e.topic); it != links_.end()) {
    it->second.timeline.push_back(e);
  } else if (const auto at = e.topic.rfind('@'); at != std::string::npos && per_writer(e.topic.substr(0, at))) {
    writer_events_[e.topic].push_back(e);
  } else {
    throw std::invalid_argument("an event of topic " + e.topic + ", which is not relayed");
  }
  read_event_traces(e.keys, timeline_traces_);
}

// A link's streams come from its name only: a topic's and a writer's alike.
RelayLinks::Link RelayLinks::make_link(const std::string& name, const LinkSpec& spec) const {
  const auto index = name_hash(name);
  return Link{spec, LinkLossProcess(spec.loss, derive_seed(seed_, "relay-link", index)),
              LinkDelayProcess(derive_seed(seed_, "relay-link-delay", index))};
}

std::optional<std::string> RelayLinks::add_writer_link(const std::string& topic, const std::string& writer) {
  const auto it = links_.find(topic);
  if (it == links_.end() || !it->second.per_writer) return std::nullopt;
  if (writer.empty()) throw std::invalid_argument("a writer's link of " + topic + " needs the writer's name");
  const std::string name = relay_writer_link_name(topic, writer);
  const Link& model = it->second;
  if (std::find(model.writers.begin(), model.writers.end(), name) != model.writers.end()) return name;
  if (links_.contains(name)) throw std::invalid_argument(name + " is a relayed topic's name, not a writer's link");
  Link link = make_link(name, model.spec);
  // The topic's timeline, each event at this writer's own sample, then this writer's own events
  // (a replayed journal's), in the order they apply.
  link.timeline = model.timeline;
  for (auto& e : link.timeline) e.topic = name;
  if (const auto own = writer_events_.find(name); own != writer_events_.end()) {
    link.timeline.insert(link.timeline.end(), own->second.begin(), own->second.end());
    writer_events_.erase(own);
  }
  std::stable_sort(link.timeline.begin(), link.timeline.end(),
                   [](const RelayEvent& a, const RelayEvent& b) { return a.at_sample < b.at_sample; });
  // Its first link is not the file's: the journal says so, at its sample 0.
  if (model.changed_live)
    changes_.push_back(journal_entry(name, 0, LinkChange::Origin::request, 0, model.spec, {},
                                     RelayEvent{0, name, LinkEvent::Kind::set, link_keys(model.spec), 0}));
  links_.emplace(name, std::move(link));
  it->second.writers.push_back(name);
  return name;
}

bool RelayLinks::per_writer(const std::string& topic) const {
  const auto it = links_.find(topic);
  return it != links_.end() && it->second.per_writer;
}

std::vector<std::string> RelayLinks::writer_links(const std::string& topic) const {
  const auto it = links_.find(topic);
  return it == links_.end() ? std::vector<std::string>{} : it->second.writers;
}

void RelayLinks::change(Link& link, const LinkSpec& spec, bool reset_statistics) {
  link.loss.set_model(spec.loss);  // keeps the stream's (and a Gilbert-Elliott chain's) state
  link.spec = spec;
  if (!reset_statistics) return;
  link.stats = LinkStatistics{};
  link.recent.clear();
  link.trace_start = link.samples;
}

// The timeline's events due at the topic's next sample, as a scenario's timeline applies at a
// period (nodes/channel_links.cpp): a set ends a running ramp; a ramp starts from the values
// the link has now.
void RelayLinks::apply_due(const std::string& topic, Link& link) {
  const std::uint64_t n = link.samples;
  while (link.next_event < link.timeline.size() && link.timeline[link.next_event].at_sample <= n) {
    const RelayEvent& e = link.timeline[link.next_event++];
    RelayLinkChange entry = journal_entry(topic, n, LinkChange::Origin::timeline, 0, link.spec, {}, std::nullopt);
    try {
      if (e.kind == LinkEvent::Kind::set || e.ramp_samples == 0) {
        entry.link = apply_link_keys(link.spec, e.keys, &timeline_traces_);
        change(link, entry.link, true);
        link.ramp.reset();
        entry.replay = RelayEvent{n, topic, LinkEvent::Kind::set, link_keys(entry.link), 0};
      } else {
        Ramp ramp{n, e.ramp_samples, {}, e.keys};
        for (const auto& key : e.keys) ramp.from.emplace_back(key.name, link_key_value(link.spec, key.name));
        (void)apply_link_keys(link.spec, e.keys);  // the target must be a valid link now
        link.ramp = std::move(ramp);
        entry.replay = RelayEvent{n, topic, LinkEvent::Kind::ramp, e.keys, e.ramp_samples};
      }
    } catch (const LinkError& err) {
      // Only a live change can make a checked timeline inapplicable (e.g. another model).
      entry.failure = err.what();
    }
    changes_.push_back(std::move(entry));
  }
}

void RelayLinks::step_ramp(const std::string& topic, Link& link) {
  if (!link.ramp) return;
  const Ramp& ramp = *link.ramp;
  const std::uint64_t n = link.samples;
  const double fraction = std::min(1.0, static_cast<double>(n - ramp.start) / static_cast<double>(ramp.samples));
  LinkKeys keys;
  for (std::size_t i = 0; i < ramp.to.size(); ++i) {
    const double from = ramp.from[i].second;
    const double to = std::get<double>(ramp.to[i].value);
    keys.push_back({ramp.to[i].name, fraction >= 1.0 ? to : from + (to - from) * fraction});
  }
  try {
    change(link, apply_link_keys(link.spec, keys), false);
  } catch (const LinkError& err) {
    changes_.push_back(journal_entry(topic, n, LinkChange::Origin::timeline, 0, link.spec, err.what(), std::nullopt));
    link.ramp.reset();
    return;
  }
  if (fraction >= 1.0) {
    changes_.push_back(journal_entry(topic, n, LinkChange::Origin::timeline, 0, link.spec, {}, std::nullopt));  // the ramp's end
    link.ramp.reset();
  }
}

std::optional<RelayFate> RelayLinks::on_sample(const std::string& name) {
  const auto it = links_.find(name);
  if (it == links_.end() || it->second.per_writer) return std::nullopt;
  Link& link = it->second;
  apply_due(name, link);
  step_ramp(name, link);
  RelayFate fate;
  fate.index = link.samples++;
  double delay_ms = std::nan("");
  if (link.spec.trace) {
    const auto row = trace_sample(*link.spec.trace, fate.index - link.trace_start);
    fate.delivered = row.delivered;
    delay_ms = row.delay_ms;  // NaN: the trace has no delay column, the link's delay applies
  } else {
    fate.delivered = !link.loss.next_dropped();
  }
  link.stats.record(!fate.delivered);
  link.lifetime.record(!fate.delivered);
  link.recent.record(!fate.delivered);
  if (fate.delivered) fate.delay_ms = std::isnan(delay_ms) ? link.delay.next_delay_ms(link.spec.delay) : delay_ms;
  return fate;
}

bool RelayLinks::set_link(const std::string& name, const LinkSpec& spec, std::uint64_t request_id) {
  const auto it = links_.find(name);
  if (it == links_.end()) return false;
  Link& link = it->second;
  change(link, spec, true);  // set_model throws (and changes nothing) on an invalid model
  link.ramp.reset();         // the operator's word ends a ramp in progress
  if (link.per_writer) {
    // The model of the writers' links to come (each journals it when made), and each writer's.
    link.changed_live = true;
    for (const auto& writer : link.writers) set_link(writer, spec, request_id);
    return true;
  }
  const std::uint64_t n = link.samples;
  changes_.push_back(journal_entry(name, n, LinkChange::Origin::request, request_id, spec, {},
                                   RelayEvent{n, name, LinkEvent::Kind::set, link_keys(spec), 0}));
  return true;
}

std::vector<RelayLinkChange> RelayLinks::take_changes() {
  std::vector<RelayLinkChange> out;
  out.swap(changes_);
  return out;
}

void RelayLinks::note_request(const std::string& name, std::uint64_t request_id, const std::string& reject_reason) {
  const auto it = links_.find(name);
  if (it == links_.end()) return;
  it->second.last_request_id = request_id;
  it->second.reject_reason = reject_reason;
  for (const auto& writer : it->second.writers) note_request(writer, request_id, reject_reason);
}

std::optional<LinkSpec> RelayLinks::link(const std::string& name) const {
  const auto it = links_.find(name);
  if (it == links_.end()) return std::nullopt;
  return it->second.spec;
}

std::optional<RelayLinks::Report> RelayLinks::report(const std::string& name) const {
  const auto it = links_.find(name);
  if (it == links_.end() || it->second.per_writer) return std::nullopt;
  const Link& link = it->second;
  Report r;
  r.sensor_id = relay_topic_link_id(name);
  r.topic = name;
  r.link = link.spec;
  r.count(link.stats, link.lifetime);
  r.last_request_id = link.last_request_id;
  r.rejection_reason = link.reject_reason;
  r.recent_fit = link.recent.fit();
  r.next_sample = link.samples;
  return r;
}

std::optional<RelayLinks::Statistics> RelayLinks::statistics(const std::string& name) const {
  const auto it = links_.find(name);
  if (it == links_.end() || it->second.per_writer) return std::nullopt;
  return Statistics{it->second.stats, it->second.lifetime};
}

std::vector<RelayLinks::Report> RelayLinks::reports() const {
  std::vector<Report> out;
  for (const auto& [name, link] : links_)
    if (!link.per_writer) out.push_back(*report(name));
  return out;
}

}  // namespace netkf
