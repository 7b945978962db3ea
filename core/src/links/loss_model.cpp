// Seeded packet-loss and delay processes (netkf/links/loss_model.hpp); the link's parameters,
// validation and statistics are in link.cpp.
#include "netkf/links/loss_model.hpp"

#include "netkf/links/link_delay.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <variant>

namespace netkf {

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
  const bool was_gilbert_elliott = std::visit(overloaded{[](const BernoulliLink&) { return false; },
                                                          [](const GilbertElliottLink&) { return true; }},
                                               model_);
  model_ = model;
  // Unlike netem we keep the chain state across parameter changes: a link that is
  // in a bad spell stays in it when the operator retunes p or r. A link that was
  // Bernoulli has no chain state, so a new Gilbert-Elliott chain starts in Good.
  if (!was_gilbert_elliott) state_ = ChainState::good;
}

// ---- LinkDelayProcess ---------------------------------------------------------------

double LinkDelayProcess::next_delay_ms(const LinkDelay& delay) {
  // One uniform draw per delivered sample, also without delay, so that turning a delay on
  // or off mid-run does not shift the stream of the draws that follow.
  const double q = rng_.uniform();
  return delay_quantile(delay, q);
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
