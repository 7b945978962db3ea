// Seeded random streams: known-answer values from an independent implementation
// (Python, written from the generators' published definitions), reproducibility,
// stream independence, and moments of the uniform and normal draws within 4 SE.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <set>
#include <vector>

#include "netkf/random.hpp"

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

}  // namespace
