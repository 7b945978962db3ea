// Trace links in the channel (docs/scenario-format.md, "Trace links"): ChannelLinks replays a
// measured arrival trace period for period, switches to a model and back, and takes a trace from
// its timeline. The expected fates are written out by hand from the rows of a small trace.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "netkf/model/scenario.hpp"
#include "netkf/nodes/channel_links.hpp"
#include "support/trace_files.hpp"

namespace {

using ::testing::HasSubstr;

using netkf_test::TraceFiles;

using netkf_test::kTrace;
using netkf_test::trace_scenario_text;

// The channel replays the trace period for period, and a switch to a model and back
// restarts the trace at its offset from the period the switch took effect.
TEST_F(TraceFiles, ChannelReplaysTheTraceAndSwitchesToAModelAndBack) {
  write("traces/t.csv", kTrace);
  const netkf::Scenario s =
      netkf::load_scenario_file(write("s.yaml", trace_scenario_text("{ model: trace, trace: traces/t.csv, offset: 2 }")));
  netkf::nodes::ChannelLinks links(s);
  using V = netkf::nodes::SampleFate::Verdict;
  // Rows 2,3,4,0,1: dropped, delivered (7.5 ms), delivered (2 ms), delivered (3 ms), dropped.
  const std::vector<V> expected = {V::dropped, V::delivered, V::delivered, V::delivered, V::dropped};
  const std::vector<double> delays = {0.0, 7.5, 2.0, 3.0, 0.0};
  for (int k = 0; k < 5; ++k) {
    const auto fate = links.on_sample(1, k);
    EXPECT_EQ(fate.verdict, expected[k]) << "period " << k;
    EXPECT_DOUBLE_EQ(fate.delay_ms, delays[k]) << "period " << k;
  }
  ASSERT_TRUE(links.request(1, 1, {{"model", std::string("bernoulli")}, {"loss", 1.0}}).applied);
  for (int k = 5; k < 8; ++k) EXPECT_EQ(links.on_sample(1, k).verdict, V::dropped);
  const std::string trace = s.sensors[0].link.trace->path;
  ASSERT_TRUE(links.request(2, 1, {{"model", std::string("trace")}, {"trace", trace}, {"loop", std::string("false")}}).applied);
  // From period 8 on: rows 0..4 (offset 0, the keys given rebuild the link), then nothing.
  const std::vector<V> again = {V::delivered, V::dropped, V::dropped, V::delivered, V::delivered, V::dropped, V::dropped};
  for (int k = 8; k < 15; ++k) EXPECT_EQ(links.on_sample(1, k).verdict, again[k - 8]) << "period " << k;
  const auto changes = links.take_changes();
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].at_period, 5);
  EXPECT_FALSE(changes[0].link.trace);
  EXPECT_EQ(changes[1].at_period, 8);
  ASSERT_TRUE(changes[1].link.trace);
  EXPECT_EQ(changes[1].link.trace->path, trace);
  // A request naming a file that is not there is refused, and the link stays as it was.
  const auto refused = links.request(3, 1, {{"model", std::string("trace")}, {"trace", (dir_ / "gone.csv").string()}});
  EXPECT_FALSE(refused.applied);
  EXPECT_THAT(refused.reason, HasSubstr("gone.csv"));
  EXPECT_EQ(links.status(1)->link.trace->path, trace);
}

TEST_F(TraceFiles, TimelineSwitchesToATraceReadAtStart) {
  write("traces/t.csv", kTrace);
  const netkf::Scenario s = netkf::load_scenario_file(write(
      "s.yaml", trace_scenario_text("{ model: bernoulli, loss: 0 }") +
                    "events:\n  - { at_period: 3, link: 1, set: { model: trace, trace: traces/t.csv, offset: 1 } }\n"));
  netkf::nodes::ChannelLinks links(s);
  std::filesystem::remove(dir_ / "traces/t.csv");  // read at start: the sample path never opens it
  using V = netkf::nodes::SampleFate::Verdict;
  // Periods 0..2 loss 0; from period 3 rows 1,2,3,4,0.
  const std::vector<V> expected = {V::delivered, V::delivered, V::delivered, V::dropped,
                                   V::dropped,   V::delivered, V::delivered, V::delivered};
  for (int k = 0; k < 8; ++k) EXPECT_EQ(links.on_sample(1, k).verdict, expected[k]) << "period " << k;
  const auto changes = links.take_changes();
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_TRUE(changes[0].failure.empty()) << changes[0].failure;
  EXPECT_EQ(changes[0].at_period, 3);
}

}  // namespace
