#include "netkf/relay_links.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string_view>

#include "netkf/random.hpp"

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

}  // namespace

int relay_topic_link_id(const std::string& topic) {
  // 2^30 ids below -1000: far from the sensors' (>= 0), control's (-1) and the request id (-2).
  return -1000 - static_cast<int>(name_hash(topic) % (1ull << 30));
}

std::string relay_writer_link_name(const std::string& topic, const std::string& writer) { return topic + "@" + writer; }

RelayLinks::RelayLinks(const std::vector<RelayTopic>& topics, std::uint64_t seed) : seed_(seed) {
  for (const auto& t : topics) {
    if (t.name.empty()) throw std::invalid_argument("a relayed topic needs a name");
    Link link = make_link(t.name, t.link);
    link.per_writer = t.per_writer;
    if (!links_.emplace(t.name, std::move(link)).second)
      throw std::invalid_argument("topic " + t.name + " is relayed twice");
  }
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
  auto& writers = it->second.writers;
  if (std::find(writers.begin(), writers.end(), name) != writers.end()) return name;
  if (links_.contains(name)) throw std::invalid_argument(name + " is a relayed topic's name, not a writer's link");
  links_.emplace(name, make_link(name, it->second.spec));
  writers.push_back(name);
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

std::optional<RelayFate> RelayLinks::on_sample(const std::string& name) {
  const auto it = links_.find(name);
  if (it == links_.end() || it->second.per_writer) return std::nullopt;
  Link& link = it->second;
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

bool RelayLinks::set_link(const std::string& name, const LinkSpec& spec) {
  const auto it = links_.find(name);
  if (it == links_.end()) return false;
  Link& link = it->second;
  // First: throws (and changes nothing) on an invalid model; the writers' links then take it too.
  link.loss.set_model(spec.loss);
  link.spec = spec;
  link.stats = LinkStatistics{};
  link.recent.clear();
  link.trace_start = link.samples;
  for (const auto& writer : link.writers) set_link(writer, spec);
  return true;
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
  return Report{name, link.spec, link.stats, link.lifetime, link.samples, link.last_request_id, link.reject_reason,
                link.recent.fit()};
}

std::vector<RelayLinks::Report> RelayLinks::reports() const {
  std::vector<Report> out;
  for (const auto& [name, link] : links_)
    if (!link.per_writer) out.push_back(*report(name));
  return out;
}

}  // namespace netkf
