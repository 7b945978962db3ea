// The link type (netkf/links/link.hpp: docs/scenario-format.md, "Links"): its keys, stationary
// statistics, delay distributions and effective loss model. Scenario `events:` are
// model/test_link_events.cpp's, ramps in the channel channel_emulator/test_channel_events.cpp's.
//
// Expectations are written here independently of core/src/links/link.cpp: the Gilbert-Elliott
// user form by its closed form (r = 1/B, p = r·L/(1 − L)), the stationary statistics by
// simulation, the delay CDFs by their closed forms (uniform: linear; normal: 0.5·erfc;
// netem's Pareto: 1 − (1.5 + 0.75 z)^(−3)), the delay draws by a Kolmogorov-Smirnov
// bound, and the effective loss model by a simulation of loss draws + delay draws +
// deadline.
//
// Tolerances of the statistical checks (fixed seeds, so every run is the same; the bounds
// say what a run with any seed would pass with high probability):
//  - a loss fraction over n samples: 5 standard errors, with the standard error of a
//    Markov-modulated Bernoulli sequence (binomial variance plus the chain's
//    autocovariance, see loss_fraction_se) — for a Bernoulli link exactly binomial;
//  - a mean burst length: 5 standard errors by batch means over the bursts (consecutive
//    bursts are dependent through the chain state);
//  - an empirical CDF: the Kolmogorov-Smirnov statistic below 1.63/sqrt(n), its 1 %
//    critical value (conservative for the atoms at 0 and at netem's table limit).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <limits>
#include <ostream>
#include <string>
#include <unistd.h>
#include <variant>
#include <vector>

#include "netkf/links/link.hpp"
#include "netkf/links/link_delay.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_text.hpp"
#include "netkf/links/loss_model.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/support/random.hpp"

#include "support/link_printers.hpp"

namespace {

using netkf::BernoulliLink;
using netkf::DelayDistribution;
using netkf::GilbertElliottLink;
using netkf::LinkDelay;
using netkf::LinkError;
using netkf::LinkKey;
using netkf::LinkKeys;
using netkf::LinkSpec;
using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// netem's distribution tables hold Z · 8192 in 16 bits: Z is at most 32767/8192.
constexpr double kTableLimit = 32767.0 / 8192.0;

using netkf_test::num;
using netkf_test::word;

const GilbertElliottLink& ge(const LinkSpec& l) { return std::get<GilbertElliottLink>(l.loss); }

struct Refusal {
  std::string key;
  std::string message;
};
Refusal refusal_of(const LinkSpec& current, const LinkKeys& keys) {
  try {
    (void)netkf::apply_link_keys(current, keys);
  } catch (const LinkError& e) {
    return {e.key(), e.what()};
  }
  return {"<accepted>", "<accepted>"};
}

// ---- independent closed forms --------------------------------------------------------

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// Z = (4/3)(U^(-1/3) - 3/2), U uniform on (0,1]: P(Z <= z) = P(U >= (1.5 + 0.75 z)^(-3)).
// netem's table cannot hold Z above 32767/8192, so that is the largest value.
double pareto_cdf(double z) {
  if (z >= kTableLimit) return 1.0;
  const double base = 1.5 + 0.75 * z;
  if (base <= 1.0) return 0.0;  // z <= -2/3, the smallest value
  return 1.0 - std::pow(base, -3.0);
}

// P(delay <= d) for delay = max(0, delay_ms + jitter_ms · Z).
double closed_form_cdf(const LinkDelay& d, double deadline) {
  if (deadline < 0.0) return 0.0;
  const double z = (deadline - d.delay_ms) / d.jitter_ms;
  switch (d.distribution) {
    case DelayDistribution::uniform: return std::clamp((z + 1.0) / 2.0, 0.0, 1.0);
    case DelayDistribution::normal: return normal_cdf(z);
    case DelayDistribution::pareto: return pareto_cdf(z);
    case DelayDistribution::paretonormal: break;
  }
  ADD_FAILURE() << "no closed form for paretonormal";
  return 0.0;
}

// Stationary statistics of a Gilbert-Elliott chain computed by matrices (state moves
// first, then the drop in the new state): pi = (r, p)/(p + r), T the transition matrix,
// l the drop probabilities. P(drop) = pi·l; P(delivered, then dropped) = Σ pi_s (1 - l_s) (T l)_s.
struct ChainStats {
  double loss;
  double mean_burst;
  double loss_fraction_variance;  // asymptotic n·Var(observed loss over n samples)
};
ChainStats chain_stats(const GilbertElliottLink& g) {
  const double pi[2] = {g.r / (g.p + g.r), g.p / (g.p + g.r)};
  const double T[2][2] = {{1.0 - g.p, g.p}, {g.r, 1.0 - g.r}};
  const double l[2] = {g.loss_good, g.loss_bad};
  double drop = 0.0, burst_starts = 0.0;
  for (int s = 0; s < 2; ++s) {
    drop += pi[s] * l[s];
    double next_drop = 0.0;
    for (int t = 0; t < 2; ++t) next_drop += T[s][t] * l[t];
    burst_starts += pi[s] * (1.0 - l[s]) * next_drop;
  }
  // Cov(X_t, X_{t+k}) = pi_g pi_b (l_b - l_g)^2 λ^k with λ = 1 - p - r (k >= 1), so
  // n·Var(mean) -> L(1 - L) + 2 pi_g pi_b (l_b - l_g)^2 λ/(1 - λ).
  const double lambda = 1.0 - g.p - g.r;
  const double diff = g.loss_bad - g.loss_good;
  const double variance = drop * (1.0 - drop) + 2.0 * pi[0] * pi[1] * diff * diff * lambda / (1.0 - lambda);
  return {drop, drop / burst_starts, variance};
}

double loss_fraction_se(const netkf::LinkModel& model, double n) {
  if (const auto* b = std::get_if<BernoulliLink>(&model)) return std::sqrt(b->loss * (1.0 - b->loss) / n);
  return std::sqrt(chain_stats(std::get<GilbertElliottLink>(model)).loss_fraction_variance / n);
}

// Mean and standard error by non-overlapping batch means.
struct Estimate {
  double mean;
  double se;
};
Estimate batch_means(const std::vector<double>& values, int batches) {
  const std::size_t size = values.size() / static_cast<std::size_t>(batches);
  double sum = 0.0, sum_sq = 0.0;
  for (int b = 0; b < batches; ++b) {
    double s = 0.0;
    for (std::size_t i = 0; i < size; ++i) s += values[static_cast<std::size_t>(b) * size + i];
    const double m = s / static_cast<double>(size);
    sum += m;
    sum_sq += m * m;
  }
  const double mean = sum / batches;
  const double var = (sum_sq - batches * mean * mean) / (batches - 1);
  return {mean, std::sqrt(var / batches)};
}

// A drop sequence's statistics, counted here (bursts as runs of drops) and by LinkStatistics.
struct Observed {
  netkf::LinkStatistics stats;
  std::vector<double> bursts;  // completed runs of drops
  void record(bool dropped) {
    stats.record(dropped);
    if (dropped) {
      ++run;
    } else if (run > 0) {
      bursts.push_back(run);
      run = 0;
    }
  }
  double run = 0;
};

// Kolmogorov-Smirnov distance between the sample and `cdf`, evaluated on both sides of
// every distinct value (the delay distributions have atoms at 0 and at the table limit).
double ks_distance(std::vector<double> x, const std::function<double(double)>& cdf) {
  std::sort(x.begin(), x.end());
  const double n = static_cast<double>(x.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < x.size();) {
    std::size_t j = i;
    while (j < x.size() && x[j] == x[i]) ++j;
    const double at = cdf(x[i]);
    const double before = cdf(std::nextafter(x[i], -kInf));
    worst = std::max({worst, std::abs(static_cast<double>(j) / n - at), std::abs(static_cast<double>(i) / n - before)});
    i = j;
  }
  return worst;
}

std::vector<double> draw_delays(const LinkDelay& d, std::uint64_t seed, int n) {
  netkf::LinkDelayProcess process(seed);
  std::vector<double> out;
  out.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) out.push_back(process.next_delay_ms(d));
  return out;
}

