#include "netkf/cli/live/relay_summary.hpp"

#include <stdexcept>

namespace netkf::cli {
namespace {

struct TopicQuantity {
  const char* name;
  Measured (*measure)(const RelayTopicSummary&);
};

Measured count_of(std::uint64_t v) {
  Measured m;
  m.value = static_cast<double>(v);
  m.count = true;
  return m;
}

Measured ratio(std::uint64_t part, std::uint64_t whole, const std::string& why_none) {
  Measured m;
  if (whole == 0) m.missing = why_none;
  else m.value = static_cast<double>(part) / static_cast<double>(whole);
  return m;
}

std::string no_sample(const RelayTopicSummary& t) { return t.topic + " relayed no sample"; }

const TopicQuantity kTopicQuantities[] = {
    {"samples", [](const RelayTopicSummary& t) { return count_of(t.lifetime.samples()); }},
    {"delivered", [](const RelayTopicSummary& t) { return count_of(t.lifetime.delivered()); }},
    {"dropped", [](const RelayTopicSummary& t) { return count_of(t.lifetime.dropped()); }},
    {"refused", [](const RelayTopicSummary& t) { return count_of(t.refused); }},
    {"observed_loss",
     [](const RelayTopicSummary& t) { return ratio(t.lifetime.dropped(), t.lifetime.samples(), no_sample(t)); }},
    {"mean_burst",
     [](const RelayTopicSummary& t) {
       Measured m;
       if (t.lifetime.samples() == 0) m.missing = no_sample(t);
       else m.value = t.lifetime.mean_burst_length();
       return m;
     }},
    {"observed_arrival_rate_since_change",
     [](const RelayTopicSummary& t) {
       return ratio(t.since_change.delivered(), t.since_change.samples(),
                    t.topic + " relayed no sample since its link was last set");
     }},
};

const TopicQuantity* topic_quantity(const std::string& name) {
  for (const auto& q : kTopicQuantities)
    if (name == q.name) return &q;
  return nullptr;
}

std::string join(const std::vector<std::string>& parts) {
  std::string out;
  for (const auto& p : parts) out += (out.empty() ? "" : ", ") + p;
  return out;
}

// `link.TOPIC.NAME`: the quantity after the last dot (a topic's name may hold dots, a
// quantity's never does).
bool split_name(const std::string& name, std::string& topic, std::string& quantity) {
  const std::string prefix = "link.";
  const auto dot = name.rfind('.');
  if (name.compare(0, prefix.size(), prefix) != 0 || dot == std::string::npos || dot < prefix.size()) return false;
  topic = name.substr(prefix.size(), dot - prefix.size());
  quantity = name.substr(dot + 1);
  return true;
}

}  // namespace

std::vector<std::string> relay_quantity_names() {
  std::vector<std::string> names;
  for (const auto& q : kTopicQuantities) names.emplace_back(q.name);
  return names;
}

Check parse_relay_check(const std::string& text, const std::vector<std::string>& topics,
                        const std::vector<std::string>& per_writer_topics) {
  Check c = parse_check_syntax(text, "link.rt/chatter.observed_loss<0.35");
  const std::string quoted = "check '" + text + "': ";
  std::string topic, quantity;
  const bool split = split_name(c.name, topic, quantity);
  if (!split || !topic_quantity(quantity))
    throw std::invalid_argument(quoted + "unknown name '" + c.name + "'; a relay's names are link.TOPIC.{" +
                                join(relay_quantity_names()) + "} for the topics " + join(topics));
  for (const auto& t : topics)
    if (t == topic) return c;
  // A writer's link: TOPIC@WRITER of a per-writer topic.
  if (const auto at = topic.rfind('@'); at != std::string::npos)
    for (const auto& t : per_writer_topics)
      if (t == topic.substr(0, at)) return c;
  throw std::invalid_argument(quoted + "topic " + topic + " is not relayed (the relay's topics: " + join(topics) +
                              (per_writer_topics.empty() ? ")" : "; a writer's link of a per-writer topic: TOPIC@WRITER)"));
}

Measured measure_relay(const std::vector<RelayTopicSummary>& topics, const std::string& name) {
  std::string topic, quantity;
  if (split_name(name, topic, quantity))
    if (const auto* q = topic_quantity(quantity))
      for (const auto& t : topics)
        if (t.topic == topic) return q->measure(t);
  if (topic.find('@') != std::string::npos) {
    Measured m;
    m.missing = "no writer made the link " + topic;
    return m;
  }
  throw std::invalid_argument("no quantity named '" + name + "' in the relay's summary");
}

nlohmann::ordered_json relay_summary_json(const std::vector<RelayTopicSummary>& topics,
                                          const std::vector<CheckResult>& results) {
  nlohmann::ordered_json j;
  j["link"] = nlohmann::ordered_json::object();
  for (const auto& t : topics) {
    auto& link = j["link"][t.topic];
    for (const auto& q : kTopicQuantities) link[q.name] = measured_json(q.measure(t));
  }
  j["checks"] = checks_json(results);
  j["passed"] = all_passed(results);
  return j;
}

}  // namespace netkf::cli
