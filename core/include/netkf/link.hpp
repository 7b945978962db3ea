#pragma once
// The link: what happens to one sensor's samples between the sensor and the estimator.
// One type for every layer (scenario files, the channel emulator, the wire, `netkf ctl`,
// the dashboard, metrics, the theory): it owns its parameters, their one validation, their
// names as a person writes them (the "link keys" of docs/scenario-format.md), their
// description and the stationary statistics the theory needs.
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

struct LinkTrace;  // netkf/link_trace.hpp

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

/// How a link drops samples.
using LinkModel = std::variant<BernoulliLink, GilbertElliottLink>;

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

/// The fate of one sample on a trace link.
struct TraceSample {
  bool delivered = false;
  double delay_ms = 0.0;  // the row's delay_ms (NaN when the trace has no delay column or the row is lost)
};
/// The trace's row for the sample `periods_since_start` periods after the trace link took
/// effect (row offset + n; loop or drop past the end, as TraceLink says).
TraceSample trace_sample(const TraceLink& trace, std::uint64_t periods_since_start);

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

/// One link key as written by a person: a number, or a word (`model`, `delay_distribution`).
struct LinkKey {
  std::string name;
  std::variant<double, std::string> value;
  bool operator==(const LinkKey&) const = default;
};
using LinkKeys = std::vector<LinkKey>;

/// The model a link is, as a person writes it: "bernoulli", "gilbert_elliott" or "trace".
std::string link_kind(const LinkSpec& link);

/// The theory's model of a trace: the simple Gilbert channel (loss_good 0, loss_bad 1) with
/// the trace's own loss and mean burst (r = 1/mean burst, p = r·loss/(1 − loss)), which
/// is Bernoulli when the trace's drops are i.i.d.; bernoulli 0 or 1 for a trace that
/// delivers everything or nothing. Throws LinkError("trace") on an empty trace.
LinkModel empirical_link_model(const LinkTrace& trace);

/// Read a trace file for a link (link_trace.hpp's reader). Throws LinkError("trace", ...)
/// carrying the trace's FILE:LINE:COL message.
std::shared_ptr<const LinkTrace> read_link_trace_for(const std::string& path);
/// Read each trace a timeline event's `keys` name into `traces`, once per path, at start (never
/// per sample). One that cannot be read is left out: the loader read it already, so it has gone
/// since, and the event fails when it is due (journaled as such).
void read_event_traces(const LinkKeys& keys, TraceRows& traces);

/// Every key a link understands, in the order documented.
const std::vector<std::string>& link_key_names();
/// True for keys whose value is a word (model, delay_distribution, trace, loop).
bool link_key_is_word(const std::string& name);

/// The link `current` with `keys` applied; the keys not given keep their values. Rules
/// (docs/scenario-format.md, "Links"): giving `model` rebuilds the loss model from the keys
/// given (its required keys must be there); without it the keys change the current model's
/// parameters. A Gilbert-Elliott link may be given by p, r, loss_good, loss_bad or by the
/// user's form loss + mean_burst (the simple Gilbert channel: loss_good 0, loss_bad 1,
/// r = 1/mean_burst, p = r·loss/(1 − loss)); the forms do not mix. The result is validated.
/// Throws LinkError naming the first offending key; `current` is unchanged either way.
/// A trace link (model: trace, trace: FILE) reads FILE here, unless it is the current link's
/// file or in `preloaded`.
LinkSpec apply_link_keys(const LinkSpec& current, const LinkKeys& keys, const TraceRows* preloaded = nullptr);
/// A link from keys alone (`model` required).
LinkSpec link_from_keys(const LinkKeys& keys);
/// The whole link as keys (model, its parameters, delay_ms, jitter_ms, delay_distribution):
/// apply_link_keys(anything, link_keys(l)) == l.
LinkKeys link_keys(const LinkSpec& link);
/// The current value of a numeric key (for a Gilbert-Elliott link also `loss` and
/// `mean_burst` in the user's form). Throws LinkError when the key does not apply.
double link_key_value(const LinkSpec& link, const std::string& name);

/// Throws LinkError when a probability is outside [0,1] (or NaN), a Gilbert-Elliott chain
/// has p = r = 0, or a delay is negative, not finite or above a minute. The one validation.
void validate_link(const LinkSpec& link);
/// The loss model's part of validate_link().
void validate_link_model(const LinkModel& model);

/// Stationary probability that a sample is dropped.
double stationary_loss(const LinkModel& model);
/// Mean length of a run of consecutive drops (infinite if the link never delivers).
double mean_burst_length(const LinkModel& model);
/// "bernoulli" or "gilbert_elliott".
std::string link_model_name(const LinkModel& model);
/// The model's parameters by name, as in a scenario file: {loss} for Bernoulli;
/// {p, r, loss_good, loss_bad} for Gilbert-Elliott.
std::vector<std::pair<std::string, double>> link_parameters(const LinkModel& model);
/// One line: "bernoulli loss=0.3", "gilbert_elliott p=0.05 r=0.5 loss_good=0 loss_bad=1
/// (loss 0.09091, mean burst 2)".
std::string describe_link_model(const LinkModel& model);
/// The loss model's description, then the delay when there is one ("delay 6±4 ms uniform").
std::string describe_link(const LinkSpec& link);

/// "uniform", "normal", "pareto", "paretonormal"; parse throws LinkError on anything else.
std::string delay_distribution_name(DelayDistribution d);
DelayDistribution parse_delay_distribution(const std::string& name);

/// P(delay <= deadline_ms): the chance that a delivered sample is in time.
double probability_within(const LinkDelay& delay, double deadline_ms);
/// The delay of a standard quantile q in [0,1) (the inverse of probability_within): the
/// delay process draws q uniformly and returns this.
double delay_quantile(const LinkDelay& delay, double q);

/// The loss model the estimator sees when a sample later than `deadline_ms` counts as lost:
/// Bernoulli 1 − (1 − loss)·P(delay ≤ D); Gilbert-Elliott with loss_good and loss_bad
/// thinned the same way (the delay is drawn independently of the chain, so the arrivals
/// are again a Gilbert-Elliott chain with the same p, r). Exact for i.i.d. delays; not for
/// delays that depend on the chain's state or on each other.
LinkModel effective_loss_model(const LinkSpec& link, double deadline_ms);
/// The rate at which a link's samples arrive in time, λ = (1 − stationary loss)·in_time with
/// in_time = P(delay ≤ deadline): the one place this product is written.
double arrival_rate(const LinkModel& loss, double in_time);
/// arrival_rate of the link at `deadline_ms` (= 1 − stationary loss of its effective model).
double effective_arrival_rate(const LinkSpec& link, double deadline_ms);

}  // namespace netkf
