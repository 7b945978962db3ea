// The link type (netkf/link.hpp): keys, validation, description, stationary statistics,
// delay distributions and the effective loss model the theory uses.
#include "netkf/link.hpp"

#include "netkf/link_trace.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <string>
#include <variant>

namespace netkf {
namespace {

// A delay above a minute is a typo in a tool whose periods are milliseconds.
constexpr double kMaxDelayMs = 60000.0;
// netem's distribution tables hold Z · 8192 as 16-bit integers: |Z| <= 32767/8192 ≈ 4.
constexpr double kNetemTableLimit = 32767.0 / 8192.0;

std::string number_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

void check_probability(const char* name, double value) {
  // Written as a negated range test so that NaN is rejected too.
  if (!(value >= 0.0 && value <= 1.0))
    throw LinkError(name, std::string(name) + " must be a probability in [0, 1], got " + number_text(value));
}

// Stationary distribution of the Gilbert-Elliott chain: (pi_good, pi_bad) =
// (r, p) / (p + r). With p + r = 0 the chain never leaves its initial state, Good.
struct GoodBad {
  double good;
  double bad;
};
GoodBad stationary_distribution(const GilbertElliottLink& g) {
  const double total = g.p + g.r;
  if (total <= 0.0) return {1.0, 0.0};
  return {g.r / total, g.p / total};
}

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
  if (key == "model") return "bernoulli, gilbert_elliott or trace";
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

LinkModel apply_loss_keys(const LinkModel& current, const KeyMap& keys) {
  const bool rebuild = keys.has("model");
  const std::string model = rebuild ? keys.word("model") : link_model_name(current);
  if (model == "bernoulli") {
    for (const char* k : {"p", "r", "loss_good", "loss_bad", "mean_burst"})
      if (keys.has(k))
        throw LinkError(k, std::string(k) + " is a gilbert_elliott key; a bernoulli link has only loss" +
                               (rebuild ? "" : " (give model: gilbert_elliott to change the model)"));
    BernoulliLink b;
    if (!rebuild) b = std::get<BernoulliLink>(current);
    if (keys.has("loss")) {
      b.loss = keys.number("loss");
    } else if (rebuild) {
      throw LinkError("loss", "a bernoulli link needs loss");
    }
    return b;
  }
  if (model != "gilbert_elliott")
    throw LinkError("model", "unknown link model '" + model + "' (expected bernoulli, gilbert_elliott or trace)");

  const GilbertElliottLink* now = rebuild ? nullptr : std::get_if<GilbertElliottLink>(&current);
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

// Φ, the standard normal CDF.
double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

// Φ⁻¹ by Acklam's rational approximation (relative error 1.15e-9), refined by one Halley
// step on erfc, which brings it to double precision.
double normal_quantile(double q) {
  if (q <= 0.0) return -std::numeric_limits<double>::infinity();
  if (q >= 1.0) return std::numeric_limits<double>::infinity();
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                                 1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                 6.680131188771972e+01,  -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                 -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                 3.754408661907416e+00};
  constexpr double low = 0.02425;
  double x;
  if (q < low) {
    const double t = std::sqrt(-2.0 * std::log(q));
    x = (((((c[0] * t + c[1]) * t + c[2]) * t + c[3]) * t + c[4]) * t + c[5]) /
        ((((d[0] * t + d[1]) * t + d[2]) * t + d[3]) * t + 1.0);
  } else if (q <= 1.0 - low) {
    const double s = q - 0.5;
    const double t = s * s;
    x = (((((a[0] * t + a[1]) * t + a[2]) * t + a[3]) * t + a[4]) * t + a[5]) * s /
        (((((b[0] * t + b[1]) * t + b[2]) * t + b[3]) * t + b[4]) * t + 1.0);
  } else {
    const double t = std::sqrt(-2.0 * std::log(1.0 - q));
    x = -(((((c[0] * t + c[1]) * t + c[2]) * t + c[3]) * t + c[4]) * t + c[5]) /
        ((((d[0] * t + d[1]) * t + d[2]) * t + d[3]) * t + 1.0);
  }
  const double e = normal_cdf(x) - q;
  const double u = e * std::sqrt(2.0 * M_PI) * std::exp(x * x / 2.0);
  return x - u / (1.0 + x * u / 2.0);
}

// netem's Pareto table: Z(q) = (4/3)((1 − q)^(−1/3) − 3/2), the quantile of a Pareto of
// shape 3 and scale 1 (mean 3/2), centred and scaled by 4/3 (iproute2, netem/pareto.c).
double pareto_standard_quantile(double q) { return (4.0 / 3.0) * (std::pow(1.0 - q, -1.0 / 3.0) - 1.5); }

// The standard quantile Z(q) of each distribution (delay = delay_ms + jitter_ms · Z),
// limited to the range of netem's tables where netem's meaning is the definition.
double standard_quantile(DelayDistribution d, double q) {
  switch (d) {
    case DelayDistribution::uniform: return 2.0 * q - 1.0;
    case DelayDistribution::normal: return normal_quantile(q);
    case DelayDistribution::pareto: return std::min(pareto_standard_quantile(q), kNetemTableLimit);
    case DelayDistribution::paretonormal:
      // netem/paretonormal.c: (normal + 3·pareto)/4 of the same table index, i.e. quantile.
      // The Pareto part is capped at the table's limit before mixing, as netem's generator does.
      return std::clamp(0.25 * normal_quantile(q) + 0.75 * std::min(pareto_standard_quantile(q), kNetemTableLimit),
                        -kNetemTableLimit, kNetemTableLimit);
  }
  return 0.0;
}

// P(Z <= z) for the standard quantiles above.
double standard_cdf(DelayDistribution d, double z) {
  switch (d) {
    case DelayDistribution::uniform: return std::clamp((z + 1.0) / 2.0, 0.0, 1.0);
    case DelayDistribution::normal: return normal_cdf(z);
    case DelayDistribution::pareto: {
      if (z >= kNetemTableLimit) return 1.0;
      const double base = 1.5 + 0.75 * z;  // (1 − q)^(−1/3) at Z = z
      return base <= 1.0 ? 0.0 : 1.0 - std::pow(base, -3.0);
    }
    case DelayDistribution::paretonormal: {
      // No closed form: Z(q) increases with q, so bisect for the largest q with Z(q) <= z.
      if (z >= kNetemTableLimit) return 1.0;
      if (z < -kNetemTableLimit) return 0.0;
      double lo = 0.0, hi = 1.0;
      for (int i = 0; i < 80; ++i) {
        const double mid = 0.5 * (lo + hi);
        (standard_quantile(d, mid) <= z ? lo : hi) = mid;
      }
      return lo;
    }
  }
  return 0.0;
}

}  // namespace

std::string link_error_at(const std::string& path, const LinkError& error) {
  const std::string what = error.what();
  if (!error.key().empty() && what.rfind(error.key() + " ", 0) == 0) return path + "." + what;
  return path + ": " + what;
}

// ---- keys -------------------------------------------------------------------------

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
  if (!has_model) throw LinkError("model", "a link needs model (bernoulli, gilbert_elliott or trace)");
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
  const auto* g = link.trace ? nullptr : std::get_if<GilbertElliottLink>(&link.loss);
  if (g) {
    if (name == "p") return g->p;
    if (name == "r") return g->r;
    if (name == "loss_good") return g->loss_good;
    if (name == "loss_bad") return g->loss_bad;
    if (name == "mean_burst") return mean_burst_length(*g);
  }
  if (link_key_is_word(name)) throw LinkError(name, name + " is a name, not a number");
  throw LinkError(name, "link key '" + name + "' does not apply to a " + link_kind(link) + " link");
}

