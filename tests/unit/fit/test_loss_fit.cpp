// Link traces and loss-model fits (netkf/links/link_trace.hpp, netkf/fit/loss_fit.hpp):
// the reader's refusals at FILE:LINE:COL; the fits against independent expectations: closed
// forms (counts, the binomial and Markov-chain standard errors), the likelihood by brute
// force over every hidden state path, run-length laws against netkf/links/link_statistics.hpp's stationary
// statistics, the chi-square tail against its closed form; and what `auto` concludes on
// i.i.d. and bursty traces from fixed seeds.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <sstream>
#include <vector>

#include "netkf/fit/loss_fit.hpp"
#include "netkf/fit/recent_loss_fit.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_trace.hpp"
#include "netkf/links/loss_model.hpp"

namespace {

using netkf::BernoulliLink;
using netkf::GilbertElliottLink;
using netkf::LinkModel;
using netkf::fit::LossFamily;
using netkf::fit::LossFitOptions;
using netkf::fit::fit_loss_model;

std::vector<std::uint8_t> draw(const LinkModel& link, std::uint64_t seed, std::size_t n) {
  netkf::LinkLossProcess process(link, seed);
  std::vector<std::uint8_t> delivered(n);
  for (auto& d : delivered) d = process.next_dropped() ? 0 : 1;
  return delivered;
}

netkf::LinkTrace parse(const std::string& text, std::size_t limit = netkf::max_trace_samples) {
  std::istringstream in(text);
  return netkf::read_link_trace(in, "t.csv", limit);
}

// The message of the TraceError that parsing `text` throws ("" when it does not throw).
std::string error_of(const std::string& text, std::size_t limit = netkf::max_trace_samples) {
  try {
    parse(text, limit);
  } catch (const netkf::TraceError& e) {
    return e.what();
  }
  return "";
}

const netkf::fit::FittedValue& param(const netkf::fit::LossFit& fit, const std::string& name) {
  for (const auto& p : fit.parameters)
    if (p.name == name) return p;
  throw std::out_of_range(name);
}

// ---- the trace reader -------------------------------------------------------------------

TEST(LinkTrace, ReadsCommentsBlankLinesCrLfAndDelays) {
  const auto t = parse("# made by hand\r\n\r\nk,delivered,delay_ms\r\n5,1,4.5\r\n6,0,\r\n  # a comment\n7, 1 ,0\n8,0,3\n");
  EXPECT_EQ(t.first_k, 5u);
  EXPECT_EQ(t.delivered, (std::vector<std::uint8_t>{1, 0, 1, 0}));
  ASSERT_TRUE(t.has_delay);
  EXPECT_DOUBLE_EQ(t.delay_ms[0], 4.5);
  EXPECT_TRUE(std::isnan(t.delay_ms[1]));
  EXPECT_DOUBLE_EQ(t.delay_ms[2], 0.0);
  EXPECT_TRUE(std::isnan(t.delay_ms[3]));  // a lost sample's delay is ignored
  EXPECT_EQ(t.delivered_count(), 2u);
  const auto plain = parse("k,delivered\n0,0\n1,1");  // no final newline
  EXPECT_FALSE(plain.has_delay);
  EXPECT_EQ(plain.delivered, (std::vector<std::uint8_t>{0, 1}));
}

TEST(LinkTrace, RefusesMalformedFilesAtLineAndColumn) {
  EXPECT_EQ(error_of("k,arrived\n0,1\n").rfind("t.csv:1:3: bad header: column 2 must be 'delivered'", 0), 0u)
      << error_of("k,arrived\n0,1\n");
  EXPECT_EQ(error_of("# c\nk,delivered,delay\n").rfind("t.csv:2:13: bad header", 0), 0u);
  EXPECT_EQ(error_of("k,delivered,delay_ms,x\n").rfind("t.csv:1:22: unexpected column 'x'", 0), 0u);
  EXPECT_EQ(error_of("k\n0\n").rfind("t.csv:1:2: bad header: missing column 'delivered'", 0), 0u);
  EXPECT_EQ(error_of("k,delivered\n0,1\n1,2\n").rfind("t.csv:3:3: delivered must be 0 or 1, got '2'", 0), 0u);
  EXPECT_EQ(error_of("k,delivered\n0,yes\n").rfind("t.csv:2:3: delivered must be 0 or 1", 0), 0u);
  EXPECT_EQ(error_of("k,delivered,delay_ms\n0,1,-1\n").rfind("t.csv:2:5: delay_ms must not be negative", 0), 0u);
  EXPECT_EQ(error_of("k,delivered,delay_ms\n0,1,nan\n").rfind("t.csv:2:5: delay_ms must be a finite number", 0), 0u);
  EXPECT_EQ(error_of("k,delivered,delay_ms\n0,1,inf\n").rfind("t.csv:2:5: delay_ms must be a finite number", 0), 0u);
  EXPECT_EQ(error_of("k,delivered,delay_ms\n0,1,4ms\n").rfind("t.csv:2:5: delay_ms must be a number", 0), 0u);
  EXPECT_EQ(error_of("k,delivered,delay_ms\n0,1,\n").rfind("t.csv:2:5: delay_ms is missing on a delivered", 0), 0u);
  EXPECT_EQ(error_of("k,delivered,delay_ms\n0,1\n").rfind("t.csv:2:4: missing field 'delay_ms'", 0), 0u);
  EXPECT_EQ(error_of("k,delivered\n0,1,3\n").rfind("t.csv:2:5: unexpected field '3'", 0), 0u);
  EXPECT_EQ(error_of("k,delivered\n0,1\n2,1\n").rfind("t.csv:3:1: k must count the samples: expected 1, got 2", 0), 0u);
  EXPECT_EQ(error_of("k,delivered\n-1,1\n").rfind("t.csv:2:1: k must be a non-negative integer", 0), 0u);
  EXPECT_EQ(error_of("k,delivered\n# nothing\n").rfind("t.csv:2:1: the trace has no samples", 0), 0u);
  EXPECT_EQ(error_of("").rfind("t.csv:1:1: missing header", 0), 0u);
  EXPECT_EQ(error_of("k,delivered\n0,1\n" + std::string(5000, ' ') + "\n").rfind("t.csv:3:4097: line longer", 0), 0u);
}

TEST(LinkTrace, RefusesMoreSamplesThanItsLimit) {
  EXPECT_EQ(error_of("k,delivered\n0,1\n1,0\n2,1\n", 3), "");
  EXPECT_EQ(error_of("k,delivered\n0,1\n1,0\n2,1\n3,1\n", 3).rfind("t.csv:5:1: the trace has more than 3 samples", 0), 0u);
  EXPECT_EQ(netkf::max_trace_samples, 10'000'000u);  // the limit docs/scenario-format.md states
}

// A UTF-8 byte-order mark before the header (some editors write one) is no part of it.
TEST(LinkTrace, AByteOrderMarkBeforeTheHeaderIsSkipped) {
  const auto t = parse("\xEF\xBB\xBFk,delivered\n0,1\n1,0\n");
  EXPECT_EQ(t.delivered, (std::vector<std::uint8_t>{1, 0}));
  // Another stray byte is named by its value, not echoed.
  EXPECT_EQ(error_of("\xFEk,delivered\n0,1\n").rfind("t.csv:1:1: bad header: column 1 must be 'k', got a field starting "
                                                    "with the byte 0xFE", 0), 0u)
      << error_of("\xFEk,delivered\n0,1\n");
  // A file of another kind: the offending word, not its line.
  const std::string passwd = error_of("root:x:0:0:root:/root:/bin/bash\n");
  EXPECT_NE(passwd.find("got 'root...'"), std::string::npos) << passwd;
  EXPECT_EQ(passwd.find("/bin/bash"), std::string::npos) << passwd;
}

TEST(LinkTrace, DevicesAreRefusedUnread) {
  for (const char* device : {"/dev/zero", "/dev/urandom"}) {
    try {
      netkf::read_link_trace_file(device);
      FAIL() << device;
    } catch (const netkf::TraceError& e) {
      EXPECT_EQ(std::string(e.what()), std::string(device) + ":1:1: is a character device, not a trace file (give a "
                                                             "regular file)");
    }
  }
}

TEST(LinkTrace, MissingFileIsAnErrorAtItsName) {
  try {
    netkf::read_link_trace_file("/nonexistent/trace.csv");
    FAIL();
  } catch (const netkf::TraceError& e) {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/trace.csv:1:1: cannot open trace file: No such file or directory");
  }
}

// ---- likelihood and laws -----------------------------------------------------------------

// log P(x) by summing over all 2^n hidden state paths: an independent implementation of
// the chain (stationary start; the chain moves, then the state drops with its loss).
double brute_force_log_likelihood(const std::vector<std::uint8_t>& delivered, const GilbertElliottLink& g) {
  const std::size_t n = delivered.size();
  const double pi_bad = g.p / (g.p + g.r);
  double total = 0.0;
  for (unsigned path = 0; path < (1u << n); ++path) {
    double prob = 1.0;
    for (std::size_t t = 0; t < n; ++t) {
      const bool bad = (path >> t) & 1u, was_bad = t > 0 && ((path >> (t - 1)) & 1u);
      prob *= t == 0 ? (bad ? pi_bad : 1.0 - pi_bad) : (was_bad ? (bad ? 1.0 - g.r : g.r) : (bad ? g.p : 1.0 - g.p));
      const double loss = bad ? g.loss_bad : g.loss_good;
      prob *= delivered[t] ? 1.0 - loss : loss;
    }
    total += prob;
  }
  return std::log(total);
}

TEST(LossFit, LikelihoodEqualsTheSumOverHiddenPaths) {
  const std::vector<std::uint8_t> trace = {1, 1, 0, 0, 1, 0, 1, 1, 1, 0, 0, 0};
  for (const GilbertElliottLink g : {GilbertElliottLink{0.1, 0.4, 0.05, 0.8}, GilbertElliottLink{0.3, 0.2, 0.0, 1.0},
                                     GilbertElliottLink{0.5, 0.5, 0.3, 0.3}}) {
    EXPECT_NEAR(netkf::fit::trace_log_likelihood(trace, g), brute_force_log_likelihood(trace, g), 1e-12);
  }
  const double m = 6, n = 12;  // Bernoulli: m ln l + (n − m) ln(1 − l)
  EXPECT_NEAR(netkf::fit::trace_log_likelihood(trace, BernoulliLink{0.3}),
              m * std::log(0.3) + (n - m) * std::log(0.7), 1e-12);
}

TEST(LossFit, RunLengthLawsMatchTheLinksStationaryStatistics) {
  // Bernoulli: geometric bursts; simple Gilbert: bursts geometric with parameter r.
  const auto b = netkf::fit::run_length_distribution(BernoulliLink{0.3}, true, 50);
  for (int L = 1; L <= 5; ++L) EXPECT_NEAR(b[L - 1], std::pow(0.3, L - 1) * 0.7, 1e-15);
  const auto sg = netkf::fit::run_length_distribution(GilbertElliottLink{0.1, 0.25, 0, 1}, true, 50);
  for (int L = 1; L <= 5; ++L) EXPECT_NEAR(sg[L - 1], std::pow(0.75, L - 1) * 0.25, 1e-15);
  // Gilbert-Elliott: the law's mean is link.cpp's mean_burst_length (a ratio of rates).
  const GilbertElliottLink ge{0.03, 0.2, 0.02, 0.7};
  const auto law = netkf::fit::run_length_distribution(ge, true, 100000);
  double mass = 0.0, mean = 0.0;
  for (std::size_t L = 1; L <= law.size(); ++L) {
    mass += law[L - 1];
    mean += static_cast<double>(L) * law[L - 1];
  }
  EXPECT_NEAR(mass, 1.0, 1e-9);
  EXPECT_NEAR(mean, netkf::mean_burst_length(ge), 1e-8);
  // Gaps: the mean run of deliveries is (1 − loss)/loss times the mean burst (runs alternate).
  const auto gaps = netkf::fit::run_length_distribution(ge, false, 100000);
  double gap_mean = 0.0;
  for (std::size_t L = 1; L <= gaps.size(); ++L) gap_mean += static_cast<double>(L) * gaps[L - 1];
  const double loss = netkf::stationary_loss(ge);
  EXPECT_NEAR(gap_mean, netkf::mean_burst_length(ge) * (1.0 - loss) / loss, 1e-6);
}

TEST(LossFit, RunLengthsLeaveOutTheCensoredEnds) {
  const std::vector<std::uint8_t> t = {0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 0};
  EXPECT_EQ(netkf::fit::run_lengths(t, true), (std::vector<std::size_t>{1, 3}));
  EXPECT_EQ(netkf::fit::run_lengths(t, false), (std::vector<std::size_t>{1, 2, 1}));
}

TEST(LossFit, ChiSquareTailMatchesItsClosedForms) {
  using netkf::fit::chi_square_upper_tail;
  EXPECT_NEAR(chi_square_upper_tail(3.841458820694124, 1), 0.05, 1e-12);
  for (double x : {0.5, 2.0, 7.0}) EXPECT_NEAR(chi_square_upper_tail(x, 2), std::exp(-x / 2), 1e-14);  // χ²(2)
  EXPECT_NEAR(chi_square_upper_tail(4.0, 4), std::exp(-2.0) * 3.0, 1e-14);  // e^{-x/2}(1 + x/2)
}

// ---- the closed forms ----------------------------------------------------------------------

TEST(LossFit, BernoulliIsTheDropFractionWithItsBinomialError) {
  const auto trace = draw(BernoulliLink{0.25}, 7, 10000);
  const double n = static_cast<double>(trace.size());
  const double m = n - static_cast<double>(std::accumulate(trace.begin(), trace.end(), 0));
  LossFitOptions o;
  o.family = LossFamily::bernoulli;
  const auto fit = fit_loss_model(trace, o).fit();
  const double l = m / n;
  EXPECT_DOUBLE_EQ(param(fit, "loss").value, l);
  // The numerical observed information reproduces sqrt(l(1 − l)/n).
  EXPECT_NEAR(*param(fit, "loss").stderr_value, std::sqrt(l * (1 - l) / n), 1e-4 * std::sqrt(l * (1 - l) / n));
  EXPECT_NEAR(fit.log_likelihood, m * std::log(l) + (n - m) * std::log(1 - l), 1e-6);
  EXPECT_NEAR(fit.aic, 2.0 - 2.0 * fit.log_likelihood, 1e-9);
  EXPECT_LT(*param(fit, "loss").ci_low, l);
  EXPECT_GT(*param(fit, "loss").ci_high, l);
}

TEST(LossFit, SimpleGilbertIsTheTransitionFrequencies) {
  const auto trace = draw(GilbertElliottLink{0.05, 0.3, 0, 1}, 11, 20000);
  double from_good = 0, good_to_bad = 0, from_bad = 0, bad_to_good = 0;
  for (std::size_t t = 1; t < trace.size(); ++t) {
    if (trace[t - 1]) {
      ++from_good;
      good_to_bad += trace[t] == 0;
    } else {
      ++from_bad;
      bad_to_good += trace[t] == 1;
    }
  }
  LossFitOptions o;
  o.family = LossFamily::simple_gilbert;
  const auto r = fit_loss_model(trace, o);
  const auto& fit = r.fit();
  const double p = good_to_bad / from_good, rr = bad_to_good / from_bad;
  EXPECT_DOUBLE_EQ(param(fit, "p").value, p);
  EXPECT_DOUBLE_EQ(param(fit, "r").value, rr);
  EXPECT_EQ(param(fit, "loss_good").value, 0.0);
  EXPECT_FALSE(param(fit, "loss_bad").free);
  // A Markov chain's transition frequencies: SE sqrt(p(1 − p)/n_from) (Anderson & Goodman 1957);
  // the stationary start term moves the observed information by O(1/n).
  EXPECT_NEAR(*param(fit, "p").stderr_value, std::sqrt(p * (1 - p) / from_good), 0.01 * std::sqrt(p * (1 - p) / from_good));
  EXPECT_NEAR(*param(fit, "r").stderr_value, std::sqrt(rr * (1 - rr) / from_bad), 0.01 * std::sqrt(rr * (1 - rr) / from_bad));
  EXPECT_EQ(std::get<GilbertElliottLink>(fit.link), (GilbertElliottLink{p, rr, 0.0, 1.0}));
  EXPECT_NEAR(fit.mean_burst.value, 1.0 / rr, 1e-12);
  EXPECT_EQ(r.why, "asked for");
}

// ---- what auto concludes ---------------------------------------------------------------------

TEST(LossFit, AnIidTraceIsNotCalledBursty) {
  // One fixed seed (the rate over 20 seeds is in validation/test_loss_fit_coverage.cpp):
  // auto picks bernoulli, and the 4-parameter chain, which contains it, gains less
  // log-likelihood than its 3 extra parameters cost in AIC.
  const auto r = fit_loss_model(draw(BernoulliLink{0.2}, 1, 20000));
  ASSERT_EQ(r.candidates.size(), 4u);
  EXPECT_EQ(r.fit().family, LossFamily::bernoulli) << r.why;
  EXPECT_NE(r.why.find("not bursty"), std::string::npos) << r.why;
  const auto& bernoulli = r.candidates[0];
  const auto& ge = r.candidates[3];
  ASSERT_EQ(ge.family, LossFamily::gilbert_elliott);
  EXPECT_GT(ge.aic, bernoulli.aic);
  EXPECT_GE(ge.log_likelihood, bernoulli.log_likelihood - 1e-6);  // nested: never a worse fit
}

TEST(LossFit, BurstyTracesPickAChainWithMemory) {
  const auto sg = fit_loss_model(draw(GilbertElliottLink{0.05, 0.3, 0, 1}, 21, 20000));
  EXPECT_NE(sg.fit().family, LossFamily::bernoulli) << sg.why;
  EXPECT_NE(sg.why.find("Bursty"), std::string::npos) << sg.why;
  // A Gilbert-Elliott link that drops in both states: only the 4-parameter family explains it.
  const auto ge = fit_loss_model(draw(GilbertElliottLink{0.03, 0.2, 0.02, 0.7}, 22, 20000));
  EXPECT_EQ(ge.fit().family, LossFamily::gilbert_elliott) << ge.why;
  // The bernoulli fit of a bursty trace fails its own burst-length test.
  ASSERT_TRUE(ge.candidates[0].bursts.p_value);
  EXPECT_LT(*ge.candidates[0].bursts.p_value, 1e-6);
}

TEST(LossFit, SameSeedSameFit) {
  const auto trace = draw(GilbertElliottLink{0.03, 0.2, 0.02, 0.7}, 5, 5000);
  LossFitOptions o;
  o.family = LossFamily::gilbert_elliott;
  const auto a = fit_loss_model(trace, o).fit(), b = fit_loss_model(trace, o).fit();
  EXPECT_EQ(a.link, b.link);
  EXPECT_EQ(a.log_likelihood, b.log_likelihood);
}

TEST(LossFit, DegenerateTracesFitBernoulliOnly) {
  const std::vector<std::uint8_t> all(100, 1);
  const auto r = fit_loss_model(all);
  ASSERT_EQ(r.candidates.size(), 1u);
  EXPECT_EQ(std::get<BernoulliLink>(r.fit().link).loss, 0.0);
  EXPECT_FALSE(r.notes.empty());
  LossFitOptions o;
  o.family = LossFamily::gilbert;
  EXPECT_THROW(fit_loss_model(all, o), std::invalid_argument);
  EXPECT_THROW(fit_loss_model(std::vector<std::uint8_t>{}), std::invalid_argument);
}

TEST(LossFit, DelaySummaryQuantilesInterpolateLikeNumPy) {
  const double nan = std::nan("");
  const std::vector<double> d = {4.0, nan, 1.0, 3.0, 2.0, nan};
  const auto s = netkf::fit::summarize_delays(d);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->samples, 4u);
  EXPECT_DOUBLE_EQ(s->mean_ms, 2.5);
  EXPECT_DOUBLE_EQ(s->jitter_ms, std::sqrt(5.0 / 3.0));
  EXPECT_DOUBLE_EQ(s->quantiles[3].second, 2.5);   // median: numpy.quantile([1,2,3,4], .5)
  EXPECT_DOUBLE_EQ(s->quantiles[2].second, 1.75);  // .25
  EXPECT_DOUBLE_EQ(s->quantiles[7].second, 4.0);   // max
  EXPECT_FALSE(netkf::fit::summarize_delays(std::vector<double>{nan}));
}

}  // namespace

