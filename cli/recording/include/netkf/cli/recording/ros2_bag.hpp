#pragma once
// The ROS 2 profile of the MCAP recording (`--mcap-profile ros2`): the layout rosbag2's MCAP
// storage plugin (rosbag2_storage_mcap) writes, so that `ros2 bag info/play` and Foxglove's
// ROS 2 panels read a netkf recording (docs/recording.md, "Bags ROS 2 can play"):
//   header profile "ros2"; one channel per recorded topic under its ROS 2 name (/netkf/truth);
//   schema encoding "ros2msg", name netkf_msgs/msg/TYPE, data the .msg text with its
//   dependencies appended as rosbag2 concatenates them; message encoding "cdr" (the wire
//   sample's bytes with their encapsulation header, as DDS carries them); channel metadata
//   offered_qos_profiles; a Metadata record "rosbag2" with the bag's YAML description.
//
// The CDR itself needs the DDS type support (Fast CDR): it comes in through Ros2Codec, which
// the commands that have DDS provide (ros2_cdr_codec.hpp); this part needs no DDS.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "netkf/records/delivered.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/link_change.hpp"
#include "netkf/records/link_status.hpp"
#include "netkf/records/truth.hpp"

namespace netkf::cli {

/// How an MCAP recording encodes its messages.
enum class McapProfile { json, ros2 };
/// "json" | "ros2"; throws std::invalid_argument on anything else.
McapProfile mcap_profile_from_string(std::string_view s);
std::string to_string(McapProfile p);

namespace ros2 {

/// The ROS 2 interface package of netkf's wire types (netkf_msgs/).
inline constexpr std::string_view kPackage = "netkf_msgs";
/// The ROS distribution the bag's metadata names (rosbag2 shows it; nothing depends on it).
inline constexpr std::string_view kRosDistro = "humble";

/// The recorded topics: ROS 2 name, message type (PACKAGE/msg/TYPE) and the QoS the writer on
/// the DDS topic offers. rosout: the run's events (the json profile's netkf/events) as ROS 2's
/// log messages, rcl_interfaces/msg/Log on /rosout, which Foxglove's Log panel lists.
enum class Channel { truth, estimate, delivered, link_status, link_change, rosout };
struct Qos {
  bool reliable = true;
  bool transient_local = false;
  int depth = 1;
};
struct TopicInfo {
  std::string_view topic;    // "/netkf/truth"
  std::string_view package;  // "netkf_msgs"
  std::string_view type;     // "Truth"
  std::string schema_name() const;  // "netkf_msgs/msg/Truth"
};
TopicInfo topic_info(Channel c);

/// rcl_interfaces/msg/Log's levels (its constants).
inline constexpr std::uint8_t kLogInfo = 20, kLogWarn = 30, kLogError = 40;

/// PACKAGE/msg/TYPE's definition as rosbag2 stores it: the type's .msg text, then for each
/// type it uses (depth first, each once, in name order at each level) a line of 80 '=', a
/// line "MSG: PACKAGE/DEP" and DEP's text. Throws std::logic_error for a type netkf does not
/// have the text of (netkf_msgs' embedded ones, rcl_interfaces/Log, builtin_interfaces/Time).
std::string message_definition(std::string_view package, std::string_view type);
/// The non-primitive field types of a .msg text of `package` (PACKAGE/LinkSpec for a field
/// "LinkSpec link").
std::vector<std::string> msg_dependencies(std::string_view text, std::string_view package = kPackage);

/// The channel metadata value offered_qos_profiles: a YAML list with one profile (the rmw
/// enums as integers, the form every rosbag2 since Foxy reads; durations 0 = the default).
std::string offered_qos_profiles(const Qos& q);

/// One topic of the bag metadata.
struct BagTopic {
  std::string name, type;  // "/netkf/truth", "netkf_msgs/msg/Truth"
  Qos qos;
  std::uint64_t messages = 0;
};
/// rosbag2's metadata YAML (BagMetadata, version 8), the value of the `rosbag2` Metadata
/// record's key serialized_metadata.
std::string bag_metadata_yaml(const std::vector<BagTopic>& topics, const std::string& file_name,
                              std::uint64_t start_ns, std::uint64_t end_ns);

/// The messages of the recorded topics as CDR (XCDR1 with the 4-byte encapsulation header),
/// and back for `netkf trace extract`: the wire type of each (idl/netkf.idl, whose .msg twins
/// are netkf_msgs/msg/). Fields the records do not keep are 0 (the run id; the stamps of
/// link status and change; the truth's run).
class Ros2Codec {
 public:
  virtual ~Ros2Codec() = default;
  virtual Qos qos(Channel c) const = 0;
  virtual std::string truth(const Truth& t) const = 0;
  virtual std::string estimate(const Estimate& e) const = 0;
  virtual std::string delivered(const DeliveredMeasurement& d) const = 0;
  virtual std::string link_status(const LinkStatus& l) const = 0;
  virtual std::string link_change(const LinkChange& c) const = 0;
  /// rcl_interfaces/msg/Log: an event at `stamp_ns` (level kLogInfo, ...), logger `name`.
  virtual std::string log(std::uint64_t stamp_ns, std::uint8_t level, std::string_view name,
                          std::string_view text) const = 0;
  /// Decoding: throws std::runtime_error for bytes that are not the type's CDR.
  virtual Truth decode_truth(std::string_view cdr) const = 0;
  virtual DeliveredMeasurement decode_delivered(std::string_view cdr) const = 0;
};

}  // namespace ros2
}  // namespace netkf::cli
