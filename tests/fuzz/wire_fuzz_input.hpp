#pragma once
// The wire fuzzer's input format, shared with the seed generator (make_wire_corpus.cpp):
// byte 0 picks the wire type (modulo kWireKinds), the rest is its serialised sample as
// Fast DDS hands it to the type's deserialize (CDR with the 4-byte encapsulation header).
#include <cstdint>

namespace netkf::fuzz {

enum class WireKind : std::uint8_t {
  measurement,
  truth,
  tick,
  control_input,
  estimate,
  link_spec,
  link_control,
  link_status,
  link_change,
  measurement_batch,
};
inline constexpr std::uint8_t kWireKinds = 10;

}  // namespace netkf::fuzz
