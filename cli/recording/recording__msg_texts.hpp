#pragma once
// The .msg texts of netkf_msgs (netkf_msgs/msg/NAME.msg), embedded at build time by
// cmake/EmbedMsgs.cmake (the generated ros2_msg_texts.cpp).
#include <string_view>

namespace netkf::cli::ros2 {

/// The text of netkf_msgs/msg/NAME.msg as committed ("" for a type that was not embedded).
std::string_view msg_text(std::string_view name);

}  // namespace netkf::cli::ros2
