#pragma once
// What the link's sources share (core/src/links/): private to this room.
#include <string>

namespace netkf::link_detail {

/// A number as a message shows it (%.6g).
std::string number_text(double v);
/// Throws LinkError(name) unless value is in [0, 1] (NaN included).
void check_probability(const char* name, double value);

}  // namespace netkf::link_detail