// ======================================================================================
// apply_link_keys: partial changes, rebuilds, the user form, refusals, round trips.

TEST(LinkType, APartialChangeKeepsTheOtherKeys) {
  const LinkSpec bernoulli(BernoulliLink{0.3}, LinkDelay{5.0, 2.0, DelayDistribution::normal});
  // A delay keeps the loss model and the other delay keys.
  const LinkSpec delayed = netkf::apply_link_keys(bernoulli, {num("delay_ms", 20.0)});
  EXPECT_EQ(delayed, LinkSpec(BernoulliLink{0.3}, LinkDelay{20.0, 2.0, DelayDistribution::normal}));
  EXPECT_EQ(netkf::apply_link_keys(bernoulli, {word("delay_distribution", "pareto")}),
            LinkSpec(BernoulliLink{0.3}, LinkDelay{5.0, 2.0, DelayDistribution::pareto}));
  // `loss` on a Bernoulli link changes the loss and keeps the delay.
  EXPECT_EQ(netkf::apply_link_keys(bernoulli, {num("loss", 1.0)}),
            LinkSpec(BernoulliLink{1.0}, LinkDelay{5.0, 2.0, DelayDistribution::normal}));

  const LinkSpec chain(GilbertElliottLink{0.1, 0.3, 0.02, 0.7}, LinkDelay{6.0, 4.0, DelayDistribution::uniform});
  EXPECT_EQ(netkf::apply_link_keys(chain, {num("jitter_ms", 1.0)}),
            LinkSpec(GilbertElliottLink{0.1, 0.3, 0.02, 0.7}, LinkDelay{6.0, 1.0, DelayDistribution::uniform}));
  // A chain parameter alone changes only that parameter.
  EXPECT_EQ(netkf::apply_link_keys(chain, {num("p", 0.2)}),
            LinkSpec(GilbertElliottLink{0.2, 0.3, 0.02, 0.7}, chain.delay));
  EXPECT_EQ(netkf::apply_link_keys(chain, {num("loss_good", 0.0), num("loss_bad", 1.0)}),
            LinkSpec(GilbertElliottLink{0.1, 0.3, 0.0, 1.0}, chain.delay));
  // No keys: the same link.
  EXPECT_EQ(netkf::apply_link_keys(chain, {}), chain);
}

TEST(LinkType, ModelRebuildsTheLossModelFromTheKeysGiven) {
  const LinkSpec chain(GilbertElliottLink{0.1, 0.3, 0.02, 0.7}, LinkDelay{6.0, 4.0, DelayDistribution::normal});
  // To Bernoulli: the delay stays.
  EXPECT_EQ(netkf::apply_link_keys(chain, {word("model", "bernoulli"), num("loss", 0.25)}),
            LinkSpec(BernoulliLink{0.25}, chain.delay));
  // Rebuilding a Gilbert-Elliott link does not keep the old loss_good / loss_bad: they take
  // their defaults (0 and 1) unless given.
  EXPECT_EQ(netkf::apply_link_keys(chain, {word("model", "gilbert_elliott"), num("p", 0.05), num("r", 0.5)}),
            LinkSpec(GilbertElliottLink{0.05, 0.5, 0.0, 1.0}, chain.delay));
  EXPECT_EQ(netkf::apply_link_keys(LinkSpec(BernoulliLink{0.3}), {word("model", "gilbert_elliott"), num("p", 0.05),
                                                                  num("r", 0.5), num("loss_bad", 0.8)}),
            LinkSpec(GilbertElliottLink{0.05, 0.5, 0.0, 0.8}));

  // The rebuilt model's required keys must be there.
  const LinkSpec any(BernoulliLink{0.3});
  EXPECT_EQ(refusal_of(any, {word("model", "bernoulli")}).key, "loss");
  EXPECT_THAT(refusal_of(any, {word("model", "bernoulli")}).message, HasSubstr("needs loss"));
  EXPECT_EQ(refusal_of(chain, {word("model", "bernoulli")}).key, "loss");
  EXPECT_EQ(refusal_of(any, {word("model", "gilbert_elliott")}).key, "p");
  EXPECT_EQ(refusal_of(any, {word("model", "gilbert_elliott"), num("p", 0.1)}).key, "r");
  EXPECT_EQ(refusal_of(any, {word("model", "gilbert_elliott"), num("r", 0.1)}).key, "p");
  EXPECT_THAT(refusal_of(any, {word("model", "gilbert_elliott"), num("r", 0.1)}).message, HasSubstr("needs p and r"));
  EXPECT_EQ(refusal_of(any, {word("model", "gilbert_elliott"), num("loss", 0.1)}).key, "mean_burst");
  EXPECT_EQ(refusal_of(any, {word("model", "gilbert_elliott"), num("mean_burst", 3.0)}).key, "loss");
  EXPECT_THAT(refusal_of(any, {word("model", "gilbert_elliott"), num("mean_burst", 3.0)}).message,
              HasSubstr("needs both loss and mean_burst"));
  // Even on a Gilbert-Elliott link: `model` means "from these keys only".
  EXPECT_EQ(refusal_of(chain, {word("model", "gilbert_elliott"), num("p", 0.1)}).key, "r");
  EXPECT_EQ(refusal_of(chain, {word("model", "gilbert_elliott"), num("loss", 0.1)}).key, "mean_burst");
  // link_from_keys needs `model` at all.
  EXPECT_THROW((void)netkf::link_from_keys({num("loss", 0.1)}), LinkError);
  EXPECT_EQ(netkf::link_from_keys({word("model", "bernoulli"), num("loss", 0.1), num("delay_ms", 3.0)}),
            LinkSpec(BernoulliLink{0.1}, LinkDelay{3.0, 0.0, DelayDistribution::uniform}));
}

