// A link's keys as a person writes them (netkf/links/link_keys.hpp): parsing, applying to a
// link, the keys of a link, and the trace files a trace link's keys name.
#include "netkf/links/link_keys.hpp"

#include "link_detail.hpp"
#include "netkf/links/link_delay.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_text.hpp"
#include "netkf/links/link_trace.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <variant>

namespace netkf {
namespace {

using link_detail::check_probability;
using link_detail::number_text;

// The simple Gilbert channel (loss_good 0, loss_bad 1) with stationary loss `loss` and mean
// burst `mean_burst`: a burst is a sojourn in Bad, geometric with mean 1/r, and
// π_bad = p/(p + r) = loss gives p = r·loss/(1 − loss).
GilbertElliottLink gilbert_from_loss_and_burst(double loss, double mean_burst) {
  check_probability("loss", loss);
  if (loss >= 1.0)
    throw LinkError("loss", "loss must be below 1 for a gilbert_elliott link given by loss and mean_burst "
                            "(a link that drops everything is bernoulli loss 1)");
  if (!(mean_burst >= 1.0) || !std::isfinite(mean_burst))
    throw LinkError("mean_burst", "mean_burst must be a finite number >= 1 (a burst is one or more drops), got " +
                                      number_text(mean_burst));
  const double r = 1.0 / mean_burst;
  double p = r * loss / (1.0 - loss);
  // At the limit loss = B/(B+1) the formula gives p = 1 up to rounding (1 + 2^-52 for B = 4):
  // a valid chain, not a refusal.
  if (p > 1.0 && p <= 1.0 + 1e-12) p = 1.0;
  if (p > 1.0) {
    throw LinkError("loss", "loss " + number_text(loss) + " with mean_burst " + number_text(mean_burst) +
                                " needs p = " + number_text(p) + " > 1: a mean burst of " + number_text(mean_burst) +
                                " allows a loss of at most " + number_text(mean_burst / (mean_burst + 1.0)));
  }
  return GilbertElliottLink{p, r, 0.0, 1.0};
}

using KeyValue = std::variant<double, std::string>;

std::string expected_keys() {
  std::string out;
  for (const auto& n : link_key_names()) out += (out.empty() ? "" : ", ") + n;
  return out;
}

std::string word_choices(const std::string& key) {
  if (key == "model") return link_model_choices();
  if (key == "trace") return "a trace file";
  if (key == "loop") return "true or false";
  return "uniform, normal, pareto or paretonormal";
}

// The keys of one change, checked for names, duplicates and types.
class KeyMap {
 public:
  explicit KeyMap(const LinkKeys& keys) {
    const auto& names = link_key_names();
    for (const auto& key : keys) {
      if (std::find(names.begin(), names.end(), key.name) == names.end())
        throw LinkError(key.name, "unknown link key '" + key.name + "' (expected one of: " + expected_keys() + ")");
      if (!values_.emplace(key.name, key.value).second)
        throw LinkError(key.name, "link key '" + key.name + "' given twice");
      const bool is_word = std::holds_alternative<std::string>(key.value);
      if (link_key_is_word(key.name) && !is_word)
        throw LinkError(key.name, key.name + " must be a name (" +
                                      word_choices(key.name) + ")");
      if (!link_key_is_word(key.name)) {
        if (is_word)
          throw LinkError(key.name, key.name + " must be a number, got '" + std::get<std::string>(key.value) + "'");
        if (!std::isfinite(std::get<double>(key.value)))
          throw LinkError(key.name, key.name + " must be a finite number, got " + number_text(std::get<double>(key.value)));
      }
    }
  }
  bool has(const std::string& name) const { return values_.count(name) != 0; }
  double number(const std::string& name) const { return std::get<double>(values_.at(name)); }
  const std::string& word(const std::string& name) const { return std::get<std::string>(values_.at(name)); }

