// Seeded random streams: known-answer values from an independent implementation
// (Python, written from the generators' published definitions), reproducibility,
// stream independence, and moments of the uniform and normal draws within 4 SE.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <set>
#include <vector>

#include "netkf/support/random.hpp"

namespace {

TEST(Random, Splitmix64MatchesPublishedSequenceFromZero) {
  // First outputs of splitmix64 seeded with 0 (Vigna's reference splitmix64.c).
  std::uint64_t state = 0;
  EXPECT_EQ(netkf::splitmix64(state), 0xe220a8397b1dcdafULL);
  EXPECT_EQ(netkf::splitmix64(state), 0x6e789e6aa1b965f4ULL);
  EXPECT_EQ(netkf::splitmix64(state), 0x06c45d188009454fULL);
}

TEST(Random, Xoshiro256PlusPlusMatchesIndependentImplementation) {
  // Seed 42 expanded by splitmix64, then xoshiro256++ (values from a Python port).
  netkf::Rng rng(42);
  EXPECT_EQ(rng.next_u64(), 0xd0764d4f4476689fULL);
  EXPECT_EQ(rng.next_u64(), 0x519e4174576f3791ULL);
  EXPECT_EQ(rng.next_u64(), 0xfbe07cfb0c24ed8cULL);
  EXPECT_EQ(rng.next_u64(), 0xb37d9f600cd835b8ULL);
  netkf::Rng again(42);
  EXPECT_DOUBLE_EQ(again.uniform(), 0.8143051451229099);  // top 53 bits of 0xd0764d4f4476689f
}

TEST(Random, SameSeedSameSequence) {
  netkf::Rng a(123456789);
  netkf::Rng b(123456789);
  for (int i = 0; i < 1000; ++i) {
    ASSERT_EQ(a.next_u64(), b.next_u64());
    ASSERT_EQ(a.uniform(), b.uniform());
    ASSERT_EQ(a.standard_normal(), b.standard_normal());
  }
}

TEST(Random, DifferentSeedsDiffer) {
  netkf::Rng a(1);
  netkf::Rng b(2);
  int equal = 0;
  for (int i = 0; i < 100; ++i) equal += a.next_u64() == b.next_u64() ? 1 : 0;
  EXPECT_EQ(equal, 0);
}

TEST(Random, DeriveSeedDependsOnAllInputs) {
  using netkf::derive_seed;
  const std::uint64_t base = derive_seed(42, "link", 1);
  EXPECT_EQ(base, derive_seed(42, "link", 1));  // deterministic
  EXPECT_NE(base, derive_seed(43, "link", 1));
  EXPECT_NE(base, derive_seed(42, "links", 1));
  EXPECT_NE(base, derive_seed(42, "sensor-noise", 1));
  EXPECT_NE(base, derive_seed(42, "link", 2));
  // Many (stream, index) pairs of one scenario give distinct seeds.
  std::set<std::uint64_t> seen;
  for (const char* stream : {"link", "sensor-noise", "process-noise", "monte-carlo"})
    for (std::uint64_t i = 0; i < 1000; ++i) seen.insert(derive_seed(7, stream, i));
  EXPECT_EQ(seen.size(), 4000u);
}

TEST(Random, DerivedStreamsAreUncorrelated) {
  // Two streams of one scenario: sample correlation of their uniforms is ~ N(0, 1/N).
  netkf::Rng a(netkf::derive_seed(42, "link", 1));
  netkf::Rng b(netkf::derive_seed(42, "link", 2));
  const int N = 200000;
  double sum = 0.0;
  for (int i = 0; i < N; ++i) sum += (a.uniform() - 0.5) * (b.uniform() - 0.5);
  const double corr = (sum / N) * 12.0;       // divide by Var U = 1/12
  EXPECT_LT(std::abs(corr), 4.0 / std::sqrt(N));
}

TEST(Random, UniformMomentsWithinFourStandardErrors) {
  netkf::Rng rng(netkf::derive_seed(2024, "test-uniform"));
  const int N = 1000000;
  double sum = 0.0;
  double sum_sq_dev = 0.0;
  double lo = 1.0;
  double hi = 0.0;
  for (int i = 0; i < N; ++i) {
    const double u = rng.uniform();
    sum += u;
    sum_sq_dev += (u - 0.5) * (u - 0.5);
    lo = std::min(lo, u);
    hi = std::max(hi, u);
  }
  EXPECT_GE(lo, 0.0);
  EXPECT_LT(hi, 1.0);
  // Mean 1/2, SE sqrt(1/12 / N). Var about the true mean: 1/12 with
  // Var[(U-1/2)^2] = 1/80 - 1/144 = 1/180, SE sqrt(1/180 / N).
  EXPECT_NEAR(sum / N, 0.5, 4.0 * std::sqrt(1.0 / 12.0 / N));
  EXPECT_NEAR(sum_sq_dev / N, 1.0 / 12.0, 4.0 * std::sqrt(1.0 / 180.0 / N));
}

TEST(Random, NormalMomentsWithinFourStandardErrors) {
  netkf::Rng rng(netkf::derive_seed(2024, "test-normal"));
  const int N = 1000000;
  double sum = 0.0;
  double sum_sq = 0.0;
  double sum_4 = 0.0;
  int beyond_two = 0;
  for (int i = 0; i < N; ++i) {
    const double z = rng.standard_normal();
    ASSERT_TRUE(std::isfinite(z));
    sum += z;
    sum_sq += z * z;
    sum_4 += z * z * z * z;
    beyond_two += std::abs(z) > 2.0 ? 1 : 0;
  }
  // Mean 0 (SE 1/sqrt N); E z^2 = 1 (Var z^2 = 2); E z^4 = 3 (Var z^4 = 105 - 9 = 96).
  EXPECT_NEAR(sum / N, 0.0, 4.0 / std::sqrt(N));
  EXPECT_NEAR(sum_sq / N, 1.0, 4.0 * std::sqrt(2.0 / N));
  EXPECT_NEAR(sum_4 / N, 3.0, 4.0 * std::sqrt(96.0 / N));
  // Tail: P(|Z| > 2) = erfc(2/sqrt 2).
  const double p2 = std::erfc(2.0 / std::sqrt(2.0));
  EXPECT_NEAR(static_cast<double>(beyond_two) / N, p2, 4.0 * std::sqrt(p2 * (1 - p2) / N));
}

// The ziggurat's tables against their definition (Marsaglia & Tsang 2000): every strip
// has the same area v, the base strip being the box [0, r] x [0, f(r)] plus the tail,
// whose area is the closed form sqrt(pi/2) erfc(r / sqrt 2).
TEST(Random, ZigguratStripsHaveEqualArea) {
  const auto& zig = netkf::detail::normal_ziggurat();
  constexpr int L = netkf::detail::NormalZiggurat::kLayers;
  const double r = zig.x[1];
  const double pi = std::acos(-1.0);
  const double v = r * std::exp(-0.5 * r * r) + std::sqrt(pi / 2.0) * std::erfc(r / std::sqrt(2.0));
  EXPECT_NEAR(zig.x[0] * std::exp(-0.5 * r * r), v, 1e-12 * v);  // virtual width of the base strip
  for (int i = 1; i < L; ++i) {
    ASSERT_GT(zig.x[i], zig.x[i + 1]) << "strip " << i;
    const double top = i + 1 == L ? 1.0 : std::exp(-0.5 * zig.x[i + 1] * zig.x[i + 1]);
    EXPECT_NEAR(zig.x[i] * (top - std::exp(-0.5 * zig.x[i] * zig.x[i])), v, 1e-9 * v) << "strip " << i;
    EXPECT_DOUBLE_EQ(zig.ratio[i], zig.x[i + 1] / zig.x[i]);
  }
  EXPECT_EQ(zig.x[L], 0.0);
}

// Standard normal CDF, independent of the generator.
double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

TEST(Random, NormalMatchesTheNormalDistribution) {
  // Phi(Z) is uniform: chi-square over 1000 equal-probability bins (a strip or wedge
  // table error shows as a bias of some bins) and the Kolmogorov-Smirnov distance.
  netkf::Rng rng(netkf::derive_seed(2026, "test-normal-cdf"));
  const int N = 2000000;
  const int bins = 1000;
  std::vector<int> count(bins, 0);
  std::vector<double> u(N);
  for (int i = 0; i < N; ++i) {
    u[static_cast<std::size_t>(i)] = normal_cdf(rng.standard_normal());
    const int b = std::min(bins - 1, static_cast<int>(u[static_cast<std::size_t>(i)] * bins));
    ++count[static_cast<std::size_t>(b)];
  }
  const double expected = static_cast<double>(N) / bins;
  double chi2 = 0.0;
  for (int c : count) chi2 += (c - expected) * (c - expected) / expected;
  // chi2 with 999 degrees of freedom: mean 999, sd sqrt(2 * 999) = 44.7; 5 sd.
  EXPECT_LT(chi2, 999.0 + 5.0 * std::sqrt(2.0 * 999.0));
  std::sort(u.begin(), u.end());
  double ks = 0.0;
  for (int i = 0; i < N; ++i) {
    const double ui = u[static_cast<std::size_t>(i)];
    ks = std::max({ks, ui - static_cast<double>(i) / N, static_cast<double>(i + 1) / N - ui});
  }
  // P(sqrt(N) D > 1.95) = 0.001 (Kolmogorov distribution).
  EXPECT_LT(std::sqrt(static_cast<double>(N)) * ks, 1.95);
}

TEST(Random, NormalTailBeyondTheZigguratBase) {
  // Draws beyond r = 3.654 come only from the tail algorithm: their frequency, and that
  // of |Z| > 4.2, must match erfc within 4 SE.
  netkf::Rng rng(netkf::derive_seed(2026, "test-normal-tail"));
  const int N = 4000000;
  const double r = netkf::detail::normal_ziggurat().x[1];
  int beyond_r = 0;
  int beyond_42 = 0;
  for (int i = 0; i < N; ++i) {
    const double z = std::abs(rng.standard_normal());
    beyond_r += z > r ? 1 : 0;
    beyond_42 += z > 4.2 ? 1 : 0;
  }
  for (auto [threshold, hits] : {std::pair{r, beyond_r}, std::pair{4.2, beyond_42}}) {
    const double p = std::erfc(threshold / std::sqrt(2.0));
    EXPECT_NEAR(static_cast<double>(hits) / N, p, 4.0 * std::sqrt(p * (1 - p) / N)) << "|Z| > " << threshold;
  }
}

}  // namespace
