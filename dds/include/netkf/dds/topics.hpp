#pragma once
// Topic names and QoS of the live network: the single place where they are defined.
// A Topic<T> ties a name to its wire type so a Writer/Reader cannot mix them up.
#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>

#include <fastcdr/exceptions/Exception.h>
#include <fastdds/rtps/common/SerializedPayload.h>

#include "netkf/dds/wire.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::dds {

/// Heartbeat period of every reliable writer (Fast DDS default: 3 s). Readers acknowledge
/// samples when a heartbeat asks them to, and a volatile writer drops acknowledged samples
/// from its history. With 3 s, a writer that fills its history between two heartbeats
/// (a 256-deep history at 100 Hz takes 2.56 s; the channel's single writer for 128 sensors,
/// 0.3 s) makes Fast DDS add a heartbeat to every write (its "piggyback" on a full history),
/// and the reader answers each with an acknowledgement: two extra messages and wake-ups per
/// sample. Hence a heartbeat every 250 ms and histories that hold a few heartbeat periods at
/// the writer's rate (history_depth_for_rate) — but no deeper: a writer re-sends what a
/// lagging reader reports missing, and a deep history made 64 sensor processes swamp the
/// channel with repairs (BENCHMARKS.md, "Heartbeats and NACK suppression").
inline constexpr std::chrono::milliseconds kHeartbeatPeriod{250};

/// How long a reliable writer ignores requests to re-send a sample it has just sent (Fast DDS
/// default: 0). Fast DDS runs this as a timer per matched reader, restarted by every write
/// once it has fired: with 0 it fires at once, so every write woke the writer's event thread,
/// which then waited for the writer's lock (perf sched:sched_wakeup on the channel). With
/// 50 ms the timer stays armed across writes and fires at most 20 times a second. Repairs are
/// unaffected in practice: a sample sent through shared memory arrives in microseconds, and a
/// lost one is re-sent after the next heartbeat (kHeartbeatPeriod) anyway.
inline constexpr std::chrono::milliseconds kNackSuppression{50};

/// Keep-last depth for a writer publishing `samples_per_second`: three heartbeat periods of
/// samples, and never less than `minimum` (the topic's depth).
constexpr std::int32_t history_depth_for_rate(double samples_per_second, std::int32_t minimum) {
  const double three_periods = samples_per_second * 3.0 * static_cast<double>(kHeartbeatPeriod.count()) / 1000.0;
  const auto whole = static_cast<std::int32_t>(three_periods);
  const std::int32_t depth = whole + (three_periods > static_cast<double>(whole) ? 1 : 0);  // rounded up
  return depth > minimum ? depth : minimum;
}

/// How a topic's samples are kept and delivered.
struct TopicQos {
  /// Reliable delivery (every topic of netkf is reliable: losses are the channel emulator's job).
  bool reliable = true;
  /// Transient-local: late joiners receive the last `depth` samples (link status).
  bool transient_local = false;
  /// Keep-last history depth (per writer; a writer may ask for more, see
  /// history_depth_for_rate).
  std::int32_t depth = 64;
  /// Instances of a keyed type (presence: one per process); 1 for the unkeyed topics.
  std::int32_t instances = 1;
  /// Allocate each sample's payload at its own size and reuse it (Fast DDS's
  /// DYNAMIC_REUSABLE_MEMORY_MODE) instead of at the type's largest size: a batch can be ~84 kB
  /// at most and is ~3 kB for 64 scalar sensors, so a deep history would otherwise reserve
  /// depth x 84 kB.
  bool size_payloads_by_sample = false;
  /// Exclusive ownership: of several writers, readers take the samples of the strongest one
  /// whose liveliness holds (WriterOptions), the standard DDS failover. The estimate and the
  /// control input have it, so a hot-standby estimator takes over when the primary dies.
  bool exclusive_ownership = false;
};

/// What a writer adds to its topic's QoS.
struct WriterOptions {
  /// The rate this writer publishes at, when it can exceed what the topic's depth was sized for
  /// (its history then holds three heartbeat periods, see history_depth_for_rate).
  double samples_per_second = 0.0;
  /// Exclusive-ownership topics: this writer's strength (the strongest live writer owns the topic).
  std::uint32_t ownership_strength = 0;
};

/// The liveliness lease of the exclusive-ownership topics' writers and readers: a writer that
/// neither wrote nor asserted its liveliness for this long counts as gone, and the next strongest
/// takes over (a hot standby). Five periods of the default 10 ms; a writer of a slower period
/// asserts its liveliness on a timer (Writer::assert_liveliness), so the lease is one constant
/// that every reader can ask for without knowing the scenario.
inline constexpr std::chrono::milliseconds kOwnershipLease{50};