 private:
  std::map<std::string, KeyValue> values_;
};

// Bernoulli's keys applied to `now` (rebuild: to no link, so loss must be given).
LinkModel apply_bernoulli_keys(const BernoulliLink& now, const KeyMap& keys, bool rebuild) {
  for (const char* k : {"p", "r", "loss_good", "loss_bad", "mean_burst"})
    if (keys.has(k))
      throw LinkError(k, std::string(k) + " is a gilbert_elliott key; a bernoulli link has only loss" +
                             (rebuild ? "" : " (give model: gilbert_elliott to change the model)"));
  BernoulliLink b;
  if (!rebuild) b = now;
  if (keys.has("loss")) {
    b.loss = keys.number("loss");
  } else if (rebuild) {
    throw LinkError("loss", "a bernoulli link needs loss");
  }
  return b;
}

// Gilbert-Elliott's keys, the chain's (p, r, loss_good, loss_bad) or the user's form (loss,
// mean_burst), applied to `now` (null when rebuilt).
LinkModel apply_gilbert_elliott_keys(const GilbertElliottLink* now, const KeyMap& keys) {
  const bool user_form = keys.has("loss") || keys.has("mean_burst");
  for (const char* k : {"p", "r", "loss_good", "loss_bad"}) {
    if (user_form && keys.has(k))
      throw LinkError(k, "a gilbert_elliott link is given by p, r, loss_good, loss_bad or by loss and mean_burst, "
                         "not both (" + std::string(k) + " given with " + (keys.has("loss") ? "loss" : "mean_burst") + ")");
  }
  if (user_form) {
    if (!now && !(keys.has("loss") && keys.has("mean_burst")))
      throw LinkError(keys.has("loss") ? "mean_burst" : "loss",
                      "a gilbert_elliott link given by its loss needs both loss and mean_burst");
    const double loss = keys.has("loss") ? keys.number("loss") : stationary_loss(*now);
    const double burst = keys.has("mean_burst") ? keys.number("mean_burst") : mean_burst_length(*now);
    return gilbert_from_loss_and_burst(loss, burst);
  }
  GilbertElliottLink g;  // loss_good = 0, loss_bad = 1 by default: the simple Gilbert channel
  if (now) {
    g = *now;
  } else if (!keys.has("p") || !keys.has("r")) {
    throw LinkError(keys.has("p") ? "r" : "p", "a gilbert_elliott link needs p and r (or loss and mean_burst)");
  }
  if (keys.has("p")) g.p = keys.number("p");
  if (keys.has("r")) g.r = keys.number("r");
  if (keys.has("loss_good")) g.loss_good = keys.number("loss_good");
  if (keys.has("loss_bad")) g.loss_bad = keys.number("loss_bad");
  return g;
}

// The model named by the keys' model (rebuild) or the current one, with the keys applied.
LinkModel apply_loss_keys(const LinkModel& current, const KeyMap& keys) {
  const bool rebuild = keys.has("model");
  // Rebuilt: the named model's alternative only (its parameters are not used).
  const std::optional<LinkModel> model =
      rebuild ? link_model_named(keys.word("model")) : std::optional<LinkModel>(current);
  if (!model)
    throw LinkError("model",
                    "unknown link model '" + keys.word("model") + "' (expected " + word_choices("model") + ")");
  return std::visit(overloaded{[&](const BernoulliLink& b) { return apply_bernoulli_keys(b, keys, rebuild); },
                               [&](const GilbertElliottLink& g) {
                                 return apply_gilbert_elliott_keys(rebuild ? nullptr : &g, keys);
                               }},
                    *model);
}

// The loss model's keys, which a trace link refuses: its trace gives the drops.
constexpr const char* kLossKeys[] = {"loss", "p", "r", "loss_good", "loss_bad", "mean_burst"};
constexpr const char* kTraceKeys[] = {"trace", "loop", "offset"};

std::shared_ptr<const LinkTrace> trace_rows(const std::string& path, const LinkSpec& current, const TraceRows* preloaded) {
  if (current.trace && current.trace->path == path && current.trace->rows) return current.trace->rows;
  if (preloaded) {
    if (const auto it = preloaded->find(path); it != preloaded->end() && it->second) return it->second;
  }
  return read_link_trace_for(path);
}

TraceLink apply_trace_keys(const LinkSpec& current, const KeyMap& keys, bool rebuild, const TraceRows* preloaded) {
  for (const char* k : kLossKeys)
    if (keys.has(k))
      throw LinkError(k, std::string(k) + " is not a key of a trace link (its trace gives the drops; give model: "
                                          "bernoulli or gilbert_elliott to leave the trace)");
  TraceLink t;
  if (!rebuild && current.trace) t = *current.trace;
  if (keys.has("trace")) {
    t.path = keys.word("trace");
    t.rows = nullptr;
    if (t.path.empty()) throw LinkError("trace", "trace must name a trace file, got an empty name");
  } else if (rebuild) {
    throw LinkError("trace", "a trace link needs trace (a trace file: k,delivered[,delay_ms])");
  }
  // A trace link known only by its description (the wire's: path, no rows) stays so when only
  // its loop, offset or delay change: the channel, which has the rows, checks them.
  const bool described_only = !rebuild && !keys.has("trace") && !t.rows;
  if (!t.rows && !described_only) t.rows = trace_rows(t.path, current, preloaded);
  if (keys.has("loop")) {
    const std::string& w = keys.word("loop");
    if (w != "true" && w != "false") throw LinkError("loop", "loop must be true or false, got '" + w + "'");
    t.loop = w == "true";
  }
  if (keys.has("offset")) {
    const double o = keys.number("offset");
    if (!(o >= 0.0) || o != std::floor(o))
      throw LinkError("offset", "offset must be a whole number of rows >= 0, got " + number_text(o));
    if (t.rows && o >= static_cast<double>(t.rows->size()))
      throw LinkError("offset", "offset " + number_text(o) + " is past the trace's last row (" + t.path + " has " +
                                    std::to_string(t.rows->size()) + " rows)");
    t.offset = static_cast<std::uint64_t>(o);
  }
  if (described_only) return t;
  if (t.offset >= t.rows->size())
    throw LinkError("offset", "offset " + std::to_string(t.offset) + " is past the trace's last row (" + t.path +
                                  " has " + std::to_string(t.rows->size()) + " rows)");
  return t;
}

}  // namespace


const std::vector<std::string>& link_key_names() {
  static const std::vector<std::string> names = {"model",     "loss",     "p",         "r",
                                                 "loss_good", "loss_bad", "mean_burst", "trace",
                                                 "loop",      "offset",   "delay_ms",  "jitter_ms",
                                                 "delay_distribution"};
  return names;
}

bool link_key_is_word(const std::string& name) {
  return name == "model" || name == "delay_distribution" || name == "trace" || name == "loop";
}

LinkSpec apply_link_keys(const LinkSpec& current, const LinkKeys& keys, const TraceRows* preloaded) {
  const KeyMap map(keys);
  const bool rebuild = map.has("model");
  const bool to_trace = rebuild ? map.word("model") == "trace" : current.trace.has_value();
  LinkSpec out;
  out.delay = current.delay;
  if (map.has("delay_ms")) out.delay.delay_ms = map.number("delay_ms");
  if (map.has("jitter_ms")) out.delay.jitter_ms = map.number("jitter_ms");
  if (map.has("delay_distribution")) out.delay.distribution = parse_delay_distribution(map.word("delay_distribution"));
  if (to_trace) {
    out.trace = apply_trace_keys(current, map, rebuild, preloaded);
    out.loss = out.trace->rows ? empirical_link_model(*out.trace->rows) : current.loss;
    if (out.trace->rows && out.trace->rows->has_delay) {
      // The trace's delay column gives every delivered sample's delay: a drawn delay too would be two delays.
      for (const char* k : {"delay_ms", "jitter_ms"})
        if (map.has(k) && map.number(k) != 0.0)
          throw LinkError(k, std::string(k) + " cannot be given for a trace with a delay_ms column (" +
                                 out.trace->path + " gives each sample's delay)");
      out.delay = LinkDelay{};
    }
  } else {
    for (const char* k : kTraceKeys)
      if (map.has(k))
        throw LinkError(k, std::string(k) + " is a key of a trace link (give model: trace)");
    // Leaving a trace: its loss field is the trace's empirical model, not a model to edit.
    out.loss = apply_loss_keys(current.trace ? LinkModel{BernoulliLink{}} : current.loss, map);
  }
  validate_link(out);
  return out;
}

LinkSpec link_from_keys(const LinkKeys& keys) {
  const bool has_model =
      std::any_of(keys.begin(), keys.end(), [](const LinkKey& k) { return k.name == "model"; });
  if (!has_model) throw LinkError("model", "a link needs model (" + link_model_choices() + ")");
  return apply_link_keys(LinkSpec{}, keys);
}

LinkKeys link_keys(const LinkSpec& link) {
  LinkKeys keys{{"model", link_kind(link)}};
  if (link.trace) {
    keys.push_back({"trace", link.trace->path});
    keys.push_back({"loop", std::string(link.trace->loop ? "true" : "false")});
    keys.push_back({"offset", static_cast<double>(link.trace->offset)});
  } else {
    for (const auto& [name, value] : link_parameters(link.loss)) keys.push_back({name, value});
  }
  keys.push_back({"delay_ms", link.delay.delay_ms});
  keys.push_back({"jitter_ms", link.delay.jitter_ms});
  keys.push_back({"delay_distribution", delay_distribution_name(link.delay.distribution)});
  return keys;
}

double link_key_value(const LinkSpec& link, const std::string& name) {
  if (name == "delay_ms") return link.delay.delay_ms;
  if (name == "jitter_ms") return link.delay.jitter_ms;
  if (name == "loss") return stationary_loss(link.loss);
  if (link.trace && name == "offset") return static_cast<double>(link.trace->offset);
  if (!link.trace) {
    for (const auto& [key, value] : link_parameters(link.loss))
      if (key == name) return value;
    // A model not given by its loss also reads in the user's form (loss above, mean_burst).
    if (name == "mean_burst" && !link_parameters_include_loss(link.loss)) return mean_burst_length(link.loss);
  }
  if (link_key_is_word(name)) throw LinkError(name, name + " is a name, not a number");
  throw LinkError(name, "link key '" + name + "' does not apply to a " + link_kind(link) + " link");
}

std::shared_ptr<const LinkTrace> read_link_trace_for(const std::string& path) {
  try {
    return std::make_shared<const LinkTrace>(read_link_trace_file(path));
  } catch (const TraceError& e) {
    throw LinkError("trace", std::string("trace ") + e.what());
  }
}

void read_event_traces(const LinkKeys& keys, TraceRows& traces) {
  for (const auto& key : keys) {
    const auto* path = std::get_if<std::string>(&key.value);
    if (key.name != "trace" || path == nullptr || traces.contains(*path)) continue;
    try {
      traces.emplace(*path, read_link_trace_for(*path));
    } catch (const LinkError&) {
      // Gone since the loader read it: the event fails when due.
    }
  }
}

}  // namespace netkf
