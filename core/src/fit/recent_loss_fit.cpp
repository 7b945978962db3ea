// The fit of a link's recent samples (recent_loss_fit.hpp).
#include "netkf/fit/recent_loss_fit.hpp"

#include <cmath>
#include <stdexcept>

namespace netkf::fit {
namespace {

// count · log(probability), 0 when nothing was counted (the limit 0 · log 0 = 0).
double weighted_log(std::uint64_t count, double probability) {
  return count == 0 ? 0.0 : static_cast<double>(count) * std::log(probability);
}

}  // namespace

RecentArrivals::RecentArrivals(std::size_t window) : ring_(window, 0) {
  if (window < 2) throw std::invalid_argument("a recent-arrivals window needs at least 2 samples");
}

void RecentArrivals::record(bool dropped) {
  if (size_ == ring_.size()) {  // the oldest sample leaves, with its transition into the next
    const bool oldest = at(0);
    --transitions_[oldest][at(1)];
    dropped_ -= oldest ? 1 : 0;
    head_ = (head_ + 1) % ring_.size();
    --size_;
  }
  if (size_ > 0) ++transitions_[at(size_ - 1)][dropped];
  ring_[(head_ + size_) % ring_.size()] = dropped ? 1 : 0;
  ++size_;
  dropped_ += dropped ? 1 : 0;
}

void RecentArrivals::clear() {
  head_ = size_ = 0;
  dropped_ = 0;
  transitions_[0][0] = transitions_[0][1] = transitions_[1][0] = transitions_[1][1] = 0;
}

std::optional<RecentLossFit> RecentArrivals::fit() const {
  if (size_ == 0) return std::nullopt;
  RecentLossFit f;
  f.samples = size_;
  f.dropped = dropped_;
  const double q = static_cast<double>(dropped_) / static_cast<double>(size_);
  f.link = BernoulliLink{q};
  const std::uint64_t from_good = transitions_[0][0] + transitions_[0][1];
  const std::uint64_t from_bad = transitions_[1][0] + transitions_[1][1];
  if (from_good > 0 && from_bad > 0) {
    // The transition frequencies; both states have a transition out, so p + r > 0.
    const double p = static_cast<double>(transitions_[0][1]) / static_cast<double>(from_good);
    const double r = static_cast<double>(transitions_[1][0]) / static_cast<double>(from_bad);
    const double first_bad = p / (p + r);  // stationary P(Bad) of the first sample
    const double ll = std::log(at(0) ? first_bad : 1.0 - first_bad) + weighted_log(transitions_[0][0], 1.0 - p) +
                      weighted_log(transitions_[0][1], p) + weighted_log(transitions_[1][0], r) +
                      weighted_log(transitions_[1][1], 1.0 - r);
    const double ll_bernoulli = weighted_log(dropped_, q) + weighted_log(size_ - dropped_, 1.0 - q);
    // The chain can give the window probability 0: `1 0 0` has p = 0, so its stationary start
    // is Good and the first drop impossible. Then there is no chain fit (only bernoulli), not
    // an AIC gain of −∞, which no link status could carry (2048 sensors at 10 Hz had such
    // statuses rejected at the start of the run, and their links taken for silent).
    if (!std::isfinite(ll)) return f;
    // AIC = 2 · free parameters − 2 log L: bernoulli has 1, simple_gilbert 2.
    f.aic_gain = (2.0 - 2.0 * ll_bernoulli) - (4.0 - 2.0 * ll);
    if (*f.aic_gain > 2.0) {  // loss_fit.cpp's parsimony: bernoulli unless 2 worse
      f.family = LossFamily::simple_gilbert;
      f.link = GilbertElliottLink{p, r, 0.0, 1.0};
    }
  }
  return f;
}

}  // namespace netkf::fit