/// The DDS topic name of netkf's topic `name` under `naming`: itself, or ROS 2's form of the
/// ROS 2 topic /name ("rt/" + name: rmw's prefix of a topic, docs/ros2.md).
std::string dds_topic_name(std::string_view name, TopicNaming naming);
/// The DDS type name of the wire type `wire_type_name` (netkf::wire::Estimate) under `naming`:
/// itself, or the name rmw gives the ROS 2 message netkf_msgs/msg/Estimate
/// (netkf_msgs::msg::dds_::Estimate_). Throws std::invalid_argument for a name outside netkf::wire.
std::string dds_type_name(std::string_view wire_type_name, TopicNaming naming);
/// `qos` as `naming` has it: ROS 2's readers have shared ownership only (rmw offers no other),
/// and a shared reader does not match an exclusive writer, so under ROS 2 naming every topic is
/// shared (a hot standby, which needs exclusive ownership, is then refused: docs/ros2.md).
TopicQos naming_qos(TopicQos qos, TopicNaming naming);

template <class T>
struct Topic {
  using type = T;
  std::string_view name;
  TopicQos qos;
};

/// A fastddsgen type support whose deserialize refuses (returns false, the sample is
/// dropped) every payload Fast CDR cannot read. The generated one catches only a payload
/// too short: an unknown encapsulation makes Fast CDR throw BadParamException out of it,
/// which a single malformed packet would carry into the reader's callback and end the
/// process (found by tests/fuzz/fuzz_wire_conversions).
template <class Generated>
class CheckedPubSubType : public Generated {
 public:
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override {
    try {
      return Generated::deserialize(payload, data);
    } catch (const eprosima::fastcdr::exception::Exception&) {
      return false;
    }
  }
};

/// The type support of each wire type (registered by Participant::topic).
template <class T>
struct PubSubTypeOf;
template <> struct PubSubTypeOf<wire::Truth> { using type = CheckedPubSubType<wire::TruthPubSubType>; };
template <> struct PubSubTypeOf<wire::Tick> { using type = CheckedPubSubType<wire::TickPubSubType>; };
template <> struct PubSubTypeOf<wire::Measurement> { using type = CheckedPubSubType<wire::MeasurementPubSubType>; };
template <> struct PubSubTypeOf<wire::MeasurementBatch> {
  using type = CheckedPubSubType<wire::MeasurementBatchPubSubType>;
};
template <> struct PubSubTypeOf<wire::Estimate> { using type = CheckedPubSubType<wire::EstimatePubSubType>; };
template <> struct PubSubTypeOf<wire::ControlInput> { using type = CheckedPubSubType<wire::ControlInputPubSubType>; };
template <> struct PubSubTypeOf<wire::LinkControl> { using type = CheckedPubSubType<wire::LinkControlPubSubType>; };
template <> struct PubSubTypeOf<wire::LinkControlReply> {
  using type = CheckedPubSubType<wire::LinkControlReplyPubSubType>;
};
template <> struct PubSubTypeOf<wire::LinkStatus> { using type = CheckedPubSubType<wire::LinkStatusPubSubType>; };
template <> struct PubSubTypeOf<wire::LinkChange> { using type = CheckedPubSubType<wire::LinkChangePubSubType>; };
template <> struct PubSubTypeOf<wire::Presence> { using type = CheckedPubSubType<wire::PresencePubSubType>; };

