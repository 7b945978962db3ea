// Loss models: closed forms of the stationary loss and mean burst length, the
// empirical statistics of long seeded runs against them (within 4 standard
// errors, batch means for the Markov chain), reproducibility, set_model semantics
// and LinkStatistics bookkeeping.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "netkf/links/link_statistics.hpp"
#include "netkf/links/loss_model.hpp"

namespace {

using netkf::BernoulliLink;
using netkf::GilbertElliottLink;
using netkf::LinkLossProcess;
using netkf::LinkModel;
using netkf::LinkStatistics;

// Mean and standard error by non-overlapping batch means: valid for the correlated
// output of an ergodic Markov chain when batches are much longer than its mixing time.
struct Estimate {
  double mean;
  double se;
};
Estimate batch_means(const std::vector<double>& values, int batches) {
  const std::size_t size = values.size() / static_cast<std::size_t>(batches);
  std::vector<double> means;
  for (int b = 0; b < batches; ++b) {
    double s = 0.0;
    for (std::size_t i = 0; i < size; ++i) s += values[static_cast<std::size_t>(b) * size + i];
    means.push_back(s / static_cast<double>(size));
  }
  double m = 0.0;
  for (const double v : means) m += v;
  m /= batches;
  double var = 0.0;
  for (const double v : means) var += (v - m) * (v - m);
  var /= (batches - 1);
  return {m, std::sqrt(var / batches)};
}

struct LinkRun {
  std::vector<double> drops;          // 1 per dropped sample, 0 per delivered
  std::vector<double> burst_lengths;  // completed bursts of consecutive drops
  LinkStatistics stats;
};
LinkRun simulate(const LinkModel& model, std::uint64_t seed, int samples) {
  LinkLossProcess link(model, seed);
  LinkRun run;
  run.drops.reserve(static_cast<std::size_t>(samples));
  int current = 0;
  for (int i = 0; i < samples; ++i) {
    const bool dropped = link.next_dropped();
    run.stats.record(dropped);
    run.drops.push_back(dropped ? 1.0 : 0.0);
    if (dropped) {
      ++current;
    } else if (current > 0) {
      run.burst_lengths.push_back(current);
      current = 0;
    }
  }
  return run;
}

TEST(LossModel, ClosedForms) {
  EXPECT_DOUBLE_EQ(netkf::stationary_loss(BernoulliLink{0.4}), 0.4);
  EXPECT_DOUBLE_EQ(netkf::mean_burst_length(BernoulliLink{0.4}), 1.0 / 0.6);
  EXPECT_EQ(netkf::mean_burst_length(BernoulliLink{1.0}), std::numeric_limits<double>::infinity());
  // Gilbert channel (loss_good = 0, loss_bad = 1): bursts are the Bad sojourns, mean 1/r.
  const GilbertElliottLink gilbert{0.05, 0.5, 0.0, 1.0};
  EXPECT_DOUBLE_EQ(netkf::stationary_loss(gilbert), 0.05 / 0.55);
  EXPECT_NEAR(netkf::mean_burst_length(gilbert), 1.0 / 0.5, 1e-15);
  // General GE: (r loss_good + p loss_bad) / (p + r).
  const GilbertElliottLink ge{0.1, 0.3, 0.02, 0.7};
  EXPECT_NEAR(netkf::stationary_loss(ge), (0.3 * 0.02 + 0.1 * 0.7) / 0.4, 1e-15);
  // GE with equal losses in both states is Bernoulli.
  EXPECT_NEAR(netkf::mean_burst_length(GilbertElliottLink{0.2, 0.3, 0.25, 0.25}), 1.0 / 0.75, 1e-12);
  // p + r = 0: frozen in Good.
  EXPECT_DOUBLE_EQ(netkf::stationary_loss(GilbertElliottLink{0.0, 0.0, 0.1, 0.9}), 0.1);
  // Never delivers: stationary Bad with loss 1.
  EXPECT_EQ(netkf::mean_burst_length(GilbertElliottLink{1.0, 0.0, 0.0, 1.0}), std::numeric_limits<double>::infinity());
  EXPECT_EQ(netkf::link_model_name(BernoulliLink{}), "bernoulli");
  EXPECT_EQ(netkf::link_model_name(GilbertElliottLink{}), "gilbert_elliott");
}

TEST(LossModel, BernoulliEmpiricalMatchesTheory) {
  for (const double loss : {0.05, 0.4, 0.8}) {
    const LinkRun run = simulate(BernoulliLink{loss}, netkf::derive_seed(7, "test-bernoulli", static_cast<std::uint64_t>(loss * 100)), 400000);
    const double n = static_cast<double>(run.drops.size());
    EXPECT_NEAR(run.stats.observed_loss(), loss, 4.0 * std::sqrt(loss * (1 - loss) / n)) << "loss " << loss;
    // Burst lengths are i.i.d. geometric: mean 1/(1-q), variance q/(1-q)^2.
    double sum = 0.0;
    for (const double b : run.burst_lengths) sum += b;
    const double k = static_cast<double>(run.burst_lengths.size());
    const double se = std::sqrt(loss / ((1 - loss) * (1 - loss)) / k);
    EXPECT_NEAR(sum / k, netkf::mean_burst_length(BernoulliLink{loss}), 4.0 * se) << "loss " << loss;
  }
}

TEST(LossModel, GilbertElliottEmpiricalMatchesTheory) {
  const std::vector<GilbertElliottLink> sets = {
      {0.05, 0.5, 0.0, 1.0},   // Gilbert channel
      {0.1, 0.3, 0.02, 0.7},   // leaky good and bad states
      {0.3, 0.2, 0.1, 0.9},    // bad state dominant
      {0.01, 0.1, 0.0, 0.5},   // rare long bad spells, half lost
      {0.9, 0.8, 0.3, 0.6},    // fast switching
  };
  std::uint64_t index = 0;
  for (const auto& g : sets) {
    const LinkRun run = simulate(g, netkf::derive_seed(11, "test-ge", index++), 1000000);
    const Estimate loss = batch_means(run.drops, 50);
    EXPECT_NEAR(loss.mean, netkf::stationary_loss(g), 4.0 * loss.se)
        << "p=" << g.p << " r=" << g.r << " lg=" << g.loss_good << " lb=" << g.loss_bad;
    // Consecutive bursts are dependent through the chain state; batch means over bursts.
    const Estimate burst = batch_means(run.burst_lengths, 50);
    EXPECT_NEAR(burst.mean, netkf::mean_burst_length(g), 4.0 * burst.se)
        << "p=" << g.p << " r=" << g.r << " lg=" << g.loss_good << " lb=" << g.loss_bad;
    // The SE must be small enough for the comparison to mean something.
    EXPECT_LT(burst.se, 0.05 * netkf::mean_burst_length(g));
  }
}

TEST(LossModel, SameSeedSameSequenceDifferentSeedDifferent) {
  const LinkModel ge = GilbertElliottLink{0.1, 0.3, 0.02, 0.7};
  LinkLossProcess a(ge, 99);
  LinkLossProcess b(ge, 99);
  LinkLossProcess c(ge, 100);
  int differ = 0;
  for (int i = 0; i < 10000; ++i) {
    const bool da = a.next_dropped();
    ASSERT_EQ(da, b.next_dropped());
    differ += da != c.next_dropped() ? 1 : 0;
  }
  EXPECT_GT(differ, 100);
}

TEST(LossModel, ExtremeProbabilities) {
  LinkLossProcess never(BernoulliLink{0.0}, 1);
  LinkLossProcess always(BernoulliLink{1.0}, 1);
  for (int i = 0; i < 10000; ++i) {
    ASSERT_FALSE(never.next_dropped());
    ASSERT_TRUE(always.next_dropped());
  }
}

TEST(LossModel, SetModelKeepsGilbertElliottChainState) {
  // p = 1: the first transition goes Bad; r = 0: it never comes back.
  LinkLossProcess link(GilbertElliottLink{1.0, 0.0, 0.0, 1.0}, 5);
  EXPECT_EQ(link.chain_state(), LinkLossProcess::ChainState::good);
  EXPECT_TRUE(link.next_dropped());
  EXPECT_EQ(link.chain_state(), LinkLossProcess::ChainState::bad);
  // Retune p and r (r still 0): netem would reset to Good and deliver; we stay Bad.
  link.set_model(GilbertElliottLink{0.2, 0.0, 0.0, 1.0});
  EXPECT_EQ(link.chain_state(), LinkLossProcess::ChainState::bad);
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(link.next_dropped());
  // Retune so that Bad is left at the next sample: Good with loss_good = 0 delivers.
  link.set_model(GilbertElliottLink{0.0, 1.0, 0.0, 1.0});
  EXPECT_EQ(link.chain_state(), LinkLossProcess::ChainState::bad);
  EXPECT_FALSE(link.next_dropped());
  EXPECT_EQ(link.chain_state(), LinkLossProcess::ChainState::good);
}

TEST(LossModel, BernoulliToGilbertElliottStartsGood) {
  LinkLossProcess link(GilbertElliottLink{1.0, 0.0, 0.0, 1.0}, 5);
  link.next_dropped();
  ASSERT_EQ(link.chain_state(), LinkLossProcess::ChainState::bad);
  link.set_model(BernoulliLink{0.0});
  EXPECT_FALSE(link.next_dropped());
  link.set_model(GilbertElliottLink{0.0, 1.0, 0.0, 1.0});  // never leaves good
  EXPECT_EQ(link.chain_state(), LinkLossProcess::ChainState::good);
  EXPECT_FALSE(link.next_dropped());
}

TEST(LossModel, InvalidModelThrowsAndChangesNothing) {
  EXPECT_THROW(LinkLossProcess(BernoulliLink{1.5}, 1), std::invalid_argument);
  EXPECT_THROW(netkf::validate_link_model(BernoulliLink{std::nan("")}), std::invalid_argument);
  EXPECT_THROW(netkf::validate_link_model(GilbertElliottLink{0.1, -0.1, 0.0, 1.0}), std::invalid_argument);
  EXPECT_THROW(netkf::validate_link_model(GilbertElliottLink{0.1, 0.1, 0.0, 1.01}), std::invalid_argument);
  EXPECT_NO_THROW(netkf::validate_link_model(GilbertElliottLink{0.1, 0.1, 0.0, 1.0}));
  // p = r = 0: refused at run time as in a scenario file (one rule everywhere).
  EXPECT_THROW(netkf::validate_link_model(GilbertElliottLink{0.0, 0.0, 0.1, 0.9}), std::invalid_argument);

  const LinkModel original = GilbertElliottLink{1.0, 0.0, 0.0, 1.0};
  LinkLossProcess link(original, 3);
  link.next_dropped();
  try {
    link.set_model(GilbertElliottLink{0.5, 2.0, 0.0, 1.0});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find('r'), std::string::npos);
  }
  EXPECT_EQ(link.model(), original);
  EXPECT_EQ(link.chain_state(), LinkLossProcess::ChainState::bad);
}

TEST(LinkStatistics, CountsAndBursts) {
  LinkStatistics s;
  EXPECT_EQ(s.observed_loss(), 0.0);
  EXPECT_EQ(s.mean_burst_length(), 0.0);
  // delivered, drop drop, delivered, drop drop drop drop, delivered, drop (open burst)
  for (const bool d : {false, true, true, false, true, true, true, true, false, true}) s.record(d);
  EXPECT_EQ(s.samples(), 10u);
  EXPECT_EQ(s.dropped(), 7u);
  EXPECT_EQ(s.delivered(), 3u);
  EXPECT_EQ(s.bursts(), 3u);
  EXPECT_DOUBLE_EQ(s.observed_loss(), 0.7);
  EXPECT_DOUBLE_EQ(s.mean_burst_length(), 7.0 / 3.0);
}

}  // namespace