// ---- the recent window (recent_loss_fit.hpp) against the batch fitter -----------------------

namespace {

using netkf::fit::RecentArrivals;

// The batch fitter's candidate of `family` for `delivered`.
netkf::fit::LossFit batch(const std::vector<std::uint8_t>& delivered, LossFamily family) {
  LossFitOptions o;
  o.family = family;
  return fit_loss_model(delivered, o).fit();
}

// Feeds `delivered` to a window of `window` samples and checks its fit against the batch
// fitter on the window's samples (the last `window` of them): the same parameters and
// log-likelihoods, and the same choice by loss_fit.cpp's AIC rule.
void expect_window_matches_batch(const std::vector<std::uint8_t>& delivered, std::size_t window) {
  RecentArrivals recent(window);
  for (const auto d : delivered) recent.record(d == 0);
  const std::vector<std::uint8_t> last(delivered.end() - static_cast<std::ptrdiff_t>(std::min(window, delivered.size())),
                                       delivered.end());
  const auto f = recent.fit();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->samples, last.size());
  const auto b = batch(last, LossFamily::bernoulli);
  const auto s = batch(last, LossFamily::simple_gilbert);
  ASSERT_TRUE(f->aic_gain.has_value());
  EXPECT_NEAR(*f->aic_gain, b.aic - s.aic, 1e-9 * std::abs(b.aic));
  const bool chain = s.aic < b.aic - 2.0;
  EXPECT_EQ(f->family, chain ? LossFamily::simple_gilbert : LossFamily::bernoulli);
  const auto& chosen = chain ? s : b;
  EXPECT_NEAR(f->loss(), chosen.loss.value, 1e-12);
  EXPECT_NEAR(f->mean_burst(), chosen.mean_burst.value, 1e-9 * chosen.mean_burst.value);
  if (chain) {
    const auto& g = std::get<GilbertElliottLink>(f->link);
    EXPECT_NEAR(g.p, param(s, "p").value, 1e-12);
    EXPECT_NEAR(g.r, param(s, "r").value, 1e-12);
  }
}

}  // namespace

