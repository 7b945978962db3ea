#include "netkf/relay_links.hpp"

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

RelayLinks::RelayLinks(const std::vector<RelayTopic>& topics, std::uint64_t seed) {
  for (const auto& t : topics) {
    if (t.name.empty()) throw std::invalid_argument("a relayed topic needs a name");
    const auto index = name_hash(t.name);
    Link link{t.link, LinkLossProcess(t.link.loss, derive_seed(seed, "relay-link", index)),
              LinkDelayProcess(derive_seed(seed, "relay-link-delay", index))};
    if (!links_.emplace(t.name, std::move(link)).second)
      throw std::invalid_argument("topic " + t.name + " is relayed twice");
  }
}

std::optional<RelayFate> RelayLinks::on_sample(const std::string& topic) {
  const auto it = links_.find(topic);
  if (it == links_.end()) return std::nullopt;
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

bool RelayLinks::set_link(const std::string& topic, const LinkSpec& spec) {
  const auto it = links_.find(topic);
  if (it == links_.end()) return false;
  Link& link = it->second;
  link.loss.set_model(spec.loss);  // throws (and changes nothing) on an invalid model
  link.spec = spec;
  link.stats = LinkStatistics{};
  link.recent.clear();
  link.trace_start = link.samples;
  return true;
}

void RelayLinks::note_request(const std::string& topic, std::uint64_t request_id, const std::string& reject_reason) {
  const auto it = links_.find(topic);
  if (it == links_.end()) return;
  it->second.last_request_id = request_id;
  it->second.reject_reason = reject_reason;
}

std::optional<LinkSpec> RelayLinks::link(const std::string& topic) const {
  const auto it = links_.find(topic);
  if (it == links_.end()) return std::nullopt;
  return it->second.spec;
}

std::optional<RelayLinks::Report> RelayLinks::report(const std::string& topic) const {
  const auto it = links_.find(topic);
  if (it == links_.end()) return std::nullopt;
  const Link& link = it->second;
  return Report{topic, link.spec, link.stats, link.lifetime, link.samples, link.last_request_id, link.reject_reason,
                link.recent.fit()};
}

std::vector<RelayLinks::Report> RelayLinks::reports() const {
  std::vector<Report> out;
  for (const auto& [name, link] : links_) out.push_back(*report(name));
  return out;
}

}  // namespace netkf
