#pragma once
// The answer of a link's owner (the channel emulator, `netkf relay`) to one link change request
// (idl/netkf.idl, LinkControlReply).
#include <cstdint>
#include <string>

namespace netkf {

struct LinkReply {
  std::uint64_t request_id = 0;
  int sensor_id = 0;
  bool applied = false;
  std::string reason;  // why it was refused (empty when applied)
};

}  // namespace netkf