// ---- validation -------------------------------------------------------------------

void validate_link_model(const LinkModel& model) {
  if (const auto* b = std::get_if<BernoulliLink>(&model)) {
    check_probability("loss", b->loss);
    return;
  }
  const auto& g = std::get<GilbertElliottLink>(model);
  check_probability("p", g.p);
  check_probability("r", g.r);
  check_probability("loss_good", g.loss_good);
  check_probability("loss_bad", g.loss_bad);
  // p = r = 0 leaves the chain's stationary distribution undefined (it would stay wherever it is).
  if (g.p + g.r <= 0.0) throw LinkError("p", "p and r cannot both be 0 (the chain would never move)");
}

void validate_link(const LinkSpec& link) {
  validate_link_model(link.loss);
  if (link.trace && link.trace->rows && link.trace->offset >= link.trace->rows->size())
    throw LinkError("offset", "offset " + std::to_string(link.trace->offset) + " is past the trace's last row");
  for (const auto& [name, value] : {std::pair{"delay_ms", link.delay.delay_ms}, {"jitter_ms", link.delay.jitter_ms}}) {
    if (!(value >= 0.0 && value <= kMaxDelayMs))
      throw LinkError(name, std::string(name) + " must be in [0, " + number_text(kMaxDelayMs) + "] ms, got " +
                                number_text(value));
  }
}

