#include "netkf/cli/recording/ros2_cdr_codec.hpp"

#include <cmath>
#include <cstring>
#include <stdexcept>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>

#include "netkf/dds/conversions.hpp"
#include "netkf/dds/topics.hpp"

namespace netkf::cli::ros2 {
namespace {

using eprosima::fastrtps::rtps::SerializedPayload_t;

template <class Wire>
std::string serialize(Wire w) {
  typename dds::PubSubTypeOf<Wire>::type type;
  SerializedPayload_t payload(type.getSerializedSizeProvider(&w)());
  if (!type.serialize(&w, &payload)) throw std::runtime_error("CDR: a sample did not fit its serialized size");
  return std::string(reinterpret_cast<const char*>(payload.data), payload.length);
}

template <class Wire>
Wire deserialize(std::string_view cdr, const char* what) {
  typename dds::PubSubTypeOf<Wire>::type type;
  SerializedPayload_t payload(static_cast<std::uint32_t>(cdr.size()));
  std::memcpy(payload.data, cdr.data(), cdr.size());
  payload.length = static_cast<std::uint32_t>(cdr.size());
  Wire w;
  if (cdr.size() < 4 || !type.deserialize(&payload, &w))
    throw std::runtime_error(std::string("not the CDR of a ") + what);
  return w;
}

// A record's numbers as the conversions of dds/ take them (the one place records become wire samples).
Vector as_vector(const std::vector<double>& v) {
  return Eigen::Map<const Vector>(v.data(), static_cast<Eigen::Index>(v.size()));
}

Qos qos_of(const dds::TopicQos& q) { return {q.reliable, q.transient_local, q.depth}; }

class FastCdrCodec final : public Ros2Codec {
 public:
  Qos qos(Channel c) const override {
    switch (c) {
      case Channel::truth:
        return qos_of(dds::topics::truth.qos);
      case Channel::estimate:
        return qos_of(dds::topics::estimate.qos);
      case Channel::delivered:
        return qos_of(dds::topics::delivered_measurement.qos);
      case Channel::link_status:
        return qos_of(dds::topics::link_status.qos);
      case Channel::link_change:
        return qos_of(dds::topics::link_change.qos);
      case Channel::rosout:
        return {true, true, 1000};  // rcl's /rosout publisher: reliable, transient local, keep last 1000
    }
    throw std::logic_error("unknown ROS 2 channel");
  }

  std::string truth(const Truth& t) const override {
    return serialize(dds::make_truth(static_cast<std::uint64_t>(t.k), t.t, as_vector(t.x), as_vector(t.u),
                                     t.input_arrived));
  }

  std::string estimate(const Estimate& e) const override { return serialize(dds::to_wire(e)); }

  std::string delivered(const DeliveredMeasurement& d) const override {
    // The record keeps the stamp in seconds.
    return serialize(dds::make_measurement(d.sensor_id, static_cast<std::uint64_t>(d.k),
                                           static_cast<std::int64_t>(std::llround(d.stamp * 1e9)), as_vector(d.y)));
  }

  std::string link_status(const LinkStatus& l) const override { return serialize(dds::to_wire(l, 0)); }

  std::string link_change(const LinkChange& c) const override { return serialize(dds::to_wire(c, 0)); }

  // rcl_interfaces/msg/Log has no wire type in idl/netkf.idl: its fields are serialized one by
  // one with Fast CDR (the alignment and encapsulation its generated types use).
  std::string log(std::uint64_t stamp_ns, std::uint8_t level, std::string_view name,
                  std::string_view text) const override {
    const std::size_t bound = 64 + name.size() + text.size();
    std::string buffer(bound, '\0');
    eprosima::fastcdr::FastBuffer fast(buffer.data(), buffer.size());
    eprosima::fastcdr::Cdr cdr(fast, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
    cdr.serialize_encapsulation();
    cdr << static_cast<std::int32_t>(stamp_ns / 1000000000ULL) << static_cast<std::uint32_t>(stamp_ns % 1000000000ULL);
    cdr << level << std::string(name) << std::string(text) << std::string() << std::string() << std::uint32_t{0};
    buffer.resize(cdr.getSerializedDataLength());
    return buffer;
  }

  Truth decode_truth(std::string_view cdr) const override {
    const auto w = deserialize<wire::Truth>(cdr, "netkf_msgs/msg/Truth");
    return Truth{static_cast<std::int64_t>(w.k()), w.t(), w.x(), w.applied_input(), w.input_arrived()};
  }

  DeliveredMeasurement decode_delivered(std::string_view cdr) const override {
    const auto w = deserialize<wire::Measurement>(cdr, "netkf_msgs/msg/Measurement");
    return DeliveredMeasurement{w.sensor_id(), static_cast<std::int64_t>(w.k()), static_cast<double>(w.stamp_ns()) * 1e-9,
                           w.y()};
  }
};

}  // namespace

std::shared_ptr<const Ros2Codec> make_fastcdr_codec() { return std::make_shared<FastCdrCodec>(); }

}  // namespace netkf::cli::ros2
