// The MCAP writer (cli/recording/mcap_writer.hpp) byte for byte against hand-computed records, and
// the recording's channels (cli/recording/record_mcap.hpp). tests/e2e/test_mcap.py reads a real
// recording with an independent reader (@mcap/core).
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "netkf/cli/common/exit_code.hpp"
#include "mcap_writer.hpp"
#include "record_mcap.hpp"
#include "netkf/cli/recording/recording.hpp"
#include "netkf/cli/recording/ros2_bag.hpp"
#include "test_paths.hpp"

namespace netkf::cli {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes bytes_of(const std::string& s) { return Bytes(s.begin(), s.end()); }
void append(Bytes& b, std::initializer_list<int> v) {
  for (int x : v) b.push_back(static_cast<std::uint8_t>(x));
}
void append(Bytes& b, const std::string& text) { b.insert(b.end(), text.begin(), text.end()); }

TEST(McapWriterBytes, TinyFileByteForByte) {
  std::ostringstream out;
  {
    McapWriter w(out);
    EXPECT_EQ(w.add_schema("S", "jsonschema", "{}"), 1);
    EXPECT_EQ(w.add_channel(1, "t", "json"), 0);
    w.add_message(0, 5, 6, "{}");
    w.add_message(0, 0x0102030405060708ULL, 7, "");
    w.finish();
    w.finish();  // idempotent
  }
  Bytes e;
  // Magic: 0x89 M C A P 0 \r \n
  append(e, {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'});
  // Header 0x01, length 13: profile "" (u32 0), library "netkf" (u32 5 + 5 bytes)
  append(e, {0x01, 13, 0, 0, 0, 0, 0, 0, 0});
  append(e, {0, 0, 0, 0});
  append(e, {5, 0, 0, 0});
  append(e, "netkf");
  // Schema 0x03, length 2 + (4+1) + (4+10) + (4+2) = 27: id 1, name "S", encoding "jsonschema", data "{}"
  append(e, {0x03, 27, 0, 0, 0, 0, 0, 0, 0});
  append(e, {1, 0});
  append(e, {1, 0, 0, 0});
  append(e, "S");
  append(e, {10, 0, 0, 0});
  append(e, "jsonschema");
  append(e, {2, 0, 0, 0});
  append(e, "{}");
  // Channel 0x04, length 2 + 2 + (4+1) + (4+4) + 4 = 21: id 0, schema 1, topic "t",
  // encoding "json", metadata {} (u32 byte length 0)
  append(e, {0x04, 21, 0, 0, 0, 0, 0, 0, 0});
  append(e, {0, 0});
  append(e, {1, 0});
  append(e, {1, 0, 0, 0});
  append(e, "t");
  append(e, {4, 0, 0, 0});
  append(e, "json");
  append(e, {0, 0, 0, 0});
  // Message 0x05, length 2 + 4 + 8 + 8 + 2 = 24: channel 0, sequence 0, log 5, publish 6, "{}"
  append(e, {0x05, 24, 0, 0, 0, 0, 0, 0, 0});
  append(e, {0, 0});
  append(e, {0, 0, 0, 0});
  append(e, {5, 0, 0, 0, 0, 0, 0, 0});
  append(e, {6, 0, 0, 0, 0, 0, 0, 0});
  append(e, "{}");
  // Message 0x05, length 22: channel 0, sequence 1, log 0x0102030405060708 (LE), publish 7, no data
  append(e, {0x05, 22, 0, 0, 0, 0, 0, 0, 0});
  append(e, {0, 0});
  append(e, {1, 0, 0, 0});
  append(e, {8, 7, 6, 5, 4, 3, 2, 1});
  append(e, {7, 0, 0, 0, 0, 0, 0, 0});
  // DataEnd 0x0f, length 4: data section CRC 0
  append(e, {0x0f, 4, 0, 0, 0, 0, 0, 0, 0});
  append(e, {0, 0, 0, 0});
  // Footer 0x02, length 20: summary_start 0, summary_offset_start 0, summary_crc 0
  append(e, {0x02, 20, 0, 0, 0, 0, 0, 0, 0});
  for (int i = 0; i < 20; ++i) e.push_back(0);
  // Closing magic
  append(e, {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'});

  const Bytes got = bytes_of(out.str());
  ASSERT_EQ(got.size(), 8u + 22 + 36 + 30 + 33 + 31 + 13 + 29 + 8);
  EXPECT_EQ(got, e);
}

TEST(McapWriterBytes, ChannelMetadataIsAMapPrefixedByItsByteLength) {
  std::ostringstream out;
  McapWriter w(out, "lib");
  w.add_channel(0, "a", "json", {{"k", "vv"}});
  const Bytes got = bytes_of(out.str());
  // magic (8) + header (9 + 4 + 4 + 3) = 28; then the channel record
  Bytes e;
  // length 2 + 2 + (4+1) + (4+4) + 4 + (4+1) + (4+2) = 32
  append(e, {0x04, 32, 0, 0, 0, 0, 0, 0, 0});
  append(e, {0, 0, 0, 0});
  append(e, {1, 0, 0, 0});
  append(e, "a");
  append(e, {4, 0, 0, 0});
  append(e, "json");
  append(e, {11, 0, 0, 0});  // map: 11 bytes of entries
  append(e, {1, 0, 0, 0});
  append(e, "k");
  append(e, {2, 0, 0, 0});
  append(e, "vv");
  ASSERT_EQ(got.size(), 28u + e.size());
  EXPECT_EQ(Bytes(got.begin() + 28, got.end()), e);
}

TEST(McapWriterBytes, RefusesMessagesOnUnknownChannelsAndRecordsAfterTheFooter) {
  std::ostringstream out;
  McapWriter w(out);
  EXPECT_THROW(w.add_message(3, 0, 0, "{}"), std::logic_error);
  w.finish();
  EXPECT_THROW(w.add_schema("S", "jsonschema", "{}"), std::logic_error);
}

// A minimal reader of what the writer writes: (opcode, content) of each record.
struct Record {
  int opcode;
  std::string content;
};
std::vector<Record> records(const std::string& file) {
  std::vector<Record> out;
  std::size_t pos = 8;
  while (pos + 9 <= file.size() - 8) {
    const int op = static_cast<unsigned char>(file[pos]);
    std::uint64_t len = 0;
    for (int i = 7; i >= 0; --i) len = (len << 8) | static_cast<unsigned char>(file[pos + 1 + i]);
    out.push_back({op, file.substr(pos + 9, len)});
    pos += 9 + len;
  }
  return out;
}
std::uint32_t u32_at(const std::string& s, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(s[at + i]);
  return v;
}
std::string string_at(const std::string& s, std::size_t& at) {
  const auto n = u32_at(s, at);
  std::string v = s.substr(at + 4, n);
  at += 4 + n;
  return v;
}

TEST(McapRecording, ChannelsAreTheDdsTopicsWithJsonSchemas) {
  std::ostringstream out;
  const Scenario scenario = default_scenario();
  {
    McapRecorder r(out, scenario, /*with_delivered=*/true);
    r.truth(Truth{3, 3 * scenario.period_s(), std::vector<double>(scenario.state_dim(), 0.5), {}});
    Estimate e;
    e.k = 3;
    e.t = 3 * scenario.period_s();
    e.x_hat = Vector::Constant(scenario.state_dim(), 0.1);
    e.P = Matrix::Zero(scenario.state_dim(), scenario.state_dim());
    e.P(0, 0) = 1.25;  // Tr P
    r.estimate(e);
    r.delivered(DeliveredMeasurement{1, 3, 0.03, {0.2}});
    LinkStatus l;
    l.sensor_id = scenario.sensors[0].id;
    l.link = scenario.sensors[0].link;
    r.link_status(l);
    LinkStatus changed = l;  // the channel answers request 9: an event, then the status
    changed.last_request_id = 9;
    changed.link.loss = BernoulliLink{0.5};
    r.link_status(changed);
    LinkChange c;
    c.sensor_id = 1;
    c.at_period = 2;
    c.origin = netkf::LinkChange::Origin::request;
    c.request_id = 9;
    c.link = scenario.sensors[0].link;
    r.link_change(c);
    r.link_change(c);  // a transient-local repeat: written once
    LinkChange step = c;  // a timeline step: the change and its event
    step.origin = netkf::LinkChange::Origin::timeline;
    step.at_period = 4;
    step.request_id = 0;
    r.link_change(step);
    r.finish();
    EXPECT_EQ(r.estimates(), 1u);
    EXPECT_EQ(r.events(), 2u);
    EXPECT_EQ(r.messages(), 9u);
  }
  const auto recs = records(out.str());
  std::vector<std::string> topics;
  std::vector<std::string> schema_names;
  std::vector<nlohmann::json> messages;
  std::vector<std::uint16_t> message_channels;
  std::vector<std::uint64_t> log_times;
  for (const auto& rec : recs) {
    if (rec.opcode == McapWriter::kSchema) {
      std::size_t at = 2;
      schema_names.push_back(string_at(rec.content, at));
      EXPECT_EQ(string_at(rec.content, at), "jsonschema");
      EXPECT_EQ(nlohmann::json::parse(string_at(rec.content, at))["type"], "object");
    } else if (rec.opcode == McapWriter::kChannel) {
      std::size_t at = 4;
      topics.push_back(string_at(rec.content, at));
      EXPECT_EQ(string_at(rec.content, at), "json");
    } else if (rec.opcode == McapWriter::kMessage) {
      messages.push_back(nlohmann::json::parse(rec.content.substr(22)));
      message_channels.push_back(static_cast<std::uint16_t>(static_cast<unsigned char>(rec.content[0]) |
                                                            (static_cast<unsigned char>(rec.content[1]) << 8)));
      std::uint64_t t = 0;
      for (int i = 7; i >= 0; --i) t = (t << 8) | static_cast<unsigned char>(rec.content[6 + i]);
      log_times.push_back(t);
    }
  }
  EXPECT_EQ(topics, (std::vector<std::string>{"netkf/truth", "netkf/estimate", "netkf/measurement/delivered",
                                              "netkf/link/status", "netkf/link/change", "netkf/events"}));
  EXPECT_EQ(schema_names.back(), "foxglove.Log");  // Foxglove's Log panel knows it by this name
  ASSERT_EQ(messages.size(), 9u);
  EXPECT_EQ(messages[1]["k"], 3);
  EXPECT_EQ(messages[1]["trace_P"], 1.25);
  EXPECT_EQ(messages[2]["sensor_id"], 1);
  EXPECT_EQ(messages[3]["sensor_id"], scenario.sensors[0].id);
  // The answered request: foxglove.Log INFO (2) at the newest record's time, then the status.
  const std::uint16_t events_channel = message_channels[4];
  EXPECT_NE(events_channel, message_channels[3]);
  EXPECT_EQ(messages[4]["level"], 2);
  EXPECT_NE(messages[4]["message"].get<std::string>().find("loss=0.5"), std::string::npos) << messages[4];
  EXPECT_EQ(messages[4]["timestamp"]["sec"], 3 * scenario.period_ms / 1000);
  EXPECT_EQ(messages[4]["timestamp"]["nsec"], (3 * scenario.period_ms % 1000) * 1000000);
  EXPECT_EQ(messages[5]["loss"], 0.5);
  EXPECT_EQ(messages[6]["at_period"], 2);
  EXPECT_EQ(messages[6]["origin"], "request");
  EXPECT_EQ(messages[7]["origin"], "timeline");
  EXPECT_EQ(message_channels[8], events_channel);
  EXPECT_NE(messages[8]["message"].get<std::string>().find("timeline: link 1 from period 4"), std::string::npos)
      << messages[8];
  const std::uint64_t period_ns = static_cast<std::uint64_t>(scenario.period_ms) * 1000000ULL;
  EXPECT_EQ(log_times, (std::vector<std::uint64_t>{3 * period_ns, 3 * period_ns, 3 * period_ns, 3 * period_ns,
                                                   3 * period_ns, 3 * period_ns, 2 * period_ns, 4 * period_ns,
                                                   3 * period_ns}));
  EXPECT_EQ(recs.back().opcode, McapWriter::kFooter);
}

TEST(McapRecording, ChoosesMcapByTheExtension) {
  EXPECT_TRUE(is_mcap_path("run.mcap"));
  EXPECT_TRUE(is_mcap_path("/tmp/RUN.MCAP"));
  EXPECT_FALSE(is_mcap_path("run.csv"));
  EXPECT_FALSE(is_mcap_path("mcap"));
  EXPECT_FALSE(is_mcap_path("run.mcap.csv"));
}

// ---- the ros2 profile (ros2_bag.hpp): the parts that need no DDS ----

std::string msg_file(const std::string& name) {
  std::ifstream in(netkf::test::source_dir() / "netkf_msgs" / "msg" / (name + ".msg"), std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(Ros2Bag, MessageDefinitionsAreTheMsgTextsWithTheirDependenciesAppendedAsRosbag2Does) {
  EXPECT_EQ(ros2::message_definition("netkf_msgs", "Truth"), msg_file("Truth"));  // embedded byte for byte
  EXPECT_EQ(ros2::message_definition("netkf_msgs", "Estimate"), msg_file("Estimate"));
  const std::string separator = "\n" + std::string(80, '=') + "\nMSG: netkf_msgs/LinkSpec\n";
  EXPECT_EQ(ros2::message_definition("netkf_msgs", "LinkChange"), msg_file("LinkChange") + separator + msg_file("LinkSpec"));
  EXPECT_EQ(ros2::message_definition("netkf_msgs", "LinkStatus"), msg_file("LinkStatus") + separator + msg_file("LinkSpec"));
  EXPECT_THROW(ros2::message_definition("netkf_msgs", "Presence"), std::logic_error);  // not embedded: not recorded
  const std::string log = ros2::message_definition("rcl_interfaces", "Log");
  const auto time = log.find("\n" + std::string(80, '=') + "\nMSG: builtin_interfaces/Time\n");
  ASSERT_NE(time, std::string::npos) << log;
  EXPECT_NE(log.find("builtin_interfaces/Time stamp"), std::string::npos);
  EXPECT_NE(log.find("uint32 nanosec\n", time), std::string::npos);
}

TEST(Ros2Bag, DependenciesAreTheNonPrimitiveFieldTypes) {
  EXPECT_EQ(ros2::msg_dependencies("Time stamp\n", "builtin_interfaces"),
            (std::vector<std::string>{"builtin_interfaces/Time"}));
  EXPECT_EQ(ros2::msg_dependencies("Measurement[<=100] samples  # bounded\nuint64 run\n"),
            (std::vector<std::string>{"netkf_msgs/Measurement"}));
  EXPECT_EQ(ros2::msg_dependencies("# LinkSpec in a comment\nLinkKey[] keys\nstd_msgs/Header header\n"
                                   "int32 X=3\nstring<=8 name\nfloat64[3] v\n"),
            (std::vector<std::string>{"netkf_msgs/LinkKey", "std_msgs/Header"}));
}

TEST(Ros2Bag, OfferedQosIsRosbag2sYamlList) {
  const std::string y = ros2::offered_qos_profiles({/*reliable=*/true, /*transient_local=*/true, 1024});
  EXPECT_EQ(y.rfind("- history: 1\n  depth: 1024\n  reliability: 1\n  durability: 1\n", 0), 0u) << y;
  EXPECT_NE(ros2::offered_qos_profiles({false, false, 4}).find("reliability: 2\n  durability: 2\n"), std::string::npos);
}

TEST(Ros2Bag, ProfileNames) {
  EXPECT_EQ(mcap_profile_from_string("json"), McapProfile::json);
  EXPECT_EQ(mcap_profile_from_string("ros2"), McapProfile::ros2);
  EXPECT_THROW(mcap_profile_from_string("ros1"), std::invalid_argument);
  EXPECT_EQ(Recording::mcap_options("--record", std::string("run.mcap"), std::nullopt, nullptr).profile,
            McapProfile::json);
  const auto o = Recording::mcap_options("--record", std::string("dir/run.mcap"), std::string("ros2"), nullptr);
  EXPECT_EQ(o.profile, McapProfile::ros2);
  EXPECT_EQ(o.file_name, "run.mcap");
  EXPECT_THROW(Recording::mcap_options("--record", std::string("run.csv"), std::string("ros2"), nullptr), CommandError);
  EXPECT_THROW(Recording::mcap_options("--record", std::nullopt, std::string("json"), nullptr), CommandError);
  EXPECT_THROW(Recording::mcap_options("--out", std::string("x.mcap"), std::string("ros1"), nullptr), CommandError);
}

std::uint64_t u64_at(const std::string& s, std::size_t at) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(s[at + i]);
  return v;
}

TEST(McapWriterBytes, TheSummaryRepeatsSchemasAndChannelsCountsMessagesAndIndexesMetadata) {
  std::ostringstream out;
  McapWriter w(out, "netkf", "ros2", /*with_summary=*/true);
  const auto s = w.add_schema("pkg/msg/T", "ros2msg", "uint8 a\n");
  const auto a = w.add_channel(s, "/a", "cdr");
  const auto b = w.add_channel(s, "/b", "cdr");
  w.add_message(a, 50, 50, "x");
  w.add_message(b, 20, 20, "y");
  w.add_message(a, 70, 70, "z");
  w.add_metadata("rosbag2", {{"k", "v"}});
  w.finish();
  const std::string file = out.str();
  std::vector<int> ops;
  std::vector<std::size_t> offsets;
  std::size_t pos = 8;
  while (pos + 9 <= file.size() - 8) {
    ops.push_back(static_cast<unsigned char>(file[pos]));
    offsets.push_back(pos);
    pos += 9 + u64_at(file, pos + 1);
  }
  EXPECT_EQ(ops, (std::vector<int>{McapWriter::kHeader, McapWriter::kSchema, McapWriter::kChannel, McapWriter::kChannel,
                                   McapWriter::kMessage, McapWriter::kMessage, McapWriter::kMessage,
                                   McapWriter::kMetadata, McapWriter::kDataEnd, McapWriter::kSchema,
                                   McapWriter::kChannel, McapWriter::kChannel, McapWriter::kStatistics,
                                   McapWriter::kMetadataIndex, McapWriter::kFooter}));
  // The summary's schema and channels are the data section's records, byte for byte.
  const auto record_at = [&](std::size_t i) { return file.substr(offsets[i], offsets[i + 1] - offsets[i]); };
  EXPECT_EQ(record_at(9), record_at(1));
  EXPECT_EQ(record_at(10), record_at(2));
  EXPECT_EQ(record_at(11), record_at(3));
  // Statistics: 3 messages, 1 schema, 2 channels, 0 attachments, 1 metadata, 0 chunks, times 20..70,
  // channel counts {0: 2, 1: 1}.
  const std::string stats = record_at(12).substr(9);
  EXPECT_EQ(u64_at(stats, 0), 3u);
  EXPECT_EQ(static_cast<unsigned char>(stats[8]), 1);
  EXPECT_EQ(u32_at(stats, 10), 2u);
  EXPECT_EQ(u32_at(stats, 18), 1u);
  EXPECT_EQ(u64_at(stats, 26), 20u);
  EXPECT_EQ(u64_at(stats, 34), 70u);
  EXPECT_EQ(u32_at(stats, 42), 20u);  // two entries of u16 + u64
  EXPECT_EQ(u64_at(stats, 48), 2u);
  EXPECT_EQ(u64_at(stats, 58), 1u);
  // The metadata index points at the metadata record, with its whole length.
  const std::string index = record_at(13).substr(9);
  EXPECT_EQ(u64_at(index, 0), offsets[7]);
  EXPECT_EQ(u64_at(index, 8), offsets[8] - offsets[7]);
  std::size_t at = 16;
  EXPECT_EQ(string_at(index, at), "rosbag2");
  // The footer's summary_start is the first record after Data End.
  EXPECT_EQ(u64_at(file, offsets[14] + 9), offsets[9]);
}

/// A stand-in codec: the unit tests have no DDS (the real one is tested by the e2e and Python tests).
class FakeCodec final : public ros2::Ros2Codec {
 public:
  ros2::Qos qos(ros2::Channel) const override { return {true, false, 7}; }
  std::string truth(const Truth& t) const override { return "truth " + std::to_string(t.k); }
  std::string estimate(const Estimate& e) const override { return "estimate " + std::to_string(e.k); }
  std::string delivered(const DeliveredMeasurement& d) const override { return "delivered " + std::to_string(d.k); }
  std::string link_status(const LinkStatus& l) const override { return "status " + std::to_string(l.sensor_id); }
  std::string link_change(const LinkChange& c) const override { return "change " + std::to_string(c.at_period); }
  std::string log(std::uint64_t t, std::uint8_t level, std::string_view, std::string_view text) const override {
    return "log " + std::to_string(t) + " " + std::to_string(level) + " " + std::string(text);
  }
  Truth decode_truth(std::string_view) const override { return {}; }
  DeliveredMeasurement decode_delivered(std::string_view) const override { return {}; }
};

TEST(McapRecording, TheRos2ProfileWritesRosbag2sLayout) {
  std::ostringstream out;
  const Scenario scenario = default_scenario();
  EXPECT_THROW(McapRecorder(out, scenario, false, McapOptions{McapProfile::ros2, nullptr, "x.mcap"}),
               std::invalid_argument);
  std::ostringstream bag;
  {
    McapRecorder r(bag, scenario, /*with_delivered=*/false,
                   McapOptions{McapProfile::ros2, std::make_shared<FakeCodec>(), "run.mcap"});
    r.truth(Truth{3, 3 * scenario.period_s(), std::vector<double>(scenario.state_dim(), 0.5), {}});
    LinkStatus l;
    l.sensor_id = scenario.sensors[0].id;
    l.link = scenario.sensors[0].link;
    r.link_status(l);
    LinkChange c;
    c.sensor_id = 1;
    c.at_period = 2;
    c.origin = netkf::LinkChange::Origin::timeline;
    c.link = scenario.sensors[0].link;
    r.link_change(c);  // a timeline step: the change and its event
    r.link_change(c);  // a transient-local repeat: written once
    r.finish();
    EXPECT_EQ(r.messages(), 4u);
    EXPECT_EQ(r.events(), 1u);
  }
  const std::string file = bag.str();
  const auto recs = records(file);
  std::size_t at = 0;
  EXPECT_EQ(string_at(recs[0].content, at), "ros2");
  std::vector<std::string> topics, schemas, messages;
  std::map<std::string, std::string> metadata;
  for (const auto& rec : recs) {
    if (rec.opcode == McapWriter::kSchema && schemas.size() < 5) {
      std::size_t p = 2;
      schemas.push_back(string_at(rec.content, p));
      EXPECT_EQ(string_at(rec.content, p), "ros2msg");
    } else if (rec.opcode == McapWriter::kChannel && topics.size() < 5) {
      std::size_t p = 4;
      topics.push_back(string_at(rec.content, p));
      EXPECT_EQ(string_at(rec.content, p), "cdr");
      p += 4;  // the map's byte length
      EXPECT_EQ(string_at(rec.content, p), "offered_qos_profiles");
      EXPECT_EQ(string_at(rec.content, p), ros2::offered_qos_profiles({true, false, 7}));
    } else if (rec.opcode == McapWriter::kMessage) {
      messages.push_back(rec.content.substr(22));
    } else if (rec.opcode == McapWriter::kMetadata) {
      std::size_t p = 0;
      EXPECT_EQ(string_at(rec.content, p), "rosbag2");
      p += 4;
      while (p < rec.content.size()) {
        const std::string key = string_at(rec.content, p);
        metadata[key] = string_at(rec.content, p);
      }
    }
  }
  EXPECT_EQ(topics, (std::vector<std::string>{"/netkf/truth", "/netkf/estimate", "/netkf/link/status",
                                              "/netkf/link/change", "/rosout"}));
  EXPECT_EQ(schemas, (std::vector<std::string>{"netkf_msgs/msg/Truth", "netkf_msgs/msg/Estimate",
                                               "netkf_msgs/msg/LinkStatus", "netkf_msgs/msg/LinkChange",
                                               "rcl_interfaces/msg/Log"}));
  ASSERT_EQ(messages.size(), 4u);
  EXPECT_EQ(messages[0], "truth 3");
  EXPECT_EQ(messages[1], "status " + std::to_string(scenario.sensors[0].id));
  EXPECT_EQ(messages[2], "change 2");
  // The timeline step's event at the newest record's time (period 3), INFO.
  const std::uint64_t period_ns = static_cast<std::uint64_t>(scenario.period_ms) * 1000000ULL;
  EXPECT_EQ(messages[3].rfind("log " + std::to_string(3 * period_ns) + " 20 timeline: link 1 from period 2", 0), 0u)
      << messages[3];
  EXPECT_EQ(metadata["ROS_DISTRO"], std::string(ros2::kRosDistro));
  const std::string& yaml = metadata["serialized_metadata"];
  EXPECT_NE(yaml.find("message_count: 4\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("      name: /netkf/link/change\n      type: netkf_msgs/msg/LinkChange\n"), std::string::npos);
  EXPECT_NE(yaml.find("relative_file_paths:\n  - \"run.mcap\"\n"), std::string::npos);
  EXPECT_EQ(recs.back().opcode, McapWriter::kFooter);
}

}  // namespace
}  // namespace netkf::cli