TEST(LinkType, UserFormIsTheSimpleGilbertChannelAndRoundTrips) {
  struct Case {
    double loss, burst;
  };
  // Including the edges: loss 0, burst 1 (Bernoulli-like chain at loss 0.5, p = 1).
  for (const Case c : {Case{0.2, 5.0}, Case{0.05, 2.0}, Case{0.3, 1.5}, Case{0.5, 1.0}, Case{0.01, 40.0},
                       Case{0.7, 3.0}, Case{0.0, 3.0}}) {
    SCOPED_TRACE("loss " + std::to_string(c.loss) + " mean_burst " + std::to_string(c.burst));
    const LinkSpec link = netkf::apply_link_keys(
        LinkSpec(BernoulliLink{0.9}), {word("model", "gilbert_elliott"), num("loss", c.loss), num("mean_burst", c.burst)});
    const double r = 1.0 / c.burst;
    const double p = r * c.loss / (1.0 - c.loss);
    ASSERT_TRUE(std::holds_alternative<GilbertElliottLink>(link.loss));
    EXPECT_NEAR(ge(link).r, r, 1e-15);
    EXPECT_NEAR(ge(link).p, p, 1e-15);
    EXPECT_EQ(ge(link).loss_good, 0.0);
    EXPECT_EQ(ge(link).loss_bad, 1.0);
    // Round trip: the chain's statistics are what the user asked for.
    EXPECT_NEAR(netkf::stationary_loss(link.loss), c.loss, 1e-14);
    if (c.loss > 0.0) {
      EXPECT_NEAR(netkf::mean_burst_length(link.loss), c.burst, 1e-12 * c.burst);
    }
    EXPECT_NEAR(netkf::link_key_value(link, "loss"), c.loss, 1e-14);
  }
  // One key of the user form changes it and keeps the other (on a Gilbert-Elliott link).
  const LinkSpec user = netkf::apply_link_keys(LinkSpec{}, {word("model", "gilbert_elliott"), num("loss", 0.2),
                                                            num("mean_burst", 5.0), num("delay_ms", 3.0)});
  const LinkSpec more_loss = netkf::apply_link_keys(user, {num("loss", 0.1)});
  EXPECT_NEAR(netkf::stationary_loss(more_loss.loss), 0.1, 1e-14);
  EXPECT_NEAR(netkf::mean_burst_length(more_loss.loss), 5.0, 1e-12);
  EXPECT_EQ(more_loss.delay, user.delay);
  const LinkSpec longer = netkf::apply_link_keys(user, {num("mean_burst", 8.0)});
  EXPECT_NEAR(netkf::stationary_loss(longer.loss), 0.2, 1e-14);
  EXPECT_NEAR(netkf::mean_burst_length(longer.loss), 8.0, 1e-12);
  // On a chain with loss_good / loss_bad not 0 / 1, `loss` makes it the simple Gilbert
  // channel with that loss and the chain's mean burst (loss_good, loss_bad, p, r all change).
  const LinkSpec chain(GilbertElliottLink{0.1, 0.3, 0.02, 0.7});
  const double chain_burst = chain_stats(ge(chain)).mean_burst;
  const LinkSpec simple = netkf::apply_link_keys(chain, {num("loss", 0.1)});
  EXPECT_EQ(ge(simple).loss_good, 0.0);
  EXPECT_EQ(ge(simple).loss_bad, 1.0);
  EXPECT_NEAR(ge(simple).r, 1.0 / chain_burst, 1e-14);
  EXPECT_NEAR(netkf::stationary_loss(simple.loss), 0.1, 1e-14);
}

TEST(LinkType, UserFormAtTheLargestLossItsBurstAllows) {
  // B = 1 and B = 3: L = B/(B + 1) gives p = 1 exactly in floating point and is accepted.
  for (const double b : {1.0, 3.0, 7.0}) {
    const double l = b / (b + 1.0);
    const LinkSpec link = netkf::apply_link_keys(
        LinkSpec{}, {word("model", "gilbert_elliott"), num("loss", l), num("mean_burst", b)});
    EXPECT_NEAR(ge(link).p, 1.0, 1e-15) << b;
  }
  // Just above: refused, naming loss and the largest loss allowed.
  const Refusal above = refusal_of(LinkSpec{}, {word("model", "gilbert_elliott"), num("loss", 0.76), num("mean_burst", 3.0)});
  EXPECT_EQ(above.key, "loss");
  EXPECT_THAT(above.message, HasSubstr("allows a loss of at most 0.75"));
}

