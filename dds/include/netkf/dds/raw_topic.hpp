#pragma once
// Topics of any type, for `netkf relay` (docs/relay.md): samples travel as their serialized
// payload, untouched (the encapsulation header and all), so the relay needs no IDL. The type's
// name and whether it has a key come from discovery (DiscoveredWriter); the key of a keyed
// sample is the key hash its writer sent, passed on as is.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>

#include "netkf/dds/participant.hpp"

namespace netkf::dds {

/// One sample of a topic of any type: its serialized payload with the 4-byte encapsulation
/// header first, and its instance's key hash (all zero for an unkeyed topic).
struct RawSample {
  std::vector<unsigned char> payload;
  eprosima::fastrtps::rtps::InstanceHandle_t key;
  /// The writer's sequence number of this sample (the relay's recording names samples by it).
  std::int64_t sequence = 0;
  /// The participant of the writer that wrote it.
  eprosima::fastrtps::rtps::GuidPrefix_t writer_participant;
  /// The writer that wrote it (a per-writer topic's relay picks the writer's link by it).
  eprosima::fastrtps::rtps::GUID_t writer;
};

/// What the relay mirrors of a writer it discovered: the topic, its type's name, whether the
/// type is keyed, and the QoS that decide matching.
struct DiscoveredWriter {
  eprosima::fastrtps::rtps::GuidPrefix_t participant;  // the writer's participant
  std::string topic;
  std::string type;
  bool keyed = false;
  bool reliable = true;
  bool transient_local = false;
  /// What of the writer's QoS the relay's endpoints do not reproduce, in words (logged): e.g.
  /// transient or persistent durability (relayed as transient local), exclusive ownership,
  /// partitions. A writer's history kind and depth are not in discovery at all (RawReader).
  std::vector<std::string> not_mirrored;
};

/// The largest payload a raw topic takes (bytes, header included): larger samples are refused
/// by the reader (Fast DDS counts them lost), never truncated.
inline constexpr std::uint32_t kMaxRawPayload = 8u * 1024u * 1024u;

/// A type support that copies payloads in and out: registered under the discovered type name,
/// it matches every writer and reader of that name whatever their IDL.
class RawPayloadType : public eprosima::fastdds::dds::TopicDataType {
 public:
  RawPayloadType(const std::string& type_name, bool keyed);
  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override;
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override;
  std::function<std::uint32_t()> getSerializedSizeProvider(void* data) override;
  void* createData() override;
  void deleteData(void* data) override;
  bool getKey(void* data, eprosima::fastrtps::rtps::InstanceHandle_t* handle, bool force_md5) override;
};

/// Reads one topic of any type; `on_sample` runs on the DDS receive thread for each valid sample.
class RawReader : private eprosima::fastdds::dds::DataReaderListener {
 public:
  /// Keep-last `depth`; reliability and durability as the writer offers them.
  RawReader(Participant& participant, const DiscoveredWriter& writer, int depth,
            std::function<void(RawSample&&)> on_sample);
  ~RawReader() override;
  RawReader(const RawReader&) = delete;
  RawReader& operator=(const RawReader&) = delete;

 private:
  void on_data_available(eprosima::fastdds::dds::DataReader* reader) override;

  Participant& participant_;
  std::function<void(RawSample&&)> on_sample_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
};

/// Writes one topic of any type with the QoS of the writer it stands in for.
class RawWriter {
 public:
  RawWriter(Participant& participant, const DiscoveredWriter& writer, int depth);
  ~RawWriter();
  RawWriter(const RawWriter&) = delete;
  RawWriter& operator=(const RawWriter&) = delete;
  /// False when DDS refused the sample.
  bool write(RawSample& sample);

 private:
  Participant& participant_;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
};

/// The writer a discovery callback describes, for the relay.
DiscoveredWriter discovered_writer(const eprosima::fastrtps::rtps::WriterDiscoveryInfo& info);

}  // namespace netkf::dds
