#include "netkf/dds/raw_topic.hpp"

#include <cstring>

#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/rtps/builtin/data/WriterProxyData.h>
#include <fastdds/rtps/writer/WriterDiscoveryInfo.h>

namespace netkf::dds {

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::rtps::InstanceHandle_t;
using eprosima::fastrtps::rtps::SerializedPayload_t;
using ReturnCode = eprosima::fastrtps::types::ReturnCode_t;

RawPayloadType::RawPayloadType(const std::string& type_name, bool keyed) {
  setName(type_name.c_str());
  m_typeSize = kMaxRawPayload;  // an upper bound only: the raw endpoints size payloads by sample
  m_isGetKeyDefined = keyed;
}

bool RawPayloadType::serialize(void* data, SerializedPayload_t* payload) {
  const auto* sample = static_cast<const RawSample*>(data);
  const auto size = sample->payload.size();
  if (size < 4 || size > payload->max_size) return false;
  std::memcpy(payload->data, sample->payload.data(), size);
  payload->length = static_cast<std::uint32_t>(size);
  // The representation identifier of the header (RTPS 2.3 §10.2), e.g. 0x0001 CDR_LE.
  payload->encapsulation = static_cast<std::uint16_t>((sample->payload[0] << 8) | sample->payload[1]);
  return true;
}

bool RawPayloadType::deserialize(SerializedPayload_t* payload, void* data) {
  if (payload->length < 4) return false;  // not even an encapsulation header: refused, counted lost
  auto* sample = static_cast<RawSample*>(data);
  sample->payload.assign(payload->data, payload->data + payload->length);
  return true;
}

std::function<std::uint32_t()> RawPayloadType::getSerializedSizeProvider(void* data) {
  return [data] { return static_cast<std::uint32_t>(static_cast<const RawSample*>(data)->payload.size()); };
}

void* RawPayloadType::createData() { return new RawSample(); }

void RawPayloadType::deleteData(void* data) { delete static_cast<RawSample*>(data); }

// The relay cannot compute a key from a payload it does not understand: a keyed sample keeps
// the key hash its writer sent (RawReader stores it in the sample).
bool RawPayloadType::getKey(void* data, InstanceHandle_t* handle, bool /*force_md5*/) {
  if (!m_isGetKeyDefined) return false;
  *handle = static_cast<const RawSample*>(data)->key;
  return true;
}

namespace {

TopicQos raw_topic_qos(const DiscoveredWriter& writer, int depth) {
  TopicQos qos;
  qos.reliable = writer.reliable;
  qos.transient_local = writer.transient_local;
  qos.depth = depth;
  qos.instances = writer.keyed ? 1024 : 1;
  qos.size_payloads_by_sample = true;  // payloads of any size up to kMaxRawPayload, none reserved
  return qos;
}

fdds::Topic* raw_topic(Participant& participant, const DiscoveredWriter& writer) {
  return participant.topic(writer.topic, fdds::TypeSupport(new RawPayloadType(writer.type, writer.keyed)));
}

}  // namespace

RawReader::RawReader(Participant& participant, const DiscoveredWriter& writer, int depth,
                     std::function<void(RawSample&&)> on_sample)
    : participant_(participant), on_sample_(std::move(on_sample)) {
  fdds::DataReaderQos qos = reader_qos(raw_topic_qos(writer, depth));
  // Acknowledge a heartbeat at once (Fast DDS waits 5 ms by default): a writer that keeps all
  // its samples, as a fast talker does, waits for these acknowledgements before it writes on,
  // so the delay paced the relay's input (BENCHMARKS.md, "netkf relay").
  qos.reliable_reader_qos().times.heartbeatResponseDelay = eprosima::fastrtps::Duration_t(0, 0);
  reader_ = participant_.subscriber()->create_datareader(raw_topic(participant_, writer), qos, this,
                                                         fdds::StatusMask::data_available());
  if (reader_ == nullptr)
    throw DdsError("cannot create a reader of " + writer.topic + " (" + writer.type + ") on domain " +
                   std::to_string(participant_.domain()));
}

RawReader::~RawReader() {
  reader_->set_listener(nullptr);
  participant_.subscriber()->delete_datareader(reader_);
}

void RawReader::on_data_available(fdds::DataReader* reader) {
  RawSample sample;
  fdds::SampleInfo info;
  while (reader->take_next_sample(&sample, &info) == ReturnCode::RETCODE_OK) {
    if (!info.valid_data) continue;  // a dispose or unregister: not relayed (docs/relay.md)
    sample.key = info.instance_handle;
    sample.sequence = info.sample_identity.sequence_number().to64long();
    sample.writer_participant = info.sample_identity.writer_guid().guidPrefix;
    sample.writer = info.sample_identity.writer_guid();
    on_sample_(std::move(sample));
    sample = RawSample{};
  }
}

RawWriter::RawWriter(Participant& participant, const DiscoveredWriter& writer, int depth) : participant_(participant) {
  writer_ = participant_.publisher()->create_datawriter(raw_topic(participant_, writer),
                                                        writer_qos(raw_topic_qos(writer, depth)));
  if (writer_ == nullptr)
    throw DdsError("cannot create a writer of " + writer.topic + " (" + writer.type + ") on domain " +
                   std::to_string(participant_.domain()));
}

RawWriter::~RawWriter() { participant_.publisher()->delete_datawriter(writer_); }

bool RawWriter::write(RawSample& sample) { return writer_->write(&sample); }

DiscoveredWriter discovered_writer(const eprosima::fastrtps::rtps::WriterDiscoveryInfo& info) {
  DiscoveredWriter w;
  w.participant = info.info.guid().guidPrefix;
  w.topic = info.info.topicName().to_string();
  w.type = info.info.typeName().to_string();
  w.keyed = info.info.topicKind() == eprosima::fastrtps::rtps::WITH_KEY;
  w.reliable = info.info.m_qos.m_reliability.kind == fdds::RELIABLE_RELIABILITY_QOS;
  const auto& qos = info.info.m_qos;
  w.transient_local = qos.m_durability.kind != fdds::VOLATILE_DURABILITY_QOS;
  if (qos.m_durability.kind == fdds::TRANSIENT_DURABILITY_QOS || qos.m_durability.kind == fdds::PERSISTENT_DURABILITY_QOS)
    w.not_mirrored.push_back("its transient or persistent durability (relayed as transient local: the relay keeps no "
                             "samples beyond its history)");
  if (qos.m_ownership.kind == fdds::EXCLUSIVE_OWNERSHIP_QOS)
    w.not_mirrored.push_back("its exclusive ownership (the relay writes with shared ownership: a reader asking for "
                             "exclusive ownership does not match)");
  if (!qos.m_partition.empty())
    w.not_mirrored.push_back("its partitions (the relay reads and writes the default partition: it does not match "
                             "this writer)");
  return w;
}

}  // namespace netkf::dds
