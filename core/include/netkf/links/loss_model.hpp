#pragma once
// Seeded packet-loss and delay processes for one link (docs/scenario-format.md, "Links").
#include <cstdint>
#include <variant>

#include "netkf/links/link.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/support/random.hpp"

namespace netkf {

/// One link's drop process. Parameters can be changed between samples without
/// resetting the Gilbert-Elliott chain state (unlike netem, which resets to Good).
class LinkLossProcess {
 public:
  enum class ChainState { good, bad };

  LinkLossProcess(const LinkModel& model, std::uint64_t seed);

  /// Advance by one sample; true when this sample is dropped. Inline: the Monte Carlo
  /// kernels call it once per link and step.
  bool next_dropped() {
    return std::visit(overloaded{[this](const BernoulliLink& b) { return rng_.uniform() < b.loss; },
                                 [this](const GilbertElliottLink& g) { return next_dropped_gilbert_elliott(g); }},
                      model_);
  }

  /// Replace the model from the next sample on. A Gilbert-Elliott chain keeps its state;
  /// switching from Bernoulli to Gilbert-Elliott starts in Good. Throws std::invalid_argument
  /// (and changes nothing) on an invalid model.
  void set_model(const LinkModel& model);

  const LinkModel& model() const { return model_; }
  ChainState chain_state() const { return state_; }
  double stationary_loss() const { return netkf::stationary_loss(model_); }
  double mean_burst_length() const { return netkf::mean_burst_length(model_); }

 private:
  bool next_dropped_gilbert_elliott(const GilbertElliottLink& g);

  LinkModel model_;
  Rng rng_;
  ChainState state_ = ChainState::good;
};

/// One link's delay draws (i.i.d. per delivered sample, seeded like the loss draws but on a
/// stream of its own, so a delay never changes the drop decisions).
class LinkDelayProcess {
 public:
  explicit LinkDelayProcess(std::uint64_t seed) : rng_(seed) {}
  /// The hold time of the next delivered sample, in ms (0 when the link has no delay).
  double next_delay_ms(const LinkDelay& delay);

 private:
  Rng rng_;
};

/// Running statistics of what a link did: counts, observed loss, bursts of drops.
class LinkStatistics {
 public:
  void record(bool dropped);
  std::uint64_t samples() const { return samples_; }
  std::uint64_t dropped() const { return dropped_; }
  std::uint64_t delivered() const { return samples_ - dropped_; }
  double observed_loss() const;           // dropped / samples (0 when no samples)
  double mean_burst_length() const;       // mean length of completed-or-open drop runs (0 if none)
  std::uint64_t bursts() const { return bursts_; }

 private:
  std::uint64_t samples_ = 0;
  std::uint64_t dropped_ = 0;
  std::uint64_t bursts_ = 0;
  bool in_burst_ = false;
};

}  // namespace netkf
