// LogThrottle (netkf/support/log_throttle.hpp): repeated warnings are rate-limited with a count.
#include <gtest/gtest.h>

#include <chrono>

#include "netkf/support/log_throttle.hpp"

namespace {

TEST(LogThrottle, AllowsABurstPerWindowAndCountsTheRest) {
  using namespace std::chrono_literals;
  netkf::LogThrottle t(3, 10s);
  const auto t0 = netkf::LogThrottle::Clock::time_point{} + 100s;
  EXPECT_EQ(t.allow(t0), 0u);
  EXPECT_EQ(t.allow(t0 + 1s), 0u);
  EXPECT_EQ(t.allow(t0 + 2s), 0u);
  for (int i = 0; i < 600; ++i) EXPECT_FALSE(t.allow(t0 + 3s));  // 600 bad samples: none logged
  EXPECT_EQ(t.allow(t0 + 10s), 600u);                            // the next window says how many
  EXPECT_EQ(t.allow(t0 + 11s), 0u);
}

}  // namespace