// L = B/(B + 1) is documented as allowed ("B = 5 allows 0.833..."): for B = 4, 5, 9, 2.5 the
// rounding of p = r·L/(1 − L) gives 1.0000000000000002, which must not refuse the link (nor a
// no-op change such as `set: { mean_burst: 4 }` on the valid chain p = 1, r = 0.25).
TEST(LinkType, UserFormAcceptsLossEqualToItsDocumentedMaximum) {
  for (const double b : {4.0, 5.0, 9.0, 2.5}) {
    const Refusal r =
        refusal_of(LinkSpec{}, {word("model", "gilbert_elliott"), num("loss", b / (b + 1.0)), num("mean_burst", b)});
    EXPECT_EQ(r.key, "<accepted>") << "mean_burst " << b << ": " << r.message;
  }
  const LinkSpec chain(GilbertElliottLink{1.0, 0.25, 0.0, 1.0});
  EXPECT_EQ(refusal_of(chain, {num("mean_burst", 4.0)}).key, "<accepted>") << refusal_of(chain, {num("mean_burst", 4.0)}).message;
}

// The mean burst of a simple Gilbert chain is 1/r also at p = 0, where it has no drops to
// measure: a user-form link `{ loss: 0, mean_burst: 5 }` followed by `set: { loss: 0.2 }` (or
// a ramp of loss from 0) keeps mean burst 5.
TEST(LinkType, AUserFormLinkWithLossZeroKeepsItsMeanBurst) {
  EXPECT_NEAR(netkf::mean_burst_length(GilbertElliottLink{1e-12, 0.2, 0.0, 1.0}), 5.0, 1e-9);
  EXPECT_NEAR(netkf::mean_burst_length(GilbertElliottLink{0.0, 0.2, 0.0, 1.0}), 5.0, 1e-9);
  const LinkSpec clean = netkf::apply_link_keys(
      LinkSpec{}, {word("model", "gilbert_elliott"), num("loss", 0.0), num("mean_burst", 5.0)});
  const LinkSpec lossy = netkf::apply_link_keys(clean, {num("loss", 0.2)});
  EXPECT_NEAR(netkf::mean_burst_length(lossy.loss), 5.0, 1e-12);
}

TEST(LinkType, RefusalsNameTheKeyAndTheReason) {
  const LinkSpec bernoulli(BernoulliLink{0.3});
  const LinkSpec chain(GilbertElliottLink{0.1, 0.3, 0.02, 0.7});
  const LinkSpec user = netkf::apply_link_keys(
      LinkSpec{}, {word("model", "gilbert_elliott"), num("loss", 0.2), num("mean_burst", 5.0)});
  const LinkKey ge_model = word("model", "gilbert_elliott");
  struct Case {
    const char* what;
    LinkSpec current;
    LinkKeys keys;
    std::string key;
    std::string words;
  };
  const std::vector<Case> cases = {
      // the user form
      {"L = 1", bernoulli, {ge_model, num("loss", 1.0), num("mean_burst", 3.0)}, "loss", "loss must be below 1"},
      {"L > 1", bernoulli, {ge_model, num("loss", 1.5), num("mean_burst", 3.0)}, "loss",
       "loss must be a probability in [0, 1], got 1.5"},
      {"L = 1 partial", user, {num("loss", 1.0)}, "loss", "loss must be below 1"},
      {"B < 1", bernoulli, {ge_model, num("loss", 0.2), num("mean_burst", 0.5)}, "mean_burst",
       "mean_burst must be a finite number >= 1"},
      {"B < 1 partial", user, {num("mean_burst", 0.99)}, "mean_burst", "mean_burst must be a finite number >= 1"},
      {"L > B/(B+1)", bernoulli, {ge_model, num("loss", 0.9), num("mean_burst", 2.0)}, "loss",
       "a mean burst of 2 allows a loss of at most 0.666667"},
      {"L > B/(B+1) partial", user, {num("loss", 0.9)}, "loss", "a mean burst of 5 allows a loss of at most 0.833333"},
      // the forms do not mix
      {"mix p", bernoulli, {ge_model, num("loss", 0.2), num("mean_burst", 5.0), num("p", 0.1)}, "p", "not both"},
      {"mix r", chain, {num("loss", 0.2), num("r", 0.3)}, "r", "not both (r given with loss)"},
      {"mix loss_bad", chain, {num("mean_burst", 3.0), num("loss_bad", 0.5)}, "loss_bad",
       "not both (loss_bad given with mean_burst)"},
      // the chain
      {"p = r = 0", bernoulli, {ge_model, num("p", 0.0), num("r", 0.0)}, "p", "p and r cannot both be 0"},
      {"p = r = 0 partial", chain, {num("p", 0.0), num("r", 0.0)}, "p", "p and r cannot both be 0"},
      {"p > 1", chain, {num("p", 1.01)}, "p", "p must be a probability in [0, 1], got 1.01"},
      {"r < 0", chain, {num("r", -0.1)}, "r", "r must be a probability in [0, 1], got -0.1"},
      {"loss_bad > 1", chain, {num("loss_bad", 1.5)}, "loss_bad", "loss_bad must be a probability"},
      {"loss_good < 0", chain, {num("loss_good", -0.5)}, "loss_good", "loss_good must be a probability"},
      {"bernoulli loss > 1", bernoulli, {num("loss", 1.2)}, "loss", "loss must be a probability in [0, 1], got 1.2"},
      // keys of the other model
      {"p on bernoulli", bernoulli, {num("p", 0.1)}, "p",
       "p is a gilbert_elliott key; a bernoulli link has only loss (give model: gilbert_elliott to change the model)"},
      {"mean_burst on bernoulli", bernoulli, {num("mean_burst", 3.0)}, "mean_burst", "is a gilbert_elliott key"},
      {"r with model bernoulli", chain, {word("model", "bernoulli"), num("loss", 0.1), num("r", 0.2)}, "r",
       "r is a gilbert_elliott key; a bernoulli link has only loss"},
      // names
      {"unknown key", bernoulli, {num("burst", 3.0)}, "burst",
       "unknown link key 'burst' (expected one of: model, loss, p, r, loss_good, loss_bad, mean_burst, trace, loop, "
       "offset, delay_ms, jitter_ms, delay_distribution)"},
      {"duplicate key", bernoulli, {num("loss", 0.1), num("loss", 0.2)}, "loss", "link key 'loss' given twice"},
      {"unknown model", bernoulli, {word("model", "markov"), num("loss", 0.1)}, "model",
       "unknown link model 'markov' (expected bernoulli, gilbert_elliott or trace)"},
      {"unknown distribution", bernoulli, {word("delay_distribution", "gaussian")}, "delay_distribution",
       "unknown delay_distribution 'gaussian'"},
      // words and numbers
      {"model as number", bernoulli, {num("model", 1.0)}, "model", "model must be a name (bernoulli, gilbert_elliott or trace)"},
      {"distribution as number", bernoulli, {num("delay_distribution", 2.0)}, "delay_distribution",
       "delay_distribution must be a name (uniform, normal, pareto or paretonormal)"},
      {"loss as word", bernoulli, {word("loss", "high")}, "loss", "loss must be a number, got 'high'"},
      {"delay as word", bernoulli, {word("delay_ms", "5ms")}, "delay_ms", "delay_ms must be a number, got '5ms'"},
      // not finite
      {"NaN loss", bernoulli, {num("loss", kNaN)}, "loss", "loss must be a finite number"},
      {"inf p", chain, {num("p", kInf)}, "p", "p must be a finite number"},
      {"-inf delay", bernoulli, {num("delay_ms", -kInf)}, "delay_ms", "delay_ms must be a finite number"},
      {"NaN jitter", bernoulli, {num("jitter_ms", kNaN)}, "jitter_ms", "jitter_ms must be a finite number"},
      // delays
      {"negative delay", bernoulli, {num("delay_ms", -1.0)}, "delay_ms", "delay_ms must be in [0, 60000] ms, got -1"},
      {"negative jitter", bernoulli, {num("jitter_ms", -0.5)}, "jitter_ms", "jitter_ms must be in [0, 60000] ms"},
      {"delay above a minute", bernoulli, {num("delay_ms", 60000.5)}, "delay_ms", "delay_ms must be in [0, 60000] ms"},
      {"jitter above a minute", chain, {num("jitter_ms", 1e9)}, "jitter_ms", "jitter_ms must be in [0, 60000] ms"},
  };
  for (const Case& c : cases) {
    const Refusal r = refusal_of(c.current, c.keys);
    EXPECT_EQ(r.key, c.key) << c.what << ": " << r.message;
    EXPECT_THAT(r.message, HasSubstr(c.words)) << c.what;
  }
  // The limits themselves are accepted.
  EXPECT_NO_THROW((void)netkf::apply_link_keys(bernoulli, {num("delay_ms", 60000.0), num("jitter_ms", 60000.0)}));
  EXPECT_NO_THROW((void)netkf::apply_link_keys(bernoulli, {num("delay_ms", 0.0), num("jitter_ms", 0.0)}));
  EXPECT_NO_THROW((void)netkf::apply_link_keys(chain, {num("p", 0.0)}));  // r > 0: still moves
}

