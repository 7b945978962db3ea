// `netkf trace extract` (trace_extract.hpp): a link's or a topic's arrival trace from a samples
// CSV, an MCAP recording or a relay's record, against the pairs written here; malformed inputs
// refused at their line.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "mcap_writer.hpp"
#include "netkf/cli/recording/trace_extract.hpp"
#include "netkf/links/link_trace.hpp"
#include "support/trace_files.hpp"

namespace {

using ::testing::HasSubstr;

using netkf_test::TraceFiles;

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
