// The sampled lim E[Tr P_{k|k-1}] (core/src/theory/sampled_covariance.hpp) against independent
// expectations: closed forms for a scalar plant whose sensor is (almost) noiseless, where
// P_{k|k-1} = q (1 + a² + … + a^{2J}) with J the number of losses just before k, so the mean
// is a sum over J's stationary law (derived in docs/validation.md, "Sampled mean covariance"):
//   Bernoulli (arrival rate λ):  P(J = j) = λ (1 − λ)^j
//   Gilbert-Elliott (loss 0 in Good, 1 in Bad; p = P(G→B), r = P(B→G), π_G = r / (p + r)):
//                                P(J = 0) = π_G,  P(J = j ≥ 1) = π_G p (1 − r)^{j−1}
// and, for vector plants with Bernoulli links, Sinopoli's bounds S̄ ≤ lim E[P] ≤ V̄ (Thm 4, 6).
#include <gtest/gtest.h>

#include <cmath>

#include "netkf/theory/report.hpp"
#include "sampled_covariance.hpp"  // theory/ private: the validation sees core/src/theory
#include "theory_systems.hpp"

namespace netkf::theory {
namespace {
using netkf::testing::mat;
using netkf::testing::sensor;
using netkf::testing::system;

constexpr double kNoiseless = 1e-10;  // R: P_{k|k} ≈ 0 after an arrival

// E[Tr P_{k|k-1}] = q Σ_j P(J = j) (a^{2(j+1)} − 1) / (a² − 1), with Σ_j P(J = j) a^{2(j+1)} given.
double closed_form(double a, double q, double weighted_growth) { return q * (weighted_growth - 1.0) / (a * a - 1.0); }

double bernoulli_closed_form(double a, double q, double lambda) {
  const double a2 = a * a;
  return closed_form(a, q, lambda * a2 / (1.0 - (1.0 - lambda) * a2));
}

double gilbert_closed_form(double a, double q, double p, double r) {
  const double a2 = a * a, good = r / (p + r);
  return closed_form(a, q, good * a2 + good * p * a2 * a2 / (1.0 - (1.0 - r) * a2));
}

SampledCovariance sample(const Scenario& s) {
  const auto got = sampled_expected_covariance(s.plant.A, s.plant.Q, s.plant.P0, s.sensors, s.seed);
  EXPECT_TRUE(got.has_value());
  return got.value_or(SampledCovariance{});
}

TEST(SampledCovariance, ScalarBernoulliMatchesItsClosedForm) {
  // (1 − λ) a⁴ < 1 as well, so Tr P has a finite variance and the standard error means something.
  const double a = 1.2, q = 1.0, lambda = 0.7;
  const auto s = system(mat({{a}}), mat({{q}}), {sensor(1, mat({{1.0}}), mat({{kNoiseless}}), BernoulliLink{1.0 - lambda})});
  const auto got = sample(s);
  const double want = bernoulli_closed_form(a, q, lambda);
  EXPECT_NEAR(got.trace_mean, want, 4.0 * got.standard_error + 1e-3 * want) << "standard error " << got.standard_error;
  EXPECT_LT(got.standard_error, 0.02 * want);
}

TEST(SampledCovariance, ScalarGilbertElliottMatchesItsClosedForm) {
  const double a = 1.2, q = 0.5, p = 0.1, r = 0.6;
  const auto s = system(mat({{a}}), mat({{q}}),
                        {sensor(1, mat({{1.0}}), mat({{kNoiseless}}), GilbertElliottLink{p, r, 0.0, 1.0})});
  const auto got = sample(s);
  const double want = gilbert_closed_form(a, q, p, r);
  EXPECT_NEAR(got.trace_mean, want, 4.0 * got.standard_error + 1e-3 * want) << "standard error " << got.standard_error;
  // Same stationary loss as Bernoulli 1 − π_G, but bursty: a larger mean covariance.
  EXPECT_GT(want, bernoulli_closed_form(a, q, r / (p + r)) * 1.05);
  EXPECT_GT(got.trace_mean, bernoulli_closed_form(a, q, r / (p + r)) * 1.05);
}

TEST(SampledCovariance, VectorPlantWithBernoulliLinksLiesBetweenTheBounds) {
  auto s = system(mat({{1.25, 0.1}, {0.0, 0.95}}), mat({{0.1, 0.0}, {0.0, 0.1}}),
                  {sensor(1, mat({{0.0, 1.0}}), mat({{0.5}}), BernoulliLink{0.2}),
                   sensor(2, mat({{1.0, 1.0}}), mat({{1.0}}), BernoulliLink{0.3})});
  const AnalysisReport bounds = analyze(s);
  ASSERT_TRUE(bounds.lower_trace && bounds.upper_trace);
  EXPECT_FALSE(bounds.sampled_trace) << "i.i.d. links have bounds: nothing is sampled";
  const auto got = sample(s);
  EXPECT_GT(got.trace_mean + 4.0 * got.standard_error, *bounds.lower_trace);
  EXPECT_LT(got.trace_mean - 4.0 * got.standard_error, *bounds.upper_trace);
}

TEST(SampledCovariance, AnalyzeReportsItForGilbertElliottLinksOnlyWhenStable) {
  const double a = 1.2, q = 0.5;
  auto stable = system(mat({{a}}), mat({{q}}),
                       {sensor(1, mat({{1.0}}), mat({{kNoiseless}}), GilbertElliottLink{0.1, 0.6, 0.0, 1.0})});
  const AnalysisReport r = analyze(stable);
  ASSERT_EQ(r.stable, Verdict::yes);
  ASSERT_TRUE(r.sampled_trace && r.sampled_trace_standard_error);
  EXPECT_FALSE(r.lower_trace || r.upper_trace);
  EXPECT_NEAR(*r.sampled_trace, gilbert_closed_form(a, q, 0.1, 0.6), 4.0 * *r.sampled_trace_standard_error + 1e-3);
  // The same scenario again: the same streams, the same number.
  EXPECT_EQ(analyze(stable).sampled_trace, r.sampled_trace);

  // a² (1 − r) ≥ 1: the Markov criterion says unstable (Rohr et al. Thm 3.1), nothing is sampled.
  auto unstable = system(mat({{a}}), mat({{q}}),
                         {sensor(1, mat({{1.0}}), mat({{kNoiseless}}), GilbertElliottLink{0.1, 0.2, 0.0, 1.0})});
  const AnalysisReport u = analyze(unstable);
  EXPECT_EQ(u.stable, Verdict::no);
  EXPECT_FALSE(u.sampled_trace);
}

TEST(SampledCovariance, ARunThatDivergesGivesNoEstimate) {
  const auto s = system(mat({{3.0}}), mat({{1.0}}), {sensor(1, mat({{1.0}}), mat({{1.0}}), BernoulliLink{1.0})});
  EXPECT_FALSE(sampled_expected_covariance(s.plant.A, s.plant.Q, s.plant.P0, s.sensors, s.seed));
}

}  // namespace
}  // namespace netkf::theory