TEST(LinkType, ErrorsAreSaidAtTheirKeyPath) {
  const Refusal bad_loss = refusal_of(LinkSpec{}, {num("loss", 2.0)});
  try {
    (void)netkf::apply_link_keys(LinkSpec{}, {num("loss", 2.0)});
    ADD_FAILURE() << "loss 2 accepted";
  } catch (const LinkError& e) {
    // A message that starts with its key continues the path; any other follows a colon.
    EXPECT_EQ(netkf::link_error_at("sensors[0].link", e), "sensors[0].link." + bad_loss.message);
  }
  try {
    (void)netkf::apply_link_keys(LinkSpec{}, {num("lost", 0.5)});
    ADD_FAILURE() << "key 'lost' accepted";
  } catch (const LinkError& e) {
    EXPECT_THAT(netkf::link_error_at("events[2].set", e), StartsWith("events[2].set: unknown link key 'lost'"));
  }
}

std::vector<LinkSpec> sample_links() {
  return {
      LinkSpec{},
      LinkSpec(BernoulliLink{0.3}),
      LinkSpec(BernoulliLink{1.0}, LinkDelay{6.0, 4.0, DelayDistribution::uniform}),
      LinkSpec(BernoulliLink{0.1 + 0.2}, LinkDelay{1.0 / 3.0, 0.1 + 0.2, DelayDistribution::normal}),
      LinkSpec(GilbertElliottLink{0.1, 0.3, 0.02, 0.7}, LinkDelay{5.0, 2.0, DelayDistribution::pareto}),
      LinkSpec(GilbertElliottLink{0.05, 0.2, 0.0, 1.0}, LinkDelay{0.0, 3.0, DelayDistribution::paretonormal}),
      LinkSpec(GilbertElliottLink{1.0, 0.0, 0.0, 1.0}),
      netkf::apply_link_keys(LinkSpec{}, {word("model", "gilbert_elliott"), num("loss", 0.123), num("mean_burst", 3.7),
                                          num("delay_ms", 60000.0)}),
  };
}

TEST(LinkType, LinkKeysRebuildTheLinkFromAnywhere) {
  const std::vector<LinkSpec> links = sample_links();
  for (const LinkSpec& l : links) {
    const LinkKeys keys = netkf::link_keys(l);
    SCOPED_TRACE(netkf::describe_link(l));
    // The whole link: model first, then its parameters, then the three delay keys.
    ASSERT_GE(keys.size(), 5u);
    EXPECT_EQ(keys.front(), word("model", netkf::link_model_name(l.loss)));
    EXPECT_EQ(keys[keys.size() - 3], num("delay_ms", l.delay.delay_ms));
    EXPECT_EQ(keys[keys.size() - 2], num("jitter_ms", l.delay.jitter_ms));
    EXPECT_EQ(keys.back(), word("delay_distribution", netkf::delay_distribution_name(l.delay.distribution)));
    for (const LinkSpec& start : links) EXPECT_EQ(netkf::apply_link_keys(start, keys), l);
    EXPECT_EQ(netkf::link_from_keys(keys), l);
  }
}

TEST(LinkType, EachModelHasANameAndALabelAPageShows) {
  // The pages read the labels from the channel catalogue: one per model, as a person writes it.
  std::vector<std::pair<std::string, std::string>> seen;
  for (const netkf::LinkModel& model : netkf::one_link_of_each_model())
    seen.emplace_back(netkf::link_model_name(model), netkf::link_model_label(model));
  EXPECT_EQ(seen, (std::vector<std::pair<std::string, std::string>>{{"bernoulli", "Bernoulli"},
                                                                     {"gilbert_elliott", "Gilbert-Elliott"}}));
}