TEST(RecentLossFit, WindowEqualsTheBatchFitOfItsSamples) {
  // Bursty and i.i.d. links, seeded; windows shorter than, equal to and longer than the input.
  const std::vector<LinkModel> links{GilbertElliottLink{0.05, 0.3, 0.0, 1.0}, GilbertElliottLink{0.1, 0.4, 0.05, 0.8},
                                     BernoulliLink{0.3}};
  for (std::size_t i = 0; i < links.size(); ++i) {
    const auto delivered = draw(links[i], 100 + i, 12000);
    for (const std::size_t window : {std::size_t{5000}, std::size_t{12000}, std::size_t{20000}}) {
      SCOPED_TRACE("link " + std::to_string(i) + ", window " + std::to_string(window));
      expect_window_matches_batch(delivered, window);
    }
  }
}

TEST(RecentLossFit, CallsABurstyLinkBurstyAndAnIidOneNot) {
  RecentArrivals bursty, iid;
  for (const auto d : draw(GilbertElliottLink{0.05, 0.25, 0.0, 1.0}, 7, 5000)) bursty.record(d == 0);
  for (const auto d : draw(BernoulliLink{0.2}, 7, 5000)) iid.record(d == 0);
  const auto b = bursty.fit();
  const auto i = iid.fit();
  ASSERT_TRUE(b && i);
  EXPECT_EQ(b->family, LossFamily::simple_gilbert);
  // mean burst 1/r = 4, stationary loss p/(p + r) = 1/6: within about 4 standard errors of 5000 samples.
  EXPECT_NEAR(b->mean_burst(), 4.0, 0.6);
  EXPECT_NEAR(b->loss(), 1.0 / 6.0, 0.03);
  EXPECT_EQ(i->family, LossFamily::bernoulli);
  EXPECT_NEAR(i->loss(), 0.2, 0.025);
}

