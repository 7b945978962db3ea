#include "netkf/dds/topics.hpp"

#include <stdexcept>

namespace netkf::dds {

std::string dds_topic_name(std::string_view name, TopicNaming naming) {
  if (naming == TopicNaming::netkf) return std::string(name);
  return "rt/" + std::string(name);
}

std::string dds_type_name(std::string_view wire_type_name, TopicNaming naming) {
  if (naming == TopicNaming::netkf) return std::string(wire_type_name);
  constexpr std::string_view wire_module = "netkf::wire::";
  if (wire_type_name.substr(0, wire_module.size()) != wire_module ||
      wire_type_name.size() == wire_module.size() ||
      wire_type_name.find(':', wire_module.size()) != std::string_view::npos)
    throw std::invalid_argument("no ROS 2 name for the type " + std::string(wire_type_name) +
                                " (only netkf::wire's types have one)");
  // rosidl's DDS name of package/msg/Name: package::msg::dds_::Name_ (rosidl_generator_dds_idl).
  return "netkf_msgs::msg::dds_::" + std::string(wire_type_name.substr(wire_module.size())) + "_";
}

TopicQos naming_qos(TopicQos qos, TopicNaming naming) {
  if (naming == TopicNaming::ros2) qos.exclusive_ownership = false;
  return qos;
}

}  // namespace netkf::dds