TEST(LinkType, LinkKeyValueReadsEveryNumericKey) {
  const LinkSpec bernoulli(BernoulliLink{0.3}, LinkDelay{5.0, 2.0, DelayDistribution::normal});
  EXPECT_EQ(netkf::link_key_value(bernoulli, "loss"), 0.3);
  EXPECT_EQ(netkf::link_key_value(bernoulli, "delay_ms"), 5.0);
  EXPECT_EQ(netkf::link_key_value(bernoulli, "jitter_ms"), 2.0);
  for (const char* k : {"p", "r", "loss_good", "loss_bad", "mean_burst"}) {
    try {
      (void)netkf::link_key_value(bernoulli, k);
      ADD_FAILURE() << k << " has a value on a bernoulli link";
    } catch (const LinkError& e) {
      EXPECT_EQ(e.key(), k);
      EXPECT_THAT(e.what(), HasSubstr("does not apply to a bernoulli link"));
    }
  }
  for (const char* k : {"model", "delay_distribution"}) {
    try {
      (void)netkf::link_key_value(bernoulli, k);
      ADD_FAILURE() << k << " has a numeric value";
    } catch (const LinkError& e) {
      EXPECT_EQ(e.key(), k);
      EXPECT_THAT(e.what(), HasSubstr("is a name, not a number"));
    }
  }
  EXPECT_THROW((void)netkf::link_key_value(bernoulli, "bogus"), LinkError);

  const GilbertElliottLink g{0.1, 0.3, 0.02, 0.7};
  const LinkSpec chain(g, LinkDelay{1.0, 0.5, DelayDistribution::pareto});
  const ChainStats expected = chain_stats(g);
  EXPECT_EQ(netkf::link_key_value(chain, "p"), 0.1);
  EXPECT_EQ(netkf::link_key_value(chain, "r"), 0.3);
  EXPECT_EQ(netkf::link_key_value(chain, "loss_good"), 0.02);
  EXPECT_EQ(netkf::link_key_value(chain, "loss_bad"), 0.7);
  EXPECT_EQ(netkf::link_key_value(chain, "delay_ms"), 1.0);
  EXPECT_EQ(netkf::link_key_value(chain, "jitter_ms"), 0.5);
  // The user's form of any chain: its stationary loss and mean burst.
  EXPECT_NEAR(netkf::link_key_value(chain, "loss"), (0.3 * 0.02 + 0.1 * 0.7) / 0.4, 1e-15);
  EXPECT_NEAR(netkf::link_key_value(chain, "loss"), expected.loss, 1e-15);
  EXPECT_NEAR(netkf::link_key_value(chain, "mean_burst"), expected.mean_burst, 1e-12);
  // The simple Gilbert channel: p/(p + r) and 1/r.
  const LinkSpec simple(GilbertElliottLink{0.05, 0.2, 0.0, 1.0});
  EXPECT_NEAR(netkf::link_key_value(simple, "loss"), 0.05 / 0.25, 1e-15);
  EXPECT_NEAR(netkf::link_key_value(simple, "mean_burst"), 5.0, 1e-12);
}

// ======================================================================================
// Stationary statistics against simulation (LinkLossProcess + LinkStatistics).

TEST(LinkStationary, BothFormsMatchASimulation) {
  constexpr int kSamples = 200000;
  const std::vector<netkf::LinkModel> models = {
      BernoulliLink{0.3},
      GilbertElliottLink{0.1, 0.3, 0.02, 0.7},    // chain form, leaky states
      GilbertElliottLink{0.02, 0.25, 0.05, 0.9},  // chain form, rare bad spells
      netkf::apply_link_keys(LinkSpec{}, {word("model", "gilbert_elliott"), num("loss", 0.2), num("mean_burst", 5.0)}).loss,
      netkf::apply_link_keys(LinkSpec{}, {word("model", "gilbert_elliott"), num("loss", 0.05), num("mean_burst", 2.0)}).loss,
  };
  std::uint64_t index = 0;
  for (const auto& model : models) {
    SCOPED_TRACE(netkf::describe_link_model(model));
    netkf::LinkLossProcess process(model, netkf::derive_seed(2024, "test-link-stationary", index++));
    Observed seen;
    for (int i = 0; i < kSamples; ++i) seen.record(process.next_dropped());
    ASSERT_EQ(seen.stats.samples(), static_cast<std::uint64_t>(kSamples));

    const double loss = netkf::stationary_loss(model);
    EXPECT_NEAR(seen.stats.observed_loss(), loss, 5.0 * loss_fraction_se(model, kSamples));

    // LinkStatistics counts an open final burst too; the completed ones are enough here.
    const double burst = netkf::mean_burst_length(model);
    const Estimate b = batch_means(seen.bursts, 20);
    EXPECT_NEAR(seen.stats.mean_burst_length(), burst, 5.0 * b.se);
    EXPECT_NEAR(b.mean, burst, 5.0 * b.se);
    EXPECT_LT(b.se, 0.03 * burst);  // the comparison means something
    if (const auto* g = std::get_if<GilbertElliottLink>(&model)) {
      EXPECT_NEAR(loss, chain_stats(*g).loss, 1e-14);
      EXPECT_NEAR(burst, chain_stats(*g).mean_burst, 1e-12);
    }
  }
}

// ======================================================================================
// Delay distributions.

std::vector<LinkDelay> sample_delays() {
  return {
      {6.0, 4.0, DelayDistribution::uniform},
      {5.0, 2.0, DelayDistribution::normal},
      {5.0, 2.0, DelayDistribution::pareto},
      {5.0, 2.0, DelayDistribution::paretonormal},
  };
}

