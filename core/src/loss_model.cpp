// Seeded packet-loss processes (netkf/loss_model.hpp) and the link-model helpers
// declared in netkf/scenario.hpp (stationary loss, mean burst length, validation).
#include "netkf/loss_model.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <variant>

namespace netkf {
namespace {

void check_probability(const char* name, double value) {
  // Written as a negated range test so that NaN is rejected too.
  if (!(value >= 0.0 && value <= 1.0))
    throw std::invalid_argument(std::string(name) + " must be a probability in [0, 1], got " + std::to_string(value));
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

}  // namespace

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

std::string link_model_name(const LinkModel& model) {
  return std::holds_alternative<BernoulliLink>(model) ? "bernoulli" : "gilbert_elliott";
}

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
  // One rule for files, `ctl`, the dashboard and the control topic: p = r = 0 leaves the
  // chain's stationary distribution undefined (it would stay wherever it is).
  if (g.p + g.r <= 0.0) throw std::invalid_argument("p and r cannot both be 0 (the chain would never move)");
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
  return text;
}

// ---- LinkLossProcess ----------------------------------------------------------------

LinkLossProcess::LinkLossProcess(const LinkModel& model, std::uint64_t seed) : model_(model), rng_(seed) {
  validate_link_model(model_);
}

bool LinkLossProcess::next_dropped_gilbert_elliott(const GilbertElliottLink& g) {
  // Order per sample: first the chain transition, then the drop decision in the
  // state just entered. (The stationary loss and burst statistics computed above
  // use the same order; the stationary loss does not depend on it.)
  // uniform() is in [0, 1): probability 0 never fires, probability 1 always does.
  if (state_ == ChainState::good) {
    if (rng_.uniform() < g.p) state_ = ChainState::bad;
  } else {
    if (rng_.uniform() < g.r) state_ = ChainState::good;
  }
  const double loss = state_ == ChainState::good ? g.loss_good : g.loss_bad;
  return rng_.uniform() < loss;
}

void LinkLossProcess::set_model(const LinkModel& model) {
  validate_link_model(model);  // throws before anything changes
  const bool was_gilbert_elliott = std::holds_alternative<GilbertElliottLink>(model_);
  model_ = model;
  // Unlike netem we keep the chain state across parameter changes: a link that is
  // in a bad spell stays in it when the operator retunes p or r. A link that was
  // Bernoulli has no chain state, so a new Gilbert-Elliott chain starts in Good.
  if (!was_gilbert_elliott) state_ = ChainState::good;
}

// ---- LinkStatistics -----------------------------------------------------------------

void LinkStatistics::record(bool dropped) {
  ++samples_;
  if (dropped) {
    ++dropped_;
    if (!in_burst_) ++bursts_;
    in_burst_ = true;
  } else {
    in_burst_ = false;
  }
}

double LinkStatistics::observed_loss() const {
  return samples_ == 0 ? 0.0 : static_cast<double>(dropped_) / static_cast<double>(samples_);
}

double LinkStatistics::mean_burst_length() const {
  // Every drop belongs to exactly one burst (the last one may still be open).
  return bursts_ == 0 ? 0.0 : static_cast<double>(dropped_) / static_cast<double>(bursts_);
}

}  // namespace netkf
