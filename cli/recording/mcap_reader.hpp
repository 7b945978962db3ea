#pragma once
// A minimal MCAP reader (https://mcap.dev/spec, major version 0) for the files McapWriter
// writes: it streams the data section and returns each message with its channel's topic.
// Chunks are read when uncompressed; a compressed chunk, a bad magic or a record running
// past the end of the file is refused with McapReadError (a file cut by `kill -9` ends at
// its last whole record, as streaming readers do). Nothing here knows netkf's messages.
#include <cstdint>
#include <functional>
#include <istream>
#include <stdexcept>
#include <string>
#include <string_view>

namespace netkf::cli {

class McapReadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct McapMessage {
  std::string_view topic;
  std::uint64_t log_time_ns = 0;
  std::string_view data;
};

/// Calls `on_message` for every message, in file order. `name` names the file in errors.
/// Records are bounded (max_record_bytes); a larger one is refused, not allocated.
void read_mcap_messages(std::istream& in, const std::string& name, const std::function<void(const McapMessage&)>& on_message,
                        std::uint64_t max_record_bytes = 64u << 20);

}  // namespace netkf::cli
