// A link's stationary statistics (netkf/links/link_statistics.hpp): loss, mean burst, the
// empirical model of a trace and the effective loss model the theory uses.
#include "netkf/links/link_statistics.hpp"

#include "netkf/links/link_delay.hpp"
#include "netkf/links/link_trace.hpp"

#include <cstddef>
#include <limits>
#include <variant>

namespace netkf {
namespace {

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

constexpr double kInfinity = std::numeric_limits<double>::infinity();

}  // namespace

double stationary_loss(const LinkModel& model) {
  return std::visit(overloaded{[](const BernoulliLink& b) { return b.loss; },
                               [](const GilbertElliottLink& g) {
                                 const GoodBad pi = stationary_distribution(g);
                                 // (r·loss_good + p·loss_bad)/(p + r)   (docs/scenario-format.md, "Gilbert-Elliott")
                                 return pi.good * g.loss_good + pi.bad * g.loss_bad;
                               }},
                    model);
}

namespace {

double bernoulli_mean_burst(const BernoulliLink& b) {
  // Burst lengths are geometric: P(length = k) = loss^(k-1) (1 - loss).
  return b.loss >= 1.0 ? kInfinity : 1.0 / (1.0 - b.loss);
}

double chain_mean_burst(const GilbertElliottLink& g) {
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

}  // namespace

double mean_burst_length(const LinkModel& model) {
  return std::visit(overloaded{[](const BernoulliLink& b) { return bernoulli_mean_burst(b); },
                               [](const GilbertElliottLink& g) { return chain_mean_burst(g); }},
                    model);
}

std::optional<double> iid_arrival_rate(const LinkModel& model) {
  return std::visit(overloaded{[](const BernoulliLink& b) -> std::optional<double> { return 1.0 - b.loss; },
                               [](const GilbertElliottLink&) -> std::optional<double> { return std::nullopt; }},
                    model);
}

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

LinkModel effective_loss_model(const LinkSpec& link, double deadline_ms) {
  const double in_time = probability_within(link.delay, deadline_ms);
  const auto thinned = [in_time](double loss) { return 1.0 - (1.0 - loss) * in_time; };
  return std::visit(overloaded{[&](const BernoulliLink& b) -> LinkModel { return BernoulliLink{thinned(b.loss)}; },
                               [&](GilbertElliottLink g) -> LinkModel {
                                 g.loss_good = thinned(g.loss_good);
                                 g.loss_bad = thinned(g.loss_bad);
                                 return g;
                               }},
                    link.loss);
}

double arrival_rate(const LinkModel& loss, double in_time) { return (1.0 - stationary_loss(loss)) * in_time; }

double effective_arrival_rate(const LinkSpec& link, double deadline_ms) {
  return arrival_rate(link.loss, probability_within(link.delay, deadline_ms));
}

}  // namespace netkf
