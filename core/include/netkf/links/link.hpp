#pragma once
// The link: what happens to one sensor's samples between the sensor and the estimator.
// One type for every layer (scenario files, the channel emulator, the wire, `netkf ctl`,
// the dashboard, metrics, the theory): it owns its parameters and their one validation.
// Beside it in this room: its keys as a person writes them (link_keys.hpp, the "link keys"
// of docs/scenario-format.md), its delay distributions (link_delay.hpp), its description
// (link_text.hpp) and the stationary statistics the theory needs (link_statistics.hpp).
//
// A link is a loss model (Bernoulli or Gilbert-Elliott, one draw per sample) followed by a
// delay (i.i.d. per delivered sample). A sample that arrives after the estimator fused its
// period is late and never fused, so for the estimator a link with deadline D delivers a
// sample with probability (1 - loss) · P(delay <= D): see effective_loss_model().
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace netkf {

struct LinkTrace;  // netkf/links/link_trace.hpp

/// i.i.d. drops: each sample is lost with probability `loss` (arrival rate λ = 1 - loss).
struct BernoulliLink {
  double loss = 0.0;
  bool operator==(const BernoulliLink&) const = default;
};

/// Two-state Gilbert-Elliott chain, one transition per sample.
/// p = P(good -> bad), r = P(bad -> good); loss_good / loss_bad = P(drop) in each state.
struct GilbertElliottLink {
  double p = 0.0;
  double r = 1.0;
  double loss_good = 0.0;
  double loss_bad = 1.0;
  bool operator==(const GilbertElliottLink&) const = default;
};

/// How a link drops samples. Code that depends on the model visits it with one overload per
/// model (std::visit(overloaded{...}, model)), so that a new model does not compile until every
/// such place handles it; what does not depend on the model reads it by name instead
/// (link_model_name, link_parameters in link_text.hpp, stationary_loss, mean_burst_length).
using LinkModel = std::variant<BernoulliLink, GilbertElliottLink>;

/// One call operator per lambda: std::visit(overloaded{[](const BernoulliLink&) {...}, ...}, model).
/// Without a catch-all overload the visit refuses to compile when an alternative has none.
template <class... Fs>
struct overloaded : Fs... {
  using Fs::operator()...;
};
template <class... Fs>
overloaded(Fs...) -> overloaded<Fs...>;

/// The shape of a link's delay around its base delay (netem's names and meanings).
enum class DelayDistribution {
  uniform,       // uniform on [delay - jitter, delay + jitter]
  normal,        // mean delay, standard deviation jitter
  pareto,        // delay + jitter · Z, Z = (4/3)(U^(-1/3) - 3/2): Pareto, shape 3, mean 0 (netem's table)
  paretonormal,  // delay + jitter · (Φ⁻¹(q)/4 + (3/4)·Z(q)), one quantile q for both (netem's table)
};

/// How long a delivered sample is held. A drawn delay below 0 is 0.
struct LinkDelay {
  double delay_ms = 0.0;   // base delay: the centre of every distribution (the mean but for the cuts at 0 and netem's cap)
  double jitter_ms = 0.0;  // spread: half-width (uniform), standard deviation (normal), scale (pareto*)
  DelayDistribution distribution = DelayDistribution::uniform;
  bool operator==(const LinkDelay&) const = default;
  /// No delay at all: samples are relayed at once.
  bool none() const { return delay_ms == 0.0 && jitter_ms == 0.0; }
};

/// A link that replays a measured arrival trace (docs/scenario-format.md, "Trace links"):
/// the sample of the n-th period since the trace link took effect gets the trace's row
/// offset + n; past the last row the trace starts again at row 0 (loop) or drops every
/// sample (no loop). The rows are read once, when the link is made (never per sample).
struct TraceLink {
  std::string path;                        // the trace file as read (a scenario's is resolved against its directory)
  bool loop = true;                        // past the end: start again at row 0, else drop everything
  std::uint64_t offset = 0;                // the row of the first period (< the trace's rows)
  std::shared_ptr<const LinkTrace> rows;   // the trace; null for a link described by the wire only
  // Two trace links are the same link when they name the same file the same way.
  bool operator==(const TraceLink& o) const { return path == o.path && loop == o.loop && offset == o.offset; }
};

/// Traces already read, by path: lets a link change switch to a trace without reading a file
/// where that must not happen (the channel's sample path; its timeline is read at start).
using TraceRows = std::map<std::string, std::shared_ptr<const LinkTrace>>;

/// One link: loss model and delay, or a trace. For a trace link `loss` is the trace's
/// empirical model (empirical_link_model: the theory's view of the trace) and the channel
/// replays `trace` instead of drawing from it; `delay` is used only when the trace has no
/// delay_ms column.
struct LinkSpec {
  LinkModel loss;
  LinkDelay delay;
  std::optional<TraceLink> trace;

  LinkSpec() = default;
  // Implicit: a loss model alone is a link without delay.
  LinkSpec(LinkModel model) : loss(model) {}  // NOLINT(google-explicit-constructor)
  LinkSpec(BernoulliLink model) : loss(model) {}  // NOLINT(google-explicit-constructor)
  LinkSpec(GilbertElliottLink model) : loss(model) {}  // NOLINT(google-explicit-constructor)
  LinkSpec(LinkModel model, LinkDelay d) : loss(model), delay(d) {}
  bool operator==(const LinkSpec&) const = default;
};

/// A link parameter refused, naming its key ("loss", "mean_burst", "delay_ms", ...), so a
/// scenario file can point at the key's line and `ctl` / the dashboard can name it.
class LinkError : public std::invalid_argument {
 public:
  LinkError(std::string key, const std::string& message) : std::invalid_argument(message), key_(std::move(key)) {}
  const std::string& key() const { return key_; }

 private:
  std::string key_;
};

/// The error said at a key path: "sensors[0].link.loss must be ..." when the message starts
/// with its key, else "sensors[0].link: message".
std::string link_error_at(const std::string& path, const LinkError& error);

/// The model a link is, as a person writes it: "bernoulli", "gilbert_elliott" or "trace".
std::string link_kind(const LinkSpec& link);

/// Throws LinkError when a probability is outside [0,1] (or NaN), a Gilbert-Elliott chain
/// has p = r = 0, or a delay is negative, not finite or above a minute. The one validation.
void validate_link(const LinkSpec& link);
/// The loss model's part of validate_link().
void validate_link_model(const LinkModel& model);

/// "bernoulli" or "gilbert_elliott".
std::string link_model_name(const LinkModel& model);
/// The model's name as a page shows it to a person: "Bernoulli" or "Gilbert-Elliott" (the
/// dashboard's pages take it from the channel catalogue, so a new model needs no JavaScript).
std::string link_model_label(const LinkModel& model);

/// One valid link of each model, in the variant's order: for a check that must try a change
/// on every model (`netkf ctl set-link` before it sends one) and for the models' names.
std::vector<LinkModel> one_link_of_each_model();
/// The model called `name` ("bernoulli", ...), as one_link_of_each_model() has it; none for
/// another name ("trace" included: a trace is a link, not a loss model).
std::optional<LinkModel> link_model_named(const std::string& name);
/// The models a link's `model` key takes, as a message lists them: "bernoulli, gilbert_elliott or trace".
std::string link_model_choices();

}  // namespace netkf
