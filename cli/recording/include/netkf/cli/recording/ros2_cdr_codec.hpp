#pragma once
// The CDR of the ros2 MCAP profile (ros2_bag.hpp), with Fast DDS's type support: each record
// becomes its wire sample (the conversions of dds/, the inverse of live_bus.cpp's) and the
// generated PubSubType serializes it exactly as a DataWriter puts it on the wire, so a bag's
// bytes are the DDS samples ROS 2 reads. Built only with DDS (NETKF_WITH_DDS).
#include <memory>

#include "netkf/cli/recording/ros2_bag.hpp"

namespace netkf::cli::ros2 {

std::shared_ptr<const Ros2Codec> make_fastcdr_codec();

}  // namespace netkf::cli::ros2
