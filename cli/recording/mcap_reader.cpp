// Reading the messages of an MCAP file (mcap_reader.hpp).
#include "mcap_reader.hpp"

#include <cstring>
#include <map>
#include <vector>

#include "mcap_writer.hpp"

namespace netkf::cli {
namespace {

constexpr std::uint8_t kChunk = 0x06;

// A bounds-checked cursor over one record's content.
class Cursor {
 public:
  Cursor(std::string_view bytes, const std::string& where) : bytes_(bytes), where_(where) {}
  template <typename T>
  T integer() {
    need(sizeof(T));
    T v = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i) v |= static_cast<T>(static_cast<std::uint8_t>(bytes_[at_ + i])) << (8 * i);
    at_ += sizeof(T);
    return v;
  }
  std::string_view string() {
    const auto n = integer<std::uint32_t>();
    return take(n);
  }
  std::string_view take(std::uint64_t n) {
    need(n);
    const std::string_view s = bytes_.substr(at_, n);
    at_ += n;
    return s;
  }
  std::string_view rest() { return take(bytes_.size() - at_); }
  bool done() const { return at_ >= bytes_.size(); }

 private:
  void need(std::uint64_t n) const {
    if (n > bytes_.size() - at_) throw McapReadError(where_ + ": a record is shorter than its fields");
  }
  std::string_view bytes_;
  std::size_t at_ = 0;
  const std::string& where_;
};

class Reader {
 public:
  Reader(const std::string& name, const std::function<void(const McapMessage&)>& on_message)
      : name_(name), on_message_(on_message) {}

  // One record; false at the footer (the end of the data).
  bool record(std::uint8_t opcode, std::string_view content) {
    Cursor c(content, name_);
    switch (opcode) {
      case McapWriter::kChannel: {
        const auto id = c.integer<std::uint16_t>();
        (void)c.integer<std::uint16_t>();  // schema id
        topics_[id] = std::string(c.string());
        return true;
      }
      case McapWriter::kMessage: {
        const auto id = c.integer<std::uint16_t>();
        (void)c.integer<std::uint32_t>();  // sequence
        McapMessage m;
        m.log_time_ns = c.integer<std::uint64_t>();
        (void)c.integer<std::uint64_t>();  // publish time
        m.data = c.rest();
        const auto topic = topics_.find(id);
        if (topic == topics_.end())
          throw McapReadError(name_ + ": a message on channel " + std::to_string(id) + " before its Channel record");
        m.topic = topic->second;
        on_message_(m);
        return true;
      }
      case kChunk: return chunk(c);
      case McapWriter::kFooter: return false;
      default: return true;  // header, schema, indexes, attachments, metadata: not needed
    }
  }

 private:
  bool chunk(Cursor& c) {
    (void)c.integer<std::uint64_t>();  // message start time
    (void)c.integer<std::uint64_t>();  // message end time
    (void)c.integer<std::uint64_t>();  // uncompressed size
    (void)c.integer<std::uint32_t>();  // uncompressed crc
    const std::string_view compression = c.string();
    if (!compression.empty())
      throw McapReadError(name_ + ": a chunk compressed with '" + std::string(compression) + "' (only uncompressed chunks are read)");
    Cursor records(c.take(c.integer<std::uint64_t>()), name_);
    while (!records.done()) {
      const auto opcode = records.integer<std::uint8_t>();
      const auto length = records.integer<std::uint64_t>();
      record(opcode, records.take(length));
    }
    return true;
  }

  const std::string& name_;
  const std::function<void(const McapMessage&)>& on_message_;
  std::map<std::uint16_t, std::string> topics_;
};

}  // namespace

void read_mcap_messages(std::istream& in, const std::string& name, const std::function<void(const McapMessage&)>& on_message,
                        std::uint64_t max_record_bytes) {
  std::string magic(McapWriter::magic().size(), '\0');
  if (!in.read(magic.data(), static_cast<std::streamsize>(magic.size())) || magic != McapWriter::magic())
    throw McapReadError(name + ": not an MCAP file (no MCAP magic at its start)");
  Reader reader(name, on_message);
  std::string content;
  while (true) {
    char head[9];
    in.read(head, sizeof head);
    if (in.gcount() == 0) return;  // no footer: a cut file, read up to its last whole record
    if (in.gcount() != static_cast<std::streamsize>(sizeof head)) return;
    std::uint64_t length = 0;
    for (int i = 0; i < 8; ++i) length |= static_cast<std::uint64_t>(static_cast<std::uint8_t>(head[1 + i])) << (8 * i);
    if (length > max_record_bytes)
      throw McapReadError(name + ": a record of " + std::to_string(length) + " bytes (more than " +
                          std::to_string(max_record_bytes) + ")");
    content.resize(length);
    if (!in.read(content.data(), static_cast<std::streamsize>(length))) return;  // cut inside a record
    if (!reader.record(static_cast<std::uint8_t>(head[0]), content)) return;
  }
}

}  // namespace netkf::cli
