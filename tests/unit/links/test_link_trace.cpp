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

#include "netkf/cli/recording/mcap_writer.hpp"
#include "netkf/cli/recording/trace_extract.hpp"
#include "netkf/links/link.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_trace.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/nodes/channel_links.hpp"

namespace {

using ::testing::HasSubstr;
using netkf::LinkKeys;
using netkf::LinkSpec;
using netkf::TraceLink;

// A scratch directory of this test process, removed at the end.
class TraceFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("netkf-trace-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_ / "traces");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) const {
    const auto path = dir_ / name;
    std::ofstream(path) << text;
    return path.string();
  }
  std::filesystem::path dir_;
};

// Rows 0..4 delivered 1,0,0,1,1 with delays 3, -, -, 7.5, 2.
const char* const kTrace =
    "# five rows\n"
    "k,delivered,delay_ms\n"
    "10,1,3\n"
    "11,0,\n"
    "12,0,\n"
    "13,1,7.5\n"
    "14,1,2\n";

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

// A scenario in dir_ whose link 1 replays traces/t.csv (named relative to the scenario).
std::string scenario_text(const std::string& link) {
  return "period_ms: 10\n"
         "seed: 7\n"
         "plant: { A: [[0.5]], Q: [[1.0]] }\n"
         "sensors:\n"
         "  - { id: 1, C: [[1.0]], R: [[1.0]], link: " + link + " }\n";
}