// ---- statistics and names -----------------------------------------------------------

double stationary_loss(const LinkModel& model) {
  if (const auto* b = std::get_if<BernoulliLink>(&model)) return b->loss;
  const auto& g = std::get<GilbertElliottLink>(model);
  const GoodBad pi = stationary_distribution(g);
  // (r·loss_good + p·loss_bad)/(p + r)   (docs/scenario-format.md, "Gilbert-Elliott")
  return pi.good * g.loss_good + pi.bad * g.loss_bad;
}

double mean_burst_length(const LinkModel& model) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  if (const auto* b = std::get_if<BernoulliLink>(&model)) {
    // Burst lengths are geometric: P(length = k) = loss^(k-1) (1 - loss).
    return b->loss >= 1.0 ? kInfinity : 1.0 / (1.0 - b->loss);
  }
  const auto& g = std::get<GilbertElliottLink>(model);
  // The simple Gilbert channel: a burst is a sojourn in Bad, geometric with mean 1/r. The
  // general ratio below gives the same for p > 0; at p = 0 (loss 0) it has no drops to
  // measure, but a link given as { loss: 0, mean_burst: 5 } must keep its 5.
  if (g.loss_good == 0.0 && g.loss_bad == 1.0) return g.r > 0.0 ? 1.0 / g.r : kInfinity;
  const GoodBad pi = stationary_distribution(g);
  // Bursts per sample = P(sample t delivered, sample t+1 dropped); drops per sample
  // = P(drop). Their ratio is the mean run length of consecutive drops. Per sample
  // the chain first moves, then the sample is dropped with the new state's loss.
  const double drop_after_good = (1.0 - g.p) * g.loss_good + g.p * g.loss_bad;
  const double drop_after_bad = g.r * g.loss_good + (1.0 - g.r) * g.loss_bad;
  const double burst_starts =
      pi.good * (1.0 - g.loss_good) * drop_after_good + pi.bad * (1.0 - g.loss_bad) * drop_after_bad;
  const double drops = pi.good * g.loss_good + pi.bad * g.loss_bad;
  if (drops <= 0.0) {
    // The stationary link never drops, so there are no bursts; return the
    // shortest possible burst, as the Bernoulli formula does at loss = 0.
    return 1.0;
  }
  if (burst_starts <= 0.0) return kInfinity;  // drops but never recovers: one endless burst
  return drops / burst_starts;
}

std::string link_kind(const LinkSpec& link) { return link.trace ? "trace" : link_model_name(link.loss); }

LinkModel empirical_link_model(const LinkTrace& trace) {
  const std::size_t n = trace.size();
  if (n == 0) throw LinkError("trace", "trace is empty (a trace needs at least one row)");
  // Bursts counted around the loop (a trace link loops by default): a burst that ends the
  // trace and one that starts it are one. Then every burst follows a delivery, so
  // bursts <= delivered, and with r = bursts/drops (1/mean burst), p = bursts/delivered the
  // chain's stationary loss p/(p + r) is exactly drops/n.
  std::size_t drops = 0, bursts = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (trace.delivered[i]) continue;
    ++drops;
    if (trace.delivered[i == 0 ? n - 1 : i - 1]) ++bursts;
  }
  if (drops == 0) return BernoulliLink{0.0};
  if (drops == n) return BernoulliLink{1.0};
  const double r = static_cast<double>(bursts) / static_cast<double>(drops);
  const double p = static_cast<double>(bursts) / static_cast<double>(n - drops);
  return GilbertElliottLink{p, r, 0.0, 1.0};
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

TraceSample trace_sample(const TraceLink& trace, std::uint64_t periods_since_start) {
  TraceSample out;
  const std::uint64_t n = trace.rows ? trace.rows->size() : 0;
  if (n == 0) return out;
  std::uint64_t row = trace.offset + periods_since_start;
  if (row < periods_since_start) return out;  // beyond 2^64 rows: no trace is that long
  if (row >= n) {
    if (!trace.loop) return out;  // past the end without loop: every sample is dropped
    row %= n;                     // loop: after the last row comes row 0, not the offset
  }
  out.delivered = trace.rows->delivered[row] != 0;
  out.delay_ms = trace.rows->has_delay && out.delivered ? trace.rows->delay_ms[row]
                                                         : std::numeric_limits<double>::quiet_NaN();
  return out;
}

