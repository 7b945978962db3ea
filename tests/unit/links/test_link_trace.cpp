// Trace links (docs/scenario-format.md, "Trace links"): `model: trace` replays a measured
// arrival trace. The expectations are written out by hand from the rows of small traces
// (which row each period gets with an offset, with and without loop), and the empirical
// model from counts done here (loss = drops / rows, mean burst = drops / runs of drops).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "netkf/links/link.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_trace.hpp"
#include "netkf/model/scenario.hpp"
#include "support/trace_files.hpp"

namespace {

using ::testing::HasSubstr;
using netkf::LinkKeys;
using netkf::LinkSpec;
using netkf::TraceLink;

using netkf_test::TraceFiles;

using netkf_test::kTrace;
using netkf_test::trace_scenario_text;

std::vector<int> delivered_per_period(const TraceLink& t, int periods) {
  std::vector<int> out;
  for (int n = 0; n < periods; ++n) out.push_back(netkf::trace_sample(t, n).delivered ? 1 : 0);
  return out;
}

TEST_F(TraceFiles, PeriodNGetsRowOffsetPlusNAndLoopRestartsAtRowZero) {
  TraceLink t{write("t.csv", kTrace), true, 2, netkf::read_link_trace_for(write("t.csv", kTrace))};
  // Rows 2,3,4, then 0,1,2,3,4 again.
  EXPECT_EQ(delivered_per_period(t, 8), (std::vector<int>{0, 1, 1, 1, 0, 0, 1, 1}));
  t.loop = false;
  // Rows 2,3,4, then past the end: every sample dropped.
  EXPECT_EQ(delivered_per_period(t, 8), (std::vector<int>{0, 1, 1, 0, 0, 0, 0, 0}));
  t.offset = 0;
  t.loop = true;
  EXPECT_EQ(delivered_per_period(t, 11), (std::vector<int>{1, 0, 0, 1, 1, 1, 0, 0, 1, 1, 1}));
}

TEST_F(TraceFiles, DelayColumnGivesTheDelayOfDeliveredSamples) {
  const TraceLink t{"t.csv", true, 0, netkf::read_link_trace_for(write("t.csv", kTrace))};
  EXPECT_DOUBLE_EQ(netkf::trace_sample(t, 0).delay_ms, 3.0);
  EXPECT_TRUE(std::isnan(netkf::trace_sample(t, 1).delay_ms));
  EXPECT_DOUBLE_EQ(netkf::trace_sample(t, 3).delay_ms, 7.5);
  EXPECT_DOUBLE_EQ(netkf::trace_sample(t, 9).delay_ms, 2.0);  // row 4 of the second pass
  // Without the column the link's own delay draws apply: no delay from the trace.
  const TraceLink plain{"p.csv", true, 0, netkf::read_link_trace_for(write("p.csv", "k,delivered\n0,1\n"))};
  EXPECT_TRUE(std::isnan(netkf::trace_sample(plain, 0).delay_ms));
}

TEST_F(TraceFiles, EmpiricalModelHasTheTracesLossAndMeanBurst) {
  // 1 0 0 1 0 1 1 1 0 0 0 1: 12 rows, 6 drops in 3 runs (2, 1, 3).
  std::string text = "k,delivered\n";
  const int rows[] = {1, 0, 0, 1, 0, 1, 1, 1, 0, 0, 0, 1};
  for (int i = 0; i < 12; ++i) text += std::to_string(i) + "," + std::to_string(rows[i]) + "\n";
  const auto trace = netkf::read_link_trace_for(write("e.csv", text));
  const netkf::LinkModel m = netkf::empirical_link_model(*trace);
  EXPECT_NEAR(netkf::stationary_loss(m), 6.0 / 12.0, 1e-12);
  EXPECT_NEAR(netkf::mean_burst_length(m), 6.0 / 3.0, 1e-12);
  EXPECT_EQ(netkf::empirical_link_model(*netkf::read_link_trace_for(write("a.csv", "k,delivered\n0,1\n1,1\n"))),
            netkf::LinkModel(netkf::BernoulliLink{0.0}));
  EXPECT_EQ(netkf::empirical_link_model(*netkf::read_link_trace_for(write("n.csv", "k,delivered\n0,0\n1,0\n"))),
            netkf::LinkModel(netkf::BernoulliLink{1.0}));
  // A burst that ends the trace and one that starts it are one around the loop (the fuzzer's
  // find: 0 0 1 0 had loss 0.6): 3 drops of 4 in one run of 3.
  const auto both_ends = netkf::empirical_link_model(
      *netkf::read_link_trace_for(write("b.csv", "k,delivered\n0,0\n1,0\n2,1\n3,0\n")));
  EXPECT_NEAR(netkf::stationary_loss(both_ends), 0.75, 1e-12);
  EXPECT_NEAR(netkf::mean_burst_length(both_ends), 3.0, 1e-12);
}

TEST_F(TraceFiles, KeysBuildTraceLinksAndRoundTrip) {
  const std::string path = write("t.csv", kTrace);
  const LinkSpec l = netkf::link_from_keys(
      {{"model", std::string("trace")}, {"trace", path}, {"loop", std::string("false")}, {"offset", 3.0}});
  ASSERT_TRUE(l.trace);
  EXPECT_EQ(l.trace->path, path);
  EXPECT_FALSE(l.trace->loop);
  EXPECT_EQ(l.trace->offset, 3u);
  EXPECT_EQ(netkf::link_kind(l), "trace");
  EXPECT_NEAR(netkf::stationary_loss(l.loss), 2.0 / 5.0, 1e-12);
  EXPECT_EQ(netkf::apply_link_keys(LinkSpec(netkf::BernoulliLink{0.5}), netkf::link_keys(l)), l);
  // Changing only the offset keeps the file; leaving the trace needs a model's keys.
  EXPECT_EQ(netkf::apply_link_keys(l, {{"offset", 1.0}}).trace->offset, 1u);
  const LinkSpec b = netkf::apply_link_keys(l, {{"model", std::string("bernoulli")}, {"loss", 0.25}});
  EXPECT_FALSE(b.trace);
  EXPECT_EQ(b.loss, netkf::LinkModel(netkf::BernoulliLink{0.25}));
}

TEST_F(TraceFiles, KeysAreRefusedWithTheirNames) {
  const std::string path = write("t.csv", kTrace);
  const auto error_of = [](const LinkKeys& keys) -> std::string {
    try {
      (void)netkf::link_from_keys(keys);
    } catch (const netkf::LinkError& e) {
      return e.key() + ": " + e.what();
    }
    return "no error";
  };
  const std::string model = "trace";
  EXPECT_THAT(error_of({{"model", model}}), HasSubstr("trace: a trace link needs trace"));
  EXPECT_THAT(error_of({{"model", model}, {"trace", path}, {"loss", 0.1}}), HasSubstr("loss: loss is not a key of a trace link"));
  EXPECT_THAT(error_of({{"model", model}, {"trace", path}, {"offset", 5.0}}), HasSubstr("offset: offset 5 is past"));
  EXPECT_THAT(error_of({{"model", model}, {"trace", path}, {"offset", 1.5}}), HasSubstr("offset: offset must be a whole"));
  EXPECT_THAT(error_of({{"model", model}, {"trace", path}, {"loop", std::string("yes")}}), HasSubstr("loop: loop must be true or false"));
  EXPECT_THAT(error_of({{"model", model}, {"trace", path}, {"delay_ms", 4.0}}), HasSubstr("delay_ms: delay_ms cannot be given"));
  EXPECT_THAT(error_of({{"model", std::string("bernoulli")}, {"loss", 0.1}, {"offset", 1.0}}),
              HasSubstr("offset: offset is a key of a trace link"));
  EXPECT_THAT(error_of({{"model", model}, {"trace", (dir_ / "missing.csv").string()}}), HasSubstr("trace: trace "));
  EXPECT_THAT(error_of({{"model", model}, {"trace", write("bad.csv", "k,delivered\n0,1\n1,2\n")}}),
              HasSubstr("bad.csv:3:3:"));
}

TEST_F(TraceFiles, ScenarioNamesTheTraceRelativeToItselfAndErrorsCarryBothPositions) {
  write("traces/t.csv", kTrace);
  const std::string yaml = write("s.yaml", trace_scenario_text("{ model: trace, trace: traces/t.csv, offset: 1 }"));
  const netkf::Scenario s = netkf::load_scenario_file(yaml);
  ASSERT_TRUE(s.sensors[0].link.trace);
  EXPECT_EQ(std::filesystem::path(s.sensors[0].link.trace->path), std::filesystem::absolute(dir_ / "traces/t.csv"));
  EXPECT_TRUE(s.sensors[0].link.trace->loop);  // the default

  const auto error_of = [&](const std::string& link, const std::string& trace_text) -> std::string {
    write("traces/t.csv", trace_text);
    try {
      (void)netkf::load_scenario_file(write("s.yaml", trace_scenario_text(link)));
    } catch (const netkf::ScenarioError& e) {
      return e.what();
    }
    return "no error";
  };
  // The scenario's position of the key, then the trace's own FILE:LINE:COL.
  const std::string bad = error_of("{ model: trace, trace: traces/t.csv }", "k,delivered\n0,1\n1,x\n");
  EXPECT_THAT(bad, HasSubstr("s.yaml:5:"));
  EXPECT_THAT(bad, HasSubstr("sensors[0].link.trace"));
  EXPECT_THAT(bad, HasSubstr("t.csv:3:3:"));
  EXPECT_THAT(error_of("{ model: trace, trace: traces/t.csv }", "# nothing\nk,delivered\n"), HasSubstr("t.csv:"));
  EXPECT_THAT(error_of("{ model: trace, trace: traces/t.csv }", "k,delivered,delay_ms\n0,1,nan\n"), HasSubstr("t.csv:2:"));
  EXPECT_THAT(error_of("{ model: trace, trace: traces/t.csv, mean_burst: 3 }", kTrace),
              HasSubstr("sensors[0].link.mean_burst is not a key of a trace link"));
  EXPECT_THAT(error_of("{ model: trace, trace: traces/t.csv, looping: true }", kTrace), HasSubstr("looping"));
}

}  // namespace
