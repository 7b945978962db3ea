#include "mcap_writer.hpp"

#include <stdexcept>

namespace netkf::cli {

namespace {

// Little-endian appenders of the spec's primitive types.
void put_u16(std::string& s, std::uint16_t v) {
  for (int i = 0; i < 2; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xffU));
}
void put_u32(std::string& s, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xffU));
}
void put_u64(std::string& s, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xffU));
}
std::uint32_t length32(std::string_view v) {
  if (v.size() > 0xffffffffULL) throw std::length_error("MCAP: a string or byte array longer than 4 GiB");
  return static_cast<std::uint32_t>(v.size());
}
// String and byte array are both <u32 length><bytes>.
void put_string(std::string& s, std::string_view v) {
  put_u32(s, length32(v));
  s.append(v);
}

void put_map(std::string& s, const std::map<std::string, std::string>& map) {
  std::string entries;
  for (const auto& [key, value] : map) {
    put_string(entries, key);
    put_string(entries, value);
  }
  put_u32(s, length32(entries));  // a map is prefixed by its length in bytes
  s += entries;
}

/// A record as McapWriter::record writes it (the summary repeats schemas and channels).
std::string framed(std::uint8_t opcode, const std::string& content) {
  std::string r;
  r.push_back(static_cast<char>(opcode));
  put_u64(r, content.size());
  return r + content;
}

}  // namespace

std::string_view McapWriter::magic() {
  static constexpr char bytes[] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};
  return std::string_view(bytes, sizeof bytes);
}

McapWriter::McapWriter(std::ostream& out, std::string_view library, std::string_view profile, bool with_summary)
    : out_(out), with_summary_(with_summary) {
  out_.write(magic().data(), static_cast<std::streamsize>(magic().size()));
  position_ += magic().size();
  std::string header;
  put_string(header, profile);
  put_string(header, library);
  record(kHeader, header);
}

void McapWriter::record(std::uint8_t opcode, const std::string& content) {
  if (finished_) throw std::logic_error("MCAP: a record after the footer");
  std::string prefix;
  prefix.push_back(static_cast<char>(opcode));
  put_u64(prefix, content.size());
  out_.write(prefix.data(), static_cast<std::streamsize>(prefix.size()));
  out_.write(content.data(), static_cast<std::streamsize>(content.size()));
  position_ += prefix.size() + content.size();
}



std::uint16_t McapWriter::add_schema(std::string_view name, std::string_view encoding, std::string_view data) {
  if (next_schema_ == 0) throw std::length_error("MCAP: too many schemas");
  const std::uint16_t id = next_schema_++;
  std::string c;
  put_u16(c, id);
  put_string(c, name);
  put_string(c, encoding);
  put_string(c, data);
  record(kSchema, c);
  if (with_summary_) summary_records_ += framed(kSchema, c);
  return id;
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, std::string_view topic,
                                      std::string_view message_encoding,
                                      const std::map<std::string, std::string>& metadata) {
  if (next_channel_ == 0xffff) throw std::length_error("MCAP: too many channels");
  const std::uint16_t id = next_channel_++;
  std::string c;
  put_u16(c, id);
  put_u16(c, schema_id);
  put_string(c, topic);
  put_string(c, message_encoding);
  put_map(c, metadata);
  record(kChannel, c);
  if (with_summary_) summary_records_ += framed(kChannel, c);
  sequence_[id] = 0;
  channel_messages_[id] = 0;
  return id;
}

void McapWriter::add_message(std::uint16_t channel_id, std::uint64_t log_time_ns, std::uint64_t publish_time_ns,
                             std::string_view data) {
  auto seq = sequence_.find(channel_id);
  if (seq == sequence_.end()) throw std::logic_error("MCAP: a message on a channel that was not added");
  std::string c;
  c.reserve(22 + data.size());
  put_u16(c, channel_id);
  put_u32(c, seq->second++);
  put_u64(c, log_time_ns);
  put_u64(c, publish_time_ns);
  c.append(data);  // the rest of the record: no length prefix
  record(kMessage, c);
  if (messages_ == 0 || log_time_ns < first_log_time_) first_log_time_ = log_time_ns;
  if (messages_ == 0 || log_time_ns > last_log_time_) last_log_time_ = log_time_ns;
  ++messages_;
  ++channel_messages_[channel_id];
}

std::uint64_t McapWriter::channel_messages(std::uint16_t channel_id) const {
  auto it = channel_messages_.find(channel_id);
  return it == channel_messages_.end() ? 0 : it->second;
}

void McapWriter::add_metadata(std::string_view name, const std::map<std::string, std::string>& metadata) {
  std::string c;
  put_string(c, name);
  put_map(c, metadata);
  const std::uint64_t offset = position_;
  record(kMetadata, c);
  metadata_.push_back({offset, position_ - offset, std::string(name)});
}

void McapWriter::write_summary() {
  out_.write(summary_records_.data(), static_cast<std::streamsize>(summary_records_.size()));
  position_ += summary_records_.size();
  std::string stats;
  put_u64(stats, messages_);
  put_u16(stats, static_cast<std::uint16_t>(next_schema_ - 1));
  put_u32(stats, next_channel_);
  put_u32(stats, 0);  // attachments
  put_u32(stats, static_cast<std::uint32_t>(metadata_.size()));
  put_u32(stats, 0);  // chunks
  put_u64(stats, first_log_time_);
  put_u64(stats, last_log_time_);
  std::string counts;
  for (const auto& [channel, n] : channel_messages_) {
    put_u16(counts, channel);
    put_u64(counts, n);
  }
  put_u32(stats, length32(counts));
  stats += counts;
  record(kStatistics, stats);
  for (const auto& m : metadata_) {
    std::string index;
    put_u64(index, m.offset);
    put_u64(index, m.length);
    put_string(index, m.name);
    record(kMetadataIndex, index);
  }
}

void McapWriter::finish() {
  if (finished_) return;
  std::string data_end;
  put_u32(data_end, 0);  // data section CRC: 0 = not computed
  record(kDataEnd, data_end);
  const std::uint64_t summary_start = with_summary_ ? position_ : 0;
  if (with_summary_) write_summary();
  std::string footer;
  put_u64(footer, summary_start);  // 0: no summary section
  put_u64(footer, 0);  // summary_offset_start: no summary offset section
  put_u32(footer, 0);  // summary_crc
  record(kFooter, footer);
  out_.write(magic().data(), static_cast<std::streamsize>(magic().size()));
  out_.flush();
  finished_ = true;
}

}  // namespace netkf::cli