TEST(RecentLossFit, DegenerateWindowsAndClear) {
  RecentArrivals recent(4);
  EXPECT_FALSE(recent.fit().has_value());
  for (int i = 0; i < 6; ++i) recent.record(true);  // only drops: bernoulli loss 1, endless bursts
  auto f = recent.fit();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->samples, 4u);
  EXPECT_EQ(f->family, LossFamily::bernoulli);
  EXPECT_FALSE(f->aic_gain.has_value());
  EXPECT_EQ(f->loss(), 1.0);
  EXPECT_TRUE(std::isinf(f->mean_burst()));
  recent.record(false);  // window: drop drop drop delivered
  f = recent.fit();
  EXPECT_EQ(f->dropped, 3u);
  EXPECT_FALSE(f->aic_gain.has_value());  // no transition out of "delivered" yet
  recent.clear();
  EXPECT_EQ(recent.samples(), 0u);
  EXPECT_FALSE(recent.fit().has_value());
  EXPECT_THROW(RecentArrivals(1), std::invalid_argument);

  // `1 0 0`: transitions out of both states, but the chain's p = 0 makes its stationary start
  // Good, so the first drop has probability 0 (log-likelihood −∞). No chain fit, no −∞ gain
  // (a link status carrying it was rejected as malformed by every reader).
  RecentArrivals first_only(10);
  for (const bool dropped : {true, false, false}) first_only.record(dropped);
  f = first_only.fit();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->family, LossFamily::bernoulli);
  EXPECT_FALSE(f->aic_gain.has_value());
  EXPECT_DOUBLE_EQ(f->loss(), 1.0 / 3.0);
}