std::string link_model_name(const LinkModel& model) {
  return std::holds_alternative<BernoulliLink>(model) ? "bernoulli" : "gilbert_elliott";
}

std::vector<std::pair<std::string, double>> link_parameters(const LinkModel& model) {
  if (const auto* b = std::get_if<BernoulliLink>(&model)) return {{"loss", b->loss}};
  const auto& g = std::get<GilbertElliottLink>(model);
  return {{"p", g.p}, {"r", g.r}, {"loss_good", g.loss_good}, {"loss_bad", g.loss_bad}};
}

std::string describe_link_model(const LinkModel& model) {
  std::string text = link_model_name(model);
  for (const auto& [name, value] : link_parameters(model)) {
    char number[32];
    std::snprintf(number, sizeof number, "%.4g", value);
    text += " " + name + "=" + number;
  }
  if (std::holds_alternative<GilbertElliottLink>(model)) {
    // Both forms: the chain's parameters and what they mean to a user.
    char both[96];
    std::snprintf(both, sizeof both, " (loss %.4g, mean burst %.4g)", stationary_loss(model), mean_burst_length(model));
    text += both;
  }
  return text;
}

std::string describe_link(const LinkSpec& link) {
  std::string text;
  if (link.trace) {
    text = "trace " + link.trace->path + " offset=" + std::to_string(link.trace->offset) +
           (link.trace->loop ? " loop" : " no loop");
    if (link.trace->rows) text += " (" + std::to_string(link.trace->rows->size()) + " rows)";
    text += ", empirical " + describe_link_model(link.loss);
    if (link.trace->rows && link.trace->rows->has_delay) return text + ", delay from the trace";
  } else {
    text = describe_link_model(link.loss);
  }
  if (!link.delay.none()) {
    char delay[96];
    std::snprintf(delay, sizeof delay, ", delay %.4g±%.4g ms %s", link.delay.delay_ms, link.delay.jitter_ms,
                  delay_distribution_name(link.delay.distribution).c_str());
    text += delay;
  }
  return text;
}

std::string delay_distribution_name(DelayDistribution d) {
  switch (d) {
    case DelayDistribution::uniform: return "uniform";
    case DelayDistribution::normal: return "normal";
    case DelayDistribution::pareto: return "pareto";
    case DelayDistribution::paretonormal: return "paretonormal";
  }
  return "uniform";
}

DelayDistribution parse_delay_distribution(const std::string& name) {
  for (const auto d : {DelayDistribution::uniform, DelayDistribution::normal, DelayDistribution::pareto,
                       DelayDistribution::paretonormal})
    if (name == delay_distribution_name(d)) return d;
  throw LinkError("delay_distribution",
                  "unknown delay_distribution '" + name + "' (expected uniform, normal, pareto or paretonormal)");
}

// ---- delay --------------------------------------------------------------------------

double delay_quantile(const LinkDelay& delay, double q) {
  if (delay.jitter_ms == 0.0) return delay.delay_ms;
  return std::max(0.0, delay.delay_ms + delay.jitter_ms * standard_quantile(delay.distribution, q));
}

double probability_within(const LinkDelay& delay, double deadline_ms) {
  if (deadline_ms < 0.0) return 0.0;  // a delay is never negative
  if (delay.jitter_ms == 0.0) return delay.delay_ms <= deadline_ms ? 1.0 : 0.0;
  // For a deadline >= 0 the cut at 0 does not matter: P(max(0, X) <= D) = P(X <= D).
  return standard_cdf(delay.distribution, (deadline_ms - delay.delay_ms) / delay.jitter_ms);
}

LinkModel effective_loss_model(const LinkSpec& link, double deadline_ms) {
  const double in_time = probability_within(link.delay, deadline_ms);
  const auto thinned = [in_time](double loss) { return 1.0 - (1.0 - loss) * in_time; };
  if (const auto* b = std::get_if<BernoulliLink>(&link.loss)) return BernoulliLink{thinned(b->loss)};
  auto g = std::get<GilbertElliottLink>(link.loss);
  g.loss_good = thinned(g.loss_good);
  g.loss_bad = thinned(g.loss_bad);
  return g;
}

double arrival_rate(const LinkModel& loss, double in_time) { return (1.0 - stationary_loss(loss)) * in_time; }

double effective_arrival_rate(const LinkSpec& link, double deadline_ms) {
  return arrival_rate(link.loss, probability_within(link.delay, deadline_ms));
}

}  // namespace netkf
