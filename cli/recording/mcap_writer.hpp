#pragma once
// A minimal MCAP writer (https://mcap.dev/spec, major version 0): the unchunked,
// unindexed subset. The file is
//   magic, Header, Schema/Channel/Message/Metadata records in the order written, DataEnd,
//   [summary: the Schema and Channel records again, Statistics, a Metadata Index per
//   Metadata record], Footer, magic
// with no CRCs (0: "not computed", which the specification allows). The summary section is
// written only when asked for (with_summary): a reader that opens the file from its end
// (rosbag2's `ros2 bag info` reads the Statistics and finds the `rosbag2` Metadata record
// through its index) needs it; readers that stream the data section (@mcap/core's
// McapStreamReader, Foxglove, PlotJuggler) read either form.
//
// Every record is <opcode u8><content length u64 LE><content>; integers are little endian;
// a string is <length u32><bytes>; a byte array is <length u32><bytes>; a map of strings is
// <byte length u32> followed by its key/value strings.
//
// Nothing here knows about DDS or netkf's messages (record_mcap.hpp maps those).
#include <cstdint>
#include <map>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace netkf::cli {

class McapWriter {
 public:
  /// Writes the leading magic and the Header (profile "" = no well-known profile).
  explicit McapWriter(std::ostream& out, std::string_view library = "netkf", std::string_view profile = "",
                      bool with_summary = false);
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  /// A Schema record; returns its id (1, 2, ...; 0 is reserved for "no schema").
  std::uint16_t add_schema(std::string_view name, std::string_view encoding, std::string_view data);
  /// A Channel record; returns its id (0, 1, ...).
  std::uint16_t add_channel(std::uint16_t schema_id, std::string_view topic, std::string_view message_encoding,
                            const std::map<std::string, std::string>& metadata = {});
  /// A Message record on `channel_id`; its sequence number counts the channel's messages
  /// from 0. Times are nanoseconds.
  void add_message(std::uint16_t channel_id, std::uint64_t log_time_ns, std::uint64_t publish_time_ns,
                   std::string_view data);

  /// A Metadata record: a name and its key/value strings.
  void add_metadata(std::string_view name, const std::map<std::string, std::string>& metadata);

  /// The earliest and latest log time written (0 before the first message).
  std::uint64_t first_log_time() const { return first_log_time_; }
  std::uint64_t last_log_time() const { return last_log_time_; }
  /// Messages written on `channel_id` so far.
  std::uint64_t channel_messages(std::uint16_t channel_id) const;

  /// DataEnd, [the summary section,] Footer and the closing magic; nothing can be written after it. Idempotent.
  void finish();
  bool finished() const { return finished_; }
  std::uint64_t messages() const { return messages_; }

  // Record opcodes (the spec's names).
  static constexpr std::uint8_t kHeader = 0x01;
  static constexpr std::uint8_t kFooter = 0x02;
  static constexpr std::uint8_t kSchema = 0x03;
  static constexpr std::uint8_t kChannel = 0x04;
  static constexpr std::uint8_t kMessage = 0x05;
  static constexpr std::uint8_t kStatistics = 0x0b;
  static constexpr std::uint8_t kMetadata = 0x0c;
  static constexpr std::uint8_t kMetadataIndex = 0x0d;
  static constexpr std::uint8_t kDataEnd = 0x0f;
  /// The 8 magic bytes that open and close a file: 0x89 "MCAP" '0' "\r\n".
  static std::string_view magic();

 private:
  void record(std::uint8_t opcode, const std::string& content);
  void write_summary();

  std::ostream& out_;
  bool with_summary_ = false;
  std::uint64_t position_ = 0;  // bytes written: a summary indexes records by their offset
  std::uint64_t first_log_time_ = 0, last_log_time_ = 0;
  std::string summary_records_;  // with_summary: the Schema and Channel records, repeated in the summary
  struct MetadataAt {
    std::uint64_t offset, length;
    std::string name;
  };
  std::vector<MetadataAt> metadata_;
  std::uint16_t next_schema_ = 1;
  std::uint16_t next_channel_ = 0;
  std::map<std::uint16_t, std::uint32_t> sequence_;  // channel -> next sequence number
  std::map<std::uint16_t, std::uint64_t> channel_messages_;
  std::uint64_t messages_ = 0;
  bool finished_ = false;
};

}  // namespace netkf::cli