TEST(LinkDelays, CdfsMatchTheirClosedForms) {
  const std::vector<LinkDelay> delays = {
      {6.0, 4.0, DelayDistribution::uniform},  {2.0, 4.0, DelayDistribution::uniform},
      {5.0, 2.0, DelayDistribution::normal},   {1.0, 2.0, DelayDistribution::normal},
      {5.0, 2.0, DelayDistribution::pareto},   {0.5, 3.0, DelayDistribution::pareto},
      {20.0, 7.5, DelayDistribution::pareto},
  };
  for (const LinkDelay& d : delays) {
    SCOPED_TRACE(netkf::delay_distribution_name(d.distribution) + " " + std::to_string(d.delay_ms) + "±" +
                 std::to_string(d.jitter_ms));
    for (double t = -2.0; t <= 60.0; t += 0.25)
      EXPECT_NEAR(netkf::probability_within(d, t), closed_form_cdf(d, t), 1e-12) << "deadline " << t;
  }
  // Spot values worked by hand.
  EXPECT_DOUBLE_EQ(netkf::probability_within({6.0, 4.0, DelayDistribution::uniform}, 8.0), 0.75);
  EXPECT_NEAR(netkf::probability_within({5.0, 2.0, DelayDistribution::normal}, 7.0), 0.8413447460685429, 1e-15);
  // Pareto: z = 1 gives 1 - 2.25^-3; the smallest value is delay - (2/3) jitter.
  EXPECT_NEAR(netkf::probability_within({5.0, 2.0, DelayDistribution::pareto}, 7.0), 1.0 - 1.0 / (2.25 * 2.25 * 2.25),
              1e-15);
  EXPECT_EQ(netkf::probability_within({5.0, 3.0, DelayDistribution::pareto}, 2.999), 0.0);
  // ... and the largest delay + jitter·32767/8192 (netem's table limit).
  EXPECT_EQ(netkf::probability_within({5.0, 2.0, DelayDistribution::pareto}, 5.0 + 2.0 * kTableLimit), 1.0);
  EXPECT_LT(netkf::probability_within({5.0, 2.0, DelayDistribution::pareto}, 5.0 + 2.0 * kTableLimit - 1e-9),
            1.0 - 1.0 / 92.0);
  // No jitter: a step at the delay.
  EXPECT_EQ(netkf::probability_within({6.0, 0.0, DelayDistribution::normal}, 5.999), 0.0);
  EXPECT_EQ(netkf::probability_within({6.0, 0.0, DelayDistribution::normal}, 6.0), 1.0);
}

TEST(LinkDelays, QuantileIsTheInverseOfTheCdf) {
  for (const LinkDelay& d0 : sample_delays()) {
    // Far from 0, so the cut at 0 plays no part.
    const LinkDelay d{100.0, d0.jitter_ms, d0.distribution};
    SCOPED_TRACE(netkf::delay_distribution_name(d.distribution));
    for (const double q : {0.001, 0.01, 0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 0.98}) {
      const double x = netkf::delay_quantile(d, q);
      EXPECT_NEAR(netkf::probability_within(d, x), q, 1e-9) << q;
      if (d.distribution != DelayDistribution::paretonormal) {
        EXPECT_NEAR(closed_form_cdf(d, x), q, 1e-12) << q;
      }
    }
  }
  // Quantiles by hand: uniform is linear, pareto's median is (4/3)(2^(1/3) - 3/2).
  EXPECT_DOUBLE_EQ(netkf::delay_quantile({6.0, 4.0, DelayDistribution::uniform}, 0.25), 4.0);
  EXPECT_NEAR(netkf::delay_quantile({5.0, 2.0, DelayDistribution::pareto}, 0.5),
              5.0 + 2.0 * (4.0 / 3.0) * (std::cbrt(2.0) - 1.5), 1e-14);
  EXPECT_NEAR(netkf::delay_quantile({5.0, 2.0, DelayDistribution::normal}, 0.975), 5.0 + 2.0 * 1.959963984540054, 1e-12);
  // Pareto: capped at netem's table limit.
  EXPECT_EQ(netkf::delay_quantile({5.0, 2.0, DelayDistribution::pareto}, 0.999), 5.0 + 2.0 * kTableLimit);
}

// netem's paretonormal table: 0.25·normal + 0.75·pareto of the same table index, i.e. of
// the same quantile q. Here from the two other distributions' quantiles.
double paretonormal_from_parts(double delay, double jitter, double q) {
  const double zn = (netkf::delay_quantile({delay, jitter, DelayDistribution::normal}, q) - delay) / jitter;
  const double zp = (netkf::delay_quantile({delay, jitter, DelayDistribution::pareto}, q) - delay) / jitter;
  return delay + jitter * (0.25 * zn + 0.75 * zp);
}

TEST(LinkDelays, ParetonormalIsTheMixOfTheSameQuantile) {
  const double delay = 100.0, jitter = 10.0;  // far from 0: no cut
  for (const double q : {1e-4, 0.001, 0.01, 0.05, 0.1, 0.3, 0.5, 0.7, 0.9, 0.95, 0.98, 0.985}) {
    EXPECT_NEAR(netkf::delay_quantile({delay, jitter, DelayDistribution::paretonormal}, q),
                paretonormal_from_parts(delay, jitter, q), 1e-9)
        << q;
  }
  // Its mean is about the delay: the Pareto part has mean 0 but for netem's cap at
  // 32767/8192, which takes E[excess] = (4/3)/(2·4.5²) ≈ 0.033 jitter off it (0.75 of that
  // in the mix). Midpoint rule over q.
  const int steps = 1000000;
  double mean = 0.0;
  for (int i = 0; i < steps; ++i)
    mean += netkf::delay_quantile({delay, jitter, DelayDistribution::paretonormal}, (i + 0.5) / steps);
  mean /= steps;
  EXPECT_NEAR(mean, delay, 0.04 * jitter);
}

// netem's paretonormal.c caps the Pareto value at 32767 (Z at 32767/8192) *before* mixing:
// (normvalue + 3·min(parvalue, 32767))/4. Above q ≈ 0.989 (where the Pareto part passes the
// cap) mixing first would give larger delays than netem's: at q = 0.99, Z = 3.72, not 3.58.
TEST(LinkDelays, ParetonormalCapsTheParetoPartBeforeMixingAsNetemDoes) {
  const double delay = 100.0, jitter = 10.0;
  for (const double q : {0.99, 0.995, 0.999})
    EXPECT_NEAR(netkf::delay_quantile({delay, jitter, DelayDistribution::paretonormal}, q),
                paretonormal_from_parts(delay, jitter, q), 1e-9)
        << q;
}

