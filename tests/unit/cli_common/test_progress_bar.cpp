// The progress bar of simulate / analyze --region (progress_bar.hpp): when it is drawn, its line,
// and how often it is redrawn (a fake clock).
#include <gtest/gtest.h>

#include <chrono>
#include <sstream>
#include <string>

#include "netkf/cli/common/progress_bar.hpp"

namespace netkf::cli {
namespace {

using namespace std::chrono_literals;

TEST(ProgressBar, OnlyOnATerminalAndNeverWithJson) {
  EXPECT_TRUE(progress_bar_wanted(true, false));
  EXPECT_FALSE(progress_bar_wanted(false, false));  // stderr is a file or a pipe
  EXPECT_FALSE(progress_bar_wanted(true, true));
}

TEST(ProgressBar, LineShowsPercentAndTimeLeft) {
  EXPECT_EQ(progress_line("simulate", 0, 200, 0.0, 10), "simulate [..........]   0%");
  // A quarter done in 30 s: 90 s left at that rate.
  EXPECT_EQ(progress_line("simulate", 50, 200, 30.0, 10), "simulate [##........]  25%  1m30s left");
  EXPECT_EQ(progress_line("x", 200, 200, 12.0, 4), "x [####] 100%");
  EXPECT_EQ(progress_line("x", 1, 1000, 10.0, 4), "x [....]   0%  2h46m left");
}

TEST(ProgressBar, DisabledWritesNothing) {
  std::ostringstream out;
  {
    ProgressBar bar(out, "simulate", false);
    EXPECT_FALSE(bar.callback());  // the core need not even count
    bar.update(1, 2);
    bar.update(2, 2);
  }
  EXPECT_EQ(out.str(), "");
}

TEST(ProgressBar, RedrawsAtMostTenTimesASecondThenClears) {
  std::ostringstream out;
  auto now = std::chrono::steady_clock::time_point{} + 1h;
  {
    ProgressBar bar(out, "simulate", true, [&] { return now; });
    auto progress = bar.callback();
    ASSERT_TRUE(progress);
    progress(0, 100);
    now += 50ms;
    progress(10, 100);  // too soon after the first draw
    now += 60ms;
    progress(20, 100);
    progress(100, 100);  // the end is always drawn
  }
  const std::string text = out.str();
  EXPECT_EQ(text, "\r\033[Ksimulate [..............................]   0%"
                  "\r\033[Ksimulate [######........................]  20%  0s left"
                  "\r\033[Ksimulate [##############################] 100%"
                  "\r\033[K");
}

}  // namespace
}  // namespace netkf::cli
