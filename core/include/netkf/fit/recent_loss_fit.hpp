#pragma once
// The loss model a link's own recent samples show: the channel keeps one window per link and
// sends its fit with every link status (docs/cli.md, "Link status keys"), so `netkf ctl
// status` and the dashboard show, beside the configured model, what the link did.
//
// The window holds the drop decisions of the link's last `window` samples since its model was
// last set (a change empties it, as it resets the since-change counts; a ramp's steps do not).
// Its fit is the pair of closed-form families of loss_fit.hpp: bernoulli (loss = drops / n)
// and simple_gilbert (the chain seen directly: p = P(drop | delivered before), r = P(delivered
// | drop before), transition frequencies), with loss_fit.hpp's likelihood (the chain started in
// its stationary distribution) and its rule of choice: the least AIC, bernoulli when within 2
// of it. Both need only the window's counts of drops and of the four transitions, kept as
// samples enter and leave, so recording a sample and fitting are O(1): the channel does it on
// its receive thread and under its status lock. The hidden-chain families (gilbert,
// gilbert_elliott: Baum-Welch) are for `netkf fit` on a trace (`netkf trace extract`).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "netkf/fit/loss_fit.hpp"
#include "netkf/links/link_statistics.hpp"

namespace netkf::fit {

/// What a window shows; all of it travels in the link status (idl/netkf.idl, LinkStatus fit_*).
struct RecentLossFit {
  std::uint64_t samples = 0;   // in the window
  std::uint64_t dropped = 0;
  LossFamily family = LossFamily::bernoulli;  // bernoulli or simple_gilbert, by AIC
  LinkModel link;              // the chosen family's link: its keys as a scenario takes them
  /// AIC(bernoulli) − AIC(simple_gilbert) (> 2 chooses simple_gilbert), always finite; none
  /// without a transition out of both states, or when the fitted chain gives the window
  /// probability 0 (e.g. `1 0 0`: p = 0 cannot start in Bad); then only bernoulli is fitted.
  std::optional<double> aic_gain;

  double loss() const { return stationary_loss(link); }
  double mean_burst() const { return mean_burst_length(link); }  // infinite: loss 1
};

class RecentArrivals {
 public:
  static constexpr std::size_t kDefaultWindow = 5000;

  RecentArrivals() : RecentArrivals(kDefaultWindow) {}
  /// `window` >= 2 samples.
  explicit RecentArrivals(std::size_t window);

  void record(bool dropped);
  void clear();
  std::size_t window() const { return ring_.size(); }
  std::uint64_t samples() const { return size_; }
  /// The fit of the window; none before its first sample.
  std::optional<RecentLossFit> fit() const;

 private:
  bool at(std::size_t i) const { return ring_[(head_ + i) % ring_.size()] != 0; }  // i-th oldest

  std::vector<std::uint8_t> ring_;  // 1 = dropped
  std::size_t head_ = 0;            // oldest
  std::size_t size_ = 0;
  std::uint64_t dropped_ = 0;
  std::uint64_t transitions_[2][2] = {{0, 0}, {0, 0}};  // [previous][next] within the window, 1 = dropped
};

}  // namespace netkf::fit