TEST(LinkDelays, DrawsFollowTheCdfKolmogorovSmirnov) {
  constexpr int kDraws = 100000;
  const double bound = 1.63 / std::sqrt(static_cast<double>(kDraws));  // 1 % level
  std::uint64_t index = 0;
  for (const LinkDelay& d : sample_delays()) {
    SCOPED_TRACE(netkf::delay_distribution_name(d.distribution));
    const std::vector<double> x = draw_delays(d, netkf::derive_seed(99, "test-link-delay", index++), kDraws);
    EXPECT_LT(ks_distance(x, [&](double t) { return netkf::probability_within(d, t); }), bound);
    if (d.distribution != DelayDistribution::paretonormal) {
      EXPECT_LT(ks_distance(x, [&](double t) { return closed_form_cdf(d, t); }), bound);
    }
    EXPECT_GE(*std::min_element(x.begin(), x.end()), 0.0);
  }
}

TEST(LinkDelays, NegativeDrawsAreCutAtZero) {
  constexpr int kDraws = 200000;
  // delay < jitter: uniform on [-2, 6] puts 1/4 below 0; normal(1, 2) puts Φ(-1/2).
  const std::vector<std::pair<LinkDelay, double>> cases = {
      {{2.0, 4.0, DelayDistribution::uniform}, 0.25},
      {{1.0, 2.0, DelayDistribution::normal}, normal_cdf(-0.5)},
      {{1.0, 3.0, DelayDistribution::pareto}, pareto_cdf(-1.0 / 3.0)},
  };
  std::uint64_t index = 0;
  for (const auto& [d, p0] : cases) {
    SCOPED_TRACE(netkf::delay_distribution_name(d.distribution));
    EXPECT_NEAR(netkf::probability_within(d, 0.0), p0, 1e-12);
    EXPECT_EQ(netkf::probability_within(d, -1e-9), 0.0);
    const std::vector<double> x = draw_delays(d, netkf::derive_seed(5, "test-link-zero", index++), kDraws);
    const double zeros = static_cast<double>(std::count(x.begin(), x.end(), 0.0)) / kDraws;
    EXPECT_NEAR(zeros, p0, 5.0 * std::sqrt(p0 * (1.0 - p0) / kDraws));
    EXPECT_GE(*std::min_element(x.begin(), x.end()), 0.0);
  }
  // Without jitter: exactly the delay, and no delay at all is 0.
  netkf::LinkDelayProcess fixed(1);
  EXPECT_EQ(fixed.next_delay_ms({7.5, 0.0, DelayDistribution::normal}), 7.5);
  EXPECT_EQ(fixed.next_delay_ms({}), 0.0);
}

// ======================================================================================
// The effective loss model (late = lost).

TEST(LinkEffective, BernoulliIsThinnedByTheChanceToBeInTime) {
  const LinkSpec link(BernoulliLink{0.2}, LinkDelay{6.0, 2.0, DelayDistribution::normal});
  const double in_time = normal_cdf((8.0 - 6.0) / 2.0);
  const auto effective = netkf::effective_loss_model(link, 8.0);
  ASSERT_TRUE(std::holds_alternative<BernoulliLink>(effective));
  EXPECT_NEAR(std::get<BernoulliLink>(effective).loss, 1.0 - 0.8 * in_time, 1e-15);
  EXPECT_NEAR(netkf::effective_arrival_rate(link, 8.0), 0.8 * in_time, 1e-15);
  // No delay: the link itself. All late: everything lost.
  EXPECT_NEAR(std::get<BernoulliLink>(netkf::effective_loss_model(LinkSpec(BernoulliLink{0.2}), 8.0)).loss, 0.2, 1e-15);
  EXPECT_EQ(std::get<BernoulliLink>(netkf::effective_loss_model(LinkSpec(BernoulliLink{0.2}, {9.0, 0.0}), 8.0)).loss,
            1.0);
}

TEST(LinkEffective, GilbertElliottThinnedMatchesASimulationOfDropsDelaysAndDeadline) {
  constexpr int kSamples = 200000;
  const double deadline = 8.0;
  const std::vector<LinkSpec> links = {
      LinkSpec(GilbertElliottLink{0.1, 0.3, 0.02, 0.7}, LinkDelay{6.0, 4.0, DelayDistribution::uniform}),
      LinkSpec(GilbertElliottLink{0.05, 0.2, 0.0, 1.0}, LinkDelay{5.0, 2.0, DelayDistribution::pareto}),
      LinkSpec(BernoulliLink{0.1}, LinkDelay{6.0, 2.0, DelayDistribution::paretonormal}),
  };
  std::uint64_t index = 0;
  for (const LinkSpec& link : links) {
    SCOPED_TRACE(netkf::describe_link(link));
    const double in_time = netkf::probability_within(link.delay, deadline);
    const auto effective = netkf::effective_loss_model(link, deadline);
    if (const auto* g = std::get_if<GilbertElliottLink>(&link.loss)) {
      const auto& e = std::get<GilbertElliottLink>(effective);
      EXPECT_EQ(e.p, g->p);
      EXPECT_EQ(e.r, g->r);
      EXPECT_NEAR(e.loss_good, 1.0 - (1.0 - g->loss_good) * in_time, 1e-15);
      EXPECT_NEAR(e.loss_bad, 1.0 - (1.0 - g->loss_bad) * in_time, 1e-15);
    }
    // The channel: a loss draw per sample, a delay draw per delivered sample; late = lost.
    netkf::LinkLossProcess loss(link.loss, netkf::derive_seed(3, "test-link-effective", index));
    netkf::LinkDelayProcess delay(netkf::derive_seed(3, "test-link-effective-delay", index++));
    Observed seen;
    for (int i = 0; i < kSamples; ++i) {
      const bool dropped = loss.next_dropped();
      seen.record(dropped || delay.next_delay_ms(link.delay) > deadline);
    }
    const double delivered_in_time = 1.0 - seen.stats.observed_loss();
    EXPECT_NEAR(delivered_in_time, netkf::effective_arrival_rate(link, deadline),
                5.0 * loss_fraction_se(effective, kSamples));
    const Estimate b = batch_means(seen.bursts, 20);
    EXPECT_NEAR(b.mean, netkf::mean_burst_length(effective), 5.0 * b.se);
  }
}

}  // namespace