TEST_F(TraceFiles, ScenarioNamesTheTraceRelativeToItselfAndErrorsCarryBothPositions) {
  write("traces/t.csv", kTrace);
  const std::string yaml = write("s.yaml", scenario_text("{ model: trace, trace: traces/t.csv, offset: 1 }"));
  const netkf::Scenario s = netkf::load_scenario_file(yaml);
  ASSERT_TRUE(s.sensors[0].link.trace);
  EXPECT_EQ(std::filesystem::path(s.sensors[0].link.trace->path), std::filesystem::absolute(dir_ / "traces/t.csv"));
  EXPECT_TRUE(s.sensors[0].link.trace->loop);  // the default

  const auto error_of = [&](const std::string& link, const std::string& trace_text) -> std::string {
    write("traces/t.csv", trace_text);
    try {
      (void)netkf::load_scenario_file(write("s.yaml", scenario_text(link)));
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

// The channel replays the trace period for period, and a switch to a model and back
// restarts the trace at its offset from the period the switch took effect.
TEST_F(TraceFiles, ChannelReplaysTheTraceAndSwitchesToAModelAndBack) {
  write("traces/t.csv", kTrace);
  const netkf::Scenario s =
      netkf::load_scenario_file(write("s.yaml", scenario_text("{ model: trace, trace: traces/t.csv, offset: 2 }")));
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
      "s.yaml", scenario_text("{ model: bernoulli, loss: 0 }") +
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

// `netkf trace extract`: the delivered (sensor, period) pairs written here come back as the
// link's trace, period for period, from a samples CSV and from an MCAP file (written by the
// project's McapWriter, cut inside its last record as by kill -9).
TEST_F(TraceFiles, ExtractGivesTheLinkTraceFromSamplesCsvAndMcap) {
  // Link 1 delivered periods 3, 4, 6; link 2 every period 2..8.
  const std::vector<std::pair<int, int>> delivered = {{2, 2}, {3, 1}, {3, 2}, {4, 1}, {4, 2}, {5, 2},
                                                      {6, 1}, {6, 2}, {7, 2}, {8, 2}};
  std::string csv = "k,sensor_id,stamp,fused,y0\n";
  for (const auto& [k, id] : delivered) csv += std::to_string(k) + "," + std::to_string(id) + ",1.5,1,0.25\n";
  const std::string csv_path = write("samples.csv", csv);

  const auto mcap_path = dir_ / "run.mcap";
  {
    std::ofstream out(mcap_path, std::ios::binary);
    netkf::cli::McapWriter w(out);
    const auto schema = w.add_schema("netkf.wire.Measurement", "jsonschema", "{}");
    const auto other = w.add_channel(schema, "netkf/truth", "json");
    const auto channel = w.add_channel(schema, "netkf/measurement/delivered", "json");
    for (const auto& [k, id] : delivered) {
      w.add_message(other, 1, 1, R"({"k": 99, "sensor_id": 1})");
      w.add_message(channel, 1, 1, "{\"sensor_id\": " + std::to_string(id) + ", \"k\": " + std::to_string(k) + ", \"y\": [0.5]}");
    }
    w.finish();
  }
  const std::vector<std::uint8_t> link1 = {0, 1, 1, 0, 1, 0, 0};  // periods 2..8
  for (const std::string& path : {csv_path, mcap_path.string()}) {
    const auto samples = netkf::cli::read_delivered_samples(path);
    const netkf::LinkTrace t = netkf::cli::extract_link_trace(samples, 1);
    EXPECT_EQ(t.first_k, 2u) << path;
    EXPECT_EQ(t.delivered, link1) << path;
    EXPECT_FALSE(t.has_delay);
    const netkf::LinkTrace part = netkf::cli::extract_link_trace(samples, 1, 0, 4);
    EXPECT_EQ(part.delivered, (std::vector<std::uint8_t>{0, 0, 0, 1, 1})) << path;
    EXPECT_THROW(netkf::cli::extract_link_trace(samples, 9), std::runtime_error);
    // Written and read back: the trace format of `model: trace` and `netkf fit`.
    std::ostringstream text;
    netkf::write_link_trace(text, t, "extracted");
    std::istringstream in(text.str());
    const netkf::LinkTrace again = netkf::read_link_trace(in, "again.csv");
    EXPECT_EQ(again.first_k, t.first_k);
    EXPECT_EQ(again.delivered, t.delivered);
  }
  // A file cut inside its last record reads up to its last whole record.
  std::ostringstream whole;
  whole << std::ifstream(mcap_path, std::ios::binary).rdbuf();
  const std::string bytes = whole.str();
  const auto cut = dir_ / "cut.mcap";
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - 60);
  const auto partial = netkf::cli::read_delivered_samples(cut.string());
  EXPECT_EQ(partial.periods_by_sensor.at(1), (std::set<std::int64_t>{3, 4, 6}));
  // Not a recording: refused with the file's name.
  EXPECT_THROW(netkf::cli::read_delivered_samples(write("x.csv", "k,delivered\n0,1\n")), std::runtime_error);
  EXPECT_THROW(netkf::cli::read_delivered_samples(write("x.mcap", "not mcap")), std::runtime_error);
}

// A malformed samples CSV is refused at FILE:LINE with what is wrong (docs/cli.md: exit 2 for
// a malformed recording); it used to give a different trace, read from k and sensor_id only.
TEST_F(TraceFiles, ExtractRefusesAMalformedSamplesCsvAtItsLine) {
  const std::string header = "k,sensor_id,stamp,fused,y0\n";
  const std::string good = header + "4,1,0.04,1,0.5\n5,1,0.05,0,\n";
  EXPECT_EQ(netkf::cli::read_delivered_samples(write("good.csv", good)).periods_by_sensor.at(1).size(), 2u);
  const auto error_of = [&](const std::string& text) {
    try {
      netkf::cli::read_delivered_samples(write("bad.csv", text));
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("<accepted>");
  };
  const std::string bad = (dir_ / "bad.csv").string();
  EXPECT_EQ(error_of(good + "5,1,abc,1,zz\n"), bad + ":4: stamp must be a number, got 'abc'");
  EXPECT_EQ(error_of(good + "5,1,0.05,1,zz\n"), bad + ":4: y0 must be a number, got 'zz'");
  EXPECT_EQ(error_of(good + "5,1,0.05,2,1\n"), bad + ":4: fused must be 0 or 1, got '2'");
  EXPECT_EQ(error_of(good + "5,1,0.05,1\n"), bad + ":4: a row of 4 fields, the header has 5");
  EXPECT_EQ(error_of(good + "5,1,0.05,1,0.5,7\n"), bad + ":4: a row of 6 fields, the header has 5");
  EXPECT_EQ(error_of(good + "x,1,0.05,1,0.5\n"), bad + ":4: k must be an integer, got 'x'");
  EXPECT_EQ(error_of(good + "99999999999999999999,1,0.05,1,0.5\n"),
            bad + ":4: k is out of range, got '99999999999999999999'");
  // A file cut in the middle of a row (no end of line after it).
  EXPECT_EQ(error_of(good + "6,1,0.0"), bad + ":4: the last row is cut (no end of line): the file is truncated");
  EXPECT_EQ(error_of("k,sensor_id,stamp,fused,z0\n"), bad + ":1: bad header: column 5 must be 'y0', got 'z0'");
  // With fused_in_time (late_policy fuse_within), and a UTF-8 byte-order mark.
  EXPECT_EQ(error_of("\xEF\xBB\xBFk,sensor_id,stamp,fused,fused_in_time,y0\n4,1,0.04,1,0,0.5\n"), "<accepted>");
  // A device is refused unread.
  EXPECT_THAT([] {
    try {
      netkf::cli::read_delivered_samples("/dev/zero");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  }(), ::testing::HasSubstr("is a character device"));
}

// A relay's record (docs/relay.md, `--record`) lists every sample of every topic with its fate
// and delay: the trace of a topic has a row per sample index, and a delay column when a
// delivered sample was held. A topic name may hold commas (the five fields after it cannot).
TEST_F(TraceFiles, ExtractGivesATopicsTraceFromARelayRecord) {
  const std::string record =
      "topic,index,sequence,bytes,fate,delay_ms\n"
      "rt/a,0,1,40,delivered,0\n"
      "rt/b,0,1,8,dropped,0\n"
      "rt/a,1,2,40,dropped,0\n"
      "rt/b,1,2,8,delivered,2.5\n"
      "rt/a,2,3,40,delivered,0\n"
      "rt/b,2,3,8,delivered,0\n"
      "odd,name,0,1,8,dropped,0\n";
  const std::string path = write("fates.csv", record);
  EXPECT_TRUE(netkf::cli::is_relay_record(path));
  EXPECT_FALSE(netkf::cli::is_relay_record(write("samples.csv", "k,sensor_id,stamp,fused,y0\n")));
  const auto fates = netkf::cli::read_relay_fates(path);
  const netkf::LinkTrace a = netkf::cli::extract_topic_trace(fates, "rt/a");
  EXPECT_EQ(a.first_k, 0u);
  EXPECT_EQ(a.delivered, (std::vector<std::uint8_t>{1, 0, 1}));
  EXPECT_FALSE(a.has_delay);  // nothing was held: no delay column
  const netkf::LinkTrace b = netkf::cli::extract_topic_trace(fates, "rt/b", 1, 2);
  EXPECT_EQ(b.first_k, 1u);
  EXPECT_EQ(b.delivered, (std::vector<std::uint8_t>{1, 1}));
  ASSERT_TRUE(b.has_delay);
  EXPECT_EQ(b.delay_ms[0], 2.5);
  EXPECT_EQ(b.delay_ms[1], 0.0);
  EXPECT_EQ(netkf::cli::extract_topic_trace(fates, "odd,name").delivered, (std::vector<std::uint8_t>{0}));
  // Read back as a `model: trace` link reads it: the same rows and delays.
  std::ostringstream text;
  netkf::write_link_trace(text, b, "extracted");
  std::istringstream in(text.str());
  const netkf::LinkTrace again = netkf::read_link_trace(in, "again.csv");
  EXPECT_EQ(again.delivered, b.delivered);
  EXPECT_EQ(again.delay_ms, b.delay_ms);
  // A topic not relayed, and an index range beyond the record (a cut record), are named.
  const auto extract_error = [&](const std::string& topic, std::optional<std::int64_t> first,
                                 std::optional<std::int64_t> last) {
    try {
      netkf::cli::extract_topic_trace(fates, topic, first, last);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("<accepted>");
  };
  EXPECT_THAT(extract_error("rt/c", {}, {}), HasSubstr("topic rt/c has no sample in the record (topics: odd,name, rt/a, rt/b)"));
  EXPECT_THAT(extract_error("rt/a", 0, 3), HasSubstr("sample 3 of rt/a is not in the record"));
  EXPECT_THAT(extract_error("rt/a", 2, 1), HasSubstr("no samples to extract (2..1)"));
}

// A malformed relay record is refused at FILE:LINE with what is wrong.
TEST_F(TraceFiles, ExtractRefusesAMalformedRelayRecordAtItsLine) {
  const std::string header = "topic,index,sequence,bytes,fate,delay_ms\n";
  const std::string good = header + "rt/a,0,1,40,delivered,0\n";
  const auto error_of = [&](const std::string& text) {
    try {
      netkf::cli::read_relay_fates(write("bad.csv", text));
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("<accepted>");
  };
  const std::string bad = (dir_ / "bad.csv").string();
  EXPECT_EQ(error_of(good), "<accepted>");
  EXPECT_EQ(error_of(good + "rt/a,1,2,40,lost,0\n"), bad + ":3: fate must be delivered or dropped, got 'lost'");
  EXPECT_EQ(error_of(good + "rt/a,1,2,40,delivered,-1\n"), bad + ":3: delay_ms must be a number >= 0, got '-1'");
  EXPECT_EQ(error_of(good + "rt/a,1,2,40,delivered,nan\n"), bad + ":3: delay_ms must be a number >= 0, got 'nan'");
  EXPECT_EQ(error_of(good + "rt/a,x,2,40,delivered,0\n"), bad + ":3: index must be an integer, got 'x'");
  EXPECT_EQ(error_of(good + "rt/a,0,2,40,delivered,0\n"), bad + ":3: index 0 of rt/a a second time");
  EXPECT_EQ(error_of(good + "1,2,40,delivered,0\n"), bad + ":3: a row of fewer than 6 fields");
  EXPECT_EQ(error_of(good + ",1,2,40,delivered,0\n"), bad + ":3: a row without a topic");
  EXPECT_EQ(error_of(good + "rt/a,1,2,40,deliv"), bad + ":3: the last row is cut (no end of line): the file is truncated");
  EXPECT_EQ(error_of("k,sensor_id,stamp,fused,y0\n"),
            bad + ":1: not a relay's record (its header is 'topic,index,sequence,bytes,fate,delay_ms'; it is written "
                  "by netkf relay --record)");
  EXPECT_EQ(error_of(""), bad + ": empty file (a relay's record starts with its header)");
}

}  // namespace
