// The verdict for a measured link (netkf/fit/link_verdict.hpp) on Sinopoli's scalar
// plant (A = -1.25), where the Markov criterion has closed forms: a simple Gilbert link is
// stable iff α²(1 − r) < 1 (Rohr-Marelli-Fu Thm 3.1; multi-sensor paper Thm 4/9), so the
// critical mean burst is 1/(1 − 1/α²) = 2.778 whatever the loss; an i.i.d. link iff
// α²·loss < 1 (Sinopoli Thm 3, λ_c = 1 − 1/α²), so the critical loss is 1/α² = 0.64.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "netkf/fit/link_verdict.hpp"
#include "netkf/links/loss_model.hpp"

namespace {

using netkf::fit::LossFamily;
using netkf::theory::Verdict;

constexpr double kAlpha2 = 1.25 * 1.25;

netkf::Scenario scalar_scenario() {
  return netkf::parse_scenario(R"(
name: scalar
period_ms: 10
plant: { A: [[-1.25]], Q: [[1.0]] }
sensors:
  - { id: 1, C: [[1.0]], R: [[2.5]], link: { model: bernoulli, loss: 0.0 } }
)",
                               "scalar.yaml");
}

std::vector<std::uint8_t> draw(const netkf::LinkModel& link, std::uint64_t seed, std::size_t n) {
  netkf::LinkLossProcess process(link, seed);
  std::vector<std::uint8_t> delivered(n);
  for (auto& d : delivered) d = process.next_dropped() ? 0 : 1;
  return delivered;
}

// The scenario with link 1 fitted to `trace` by `family`, and the verdict for it.
struct Judged {
  netkf::fit::LossFit fit;
  netkf::fit::MeasuredLinkVerdict verdict;
};
Judged judge(const std::vector<std::uint8_t>& trace, LossFamily family) {
  netkf::fit::LossFitOptions o;
  o.family = family;
  Judged j{netkf::fit::fit_loss_model(trace, o).fit(), {}};
  netkf::Scenario s = scalar_scenario();
  s.sensors[0].link = netkf::fit::fitted_link_spec(s.sensors[0].link, j.fit, std::nullopt);
  j.verdict = netkf::fit::measured_link_verdict(s, 1, j.fit);
  return j;
}

TEST(LinkVerdict, SimpleGilbertLinkHasTheClosedFormCriterionAndBurstMargin) {
  const auto j = judge(draw(netkf::GilbertElliottLink{0.2, 0.5, 0, 1}, 3, 20000), LossFamily::simple_gilbert);
  const double r = std::get<netkf::GilbertElliottLink>(j.fit.link).r;
  ASSERT_TRUE(j.verdict.criterion);
  EXPECT_NEAR(*j.verdict.criterion, kAlpha2 * (1.0 - r), 1e-9);
  EXPECT_EQ(j.verdict.stable, Verdict::yes);
  ASSERT_TRUE(j.verdict.burst_boundary.critical) << j.verdict.burst_boundary.text;
  EXPECT_NEAR(*j.verdict.burst_boundary.critical, 1.0 / (1.0 - 1.0 / kAlpha2), 1e-6);
  // The criterion does not depend on the loss here: no critical loss up to B/(B + 1).
  EXPECT_FALSE(j.verdict.loss_boundary.critical) << j.verdict.loss_boundary.text;
  EXPECT_NE(j.verdict.across_interval.find("stable across"), std::string::npos) << j.verdict.across_interval;
  EXPECT_EQ(j.verdict.interval_corners.size(), 4u);
}

TEST(LinkVerdict, BernoulliLinkHasSinopolisCriticalLoss) {
  const auto j = judge(draw(netkf::BernoulliLink{0.3}, 4, 20000), LossFamily::bernoulli);
  const double loss = std::get<netkf::BernoulliLink>(j.fit.link).loss;
  ASSERT_TRUE(j.verdict.criterion);
  EXPECT_NEAR(*j.verdict.criterion, kAlpha2 * loss, 1e-9);
  ASSERT_TRUE(j.verdict.loss_boundary.critical) << j.verdict.loss_boundary.text;
  EXPECT_NEAR(*j.verdict.loss_boundary.critical, 1.0 / kAlpha2, 1e-6);
  // At the fitted loss, a simple Gilbert link of mean burst B has r = 1/B: critical B = 2.778.
  ASSERT_TRUE(j.verdict.burst_boundary.critical) << j.verdict.burst_boundary.text;
  EXPECT_NEAR(*j.verdict.burst_boundary.critical, 1.0 / (1.0 - 1.0 / kAlpha2), 1e-6);
}

TEST(LinkVerdict, UnstableLinkNeedsLessLossAndTheIntervalSaysSo) {
  const auto j = judge(draw(netkf::BernoulliLink{0.8}, 5, 20000), LossFamily::bernoulli);
  EXPECT_EQ(j.verdict.stable, Verdict::no);
  ASSERT_TRUE(j.verdict.loss_boundary.critical);
  EXPECT_NEAR(*j.verdict.loss_boundary.critical, 1.0 / kAlpha2, 1e-6);
  EXPECT_NE(j.verdict.loss_boundary.text.find("needs loss below"), std::string::npos) << j.verdict.loss_boundary.text;
  EXPECT_NE(j.verdict.across_interval.find("unstable across"), std::string::npos) << j.verdict.across_interval;
}

TEST(LinkVerdict, ALinkAtTheBoundaryIsUndecidedWithinItsInterval) {
  // r = 0.36 is the boundary: the fit's interval for the mean burst straddles 1/0.36.
  const auto j = judge(draw(netkf::GilbertElliottLink{0.1, 0.36, 0, 1}, 6, 20000), LossFamily::simple_gilbert);
  EXPECT_NE(j.verdict.across_interval.find("undecided within"), std::string::npos) << j.verdict.across_interval;
}

TEST(LinkVerdict, UnknownLinkIdIsRefused) {
  const netkf::fit::LossFit fit = netkf::fit::fit_loss_model(std::vector<std::uint8_t>{1, 0, 1}).fit();
  EXPECT_THROW(netkf::fit::measured_link_verdict(scalar_scenario(), 9, fit), std::invalid_argument);
}

}  // namespace