namespace topics {
// plant -> sensors, recorders: ground truth x_k (the estimator never subscribes).
inline constexpr Topic<wire::Truth> truth{"netkf/truth", {true, false, 256}};
// plant -> estimator: sample clock k, t_k and the input the plant applied. Transient-local: a
// restarted estimator receives the recent ticks and predicts over the periods it missed with
// the inputs the plant acknowledged (EstimatorCore::resume).
inline constexpr Topic<wire::Tick> tick{"netkf/tick", {true, true, 256}};
// sensors -> channel emulator: every sample a sensor produced (one writer per sensor process;
// a process hosting many sensors asks for a deeper history, history_depth_for_rate).
inline constexpr Topic<wire::Measurement> raw_measurement{"netkf/measurement/raw", {true, false, 256}};
// channel emulator -> estimator: the samples the lossy links delivered (one writer for all
// sensors: at least 4096, and deeper above 5461 samples/s, see history_depth_for_rate).
inline constexpr Topic<wire::Measurement> delivered_measurement{"netkf/measurement/delivered", {true, false, 4096}};
// A sensor process of several sensors -> channel; channel -> estimator: one sample per truth and
// process (wire::MeasurementBatch) instead of one per sensor, so 256 sensors at 100 Hz cost 400
// samples a second, not 25 600 (BENCHMARKS.md, "256 sensors at 100 Hz"). The readers of the
// single topics above read these too. The depths are the single topics': a reader stalled for a
// while (a loaded recorder) finds at least as much history as it did with single samples.
inline constexpr Topic<wire::MeasurementBatch> raw_measurement_batch{"netkf/measurement/raw_batch",
                                                                    {true, false, 256, 1, true}};
inline constexpr Topic<wire::MeasurementBatch> delivered_measurement_batch{"netkf/measurement/delivered_batch",
                                                                          {true, false, 4096, 1, true}};
// estimator -> everyone: x̂_{k|k}, P_{k|k} each period.
// Exclusive ownership: with a hot standby (`netkf launch --standby`) two estimators publish, and
// every reader takes the primary's estimates until its liveliness lease expires.
// Transient-local: a restarted estimator publishes the periods it missed as soon as its writer
// matched the launch's reader, but the launch's reader may match the new writer a moment later,
// and a volatile reader drops what a writer it does not know yet sent (the recording then lost
// those periods: e2e fault_estimator, `none` rows right after the restart). The launch reads it
// transient-local, so it gets them on matching; a reader that should start at the next period
// (a recorder attaching mid-run) reads estimate_from_now.
inline constexpr Topic<wire::Estimate> estimate{"netkf/estimate",
                                                {.transient_local = true, .depth = 512, .exclusive_ownership = true}};
inline constexpr Topic<wire::Estimate> estimate_from_now{"netkf/estimate", {.depth = 512, .exclusive_ownership = true}};
// estimator -> plant: u_k = -L x̂_{k|k}; exclusive like the estimate, so the plant applies the
// inputs of the estimator whose estimates the readers take.
inline constexpr Topic<wire::ControlInput> control_input{"netkf/control", {.depth = 256, .exclusive_ownership = true}};
// estimator -> channel emulator, with a lossy actuation link (plant.control.link): the inputs
// the estimator sent, which the channel relays to netkf/control on the actuation link (loss,
// delay) as it relays samples. Exclusive like netkf/control, so the standby's are not relayed.
inline constexpr Topic<wire::ControlInput> sent_control_input{"netkf/control/sent",
                                                              {.depth = 256, .exclusive_ownership = true}};
// netkf ctl -> channel emulator: link changes.
inline constexpr Topic<wire::LinkControl> link_control{"netkf/link/control", {true, false, 64}};
// channel emulator -> netkf ctl: the answer to each link change. Transient-local: `ctl` sends
// once its writer has matched the channel's reader, but the channel's reply writer may not have
// matched ctl's reader yet (discovery is not symmetric in time); a volatile reply written then
// was lost and ctl timed out although the change was applied. Kept, it reaches ctl on matching
// (ctl picks its own request id out of the last 64 replies).
inline constexpr Topic<wire::LinkControlReply> link_control_reply{"netkf/link/reply", {true, true, 64}};
// The links a channel reports at most: a live network's sensors (the launch's kMaxLiveSensors)
// and the actuation link.
inline constexpr std::int32_t kMaxLinks = 4096 + 1;
// channel emulator -> everyone. Keyed by the link, keep-last 1 of each, transient-local: a late
// joiner (`netkf ctl status`, a dashboard opened later, `netkf record`) gets every link's last
// status, and a slow reader the newest of each. (Unkeyed with a history of 256 it got the last
// 256 statuses, so with more than 256 links some links were missing: at 1536 sensors the launch
// took links for silent, BENCHMARKS.md "Sensor count limit".) Payloads sized per sample: the
// history holds one per link.
inline constexpr Topic<wire::LinkStatus> link_status{
    "netkf/link/status",
    {.transient_local = true, .depth = 1, .instances = kMaxLinks, .size_payloads_by_sample = true}};
// channel emulator -> everyone: each link change with the period it applied from (the
// journal `--record` turns into an events file); transient-local so a late recorder has it.
inline constexpr Topic<wire::LinkChange> link_change{"netkf/link/change", {true, true, 1024}};
// every process of a run -> all: who takes part (role, sensors, host, pid, scenario hash, run)
// and whether it still runs. Keyed by host, pid and role, transient-local with the last sample
// of each process, so a process that joins late sees everyone (presence.hpp).
inline constexpr Topic<wire::Presence> presence{"netkf/presence", {true, true, 1, 1024}};
}  // namespace topics

}  // namespace netkf::dds
