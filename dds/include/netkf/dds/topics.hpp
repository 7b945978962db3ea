#pragma once
// Topic names and QoS of the live network: the single place where they are defined.
// A Topic<T> ties a name to its wire type so a Writer/Reader cannot mix them up.
#include <chrono>
#include <cstdint>
#include <string_view>

#include "netkf/dds/wire.hpp"

namespace netkf::dds {

/// Heartbeat period of every reliable writer (Fast DDS default: 3 s). Readers acknowledge
/// samples when a heartbeat asks them to, and a volatile writer drops acknowledged samples
/// from its history. With 3 s, a sensor writing at 100 Hz fills a 256-deep history before
/// the first heartbeat; from then on Fast DDS adds a heartbeat to every write (its
/// "piggyback" on a full history) and the reader answers each with an acknowledgement: two
/// extra messages and wake-ups per sample. A heartbeat every 250 ms, with every history deep
/// enough to hold more than 250 ms at its design rate (depths below), keeps the
/// acknowledgements to 4 per second per writer and reader (BENCHMARKS.md, 2026-12-01 evening).
inline constexpr std::chrono::milliseconds kHeartbeatPeriod{250};

/// How a topic's samples are kept and delivered.
struct TopicQos {
  /// Reliable delivery (every topic of netkf is reliable: losses are the channel emulator's job).
  bool reliable = true;
  /// Transient-local: late joiners receive the last `depth` samples (link status).
  bool transient_local = false;
  /// Keep-last history depth (per writer). Sized so that a writer at its design rate takes
  /// several heartbeat periods (kHeartbeatPeriod) to fill it: a full history makes Fast DDS
  /// add a heartbeat to every write, and the reader answers each with an acknowledgement.
  std::int32_t depth = 64;
};

template <class T>
struct Topic {
  using type = T;
  std::string_view name;
  TopicQos qos;
};

/// The fastddsgen type support of each wire type.
template <class T>
struct PubSubTypeOf;
template <> struct PubSubTypeOf<wire::Truth> { using type = wire::TruthPubSubType; };
template <> struct PubSubTypeOf<wire::Tick> { using type = wire::TickPubSubType; };
template <> struct PubSubTypeOf<wire::Measurement> { using type = wire::MeasurementPubSubType; };
template <> struct PubSubTypeOf<wire::Estimate> { using type = wire::EstimatePubSubType; };
template <> struct PubSubTypeOf<wire::ControlInput> { using type = wire::ControlInputPubSubType; };
template <> struct PubSubTypeOf<wire::LinkControl> { using type = wire::LinkControlPubSubType; };
template <> struct PubSubTypeOf<wire::LinkControlReply> { using type = wire::LinkControlReplyPubSubType; };
template <> struct PubSubTypeOf<wire::LinkStatus> { using type = wire::LinkStatusPubSubType; };

namespace topics {
// plant -> sensors, recorders: ground truth x_k (the estimator never subscribes).
inline constexpr Topic<wire::Truth> truth{"netkf/truth", {true, false, 256}};
// plant -> estimator: sample clock k, t_k and the input the plant applied.
inline constexpr Topic<wire::Tick> tick{"netkf/tick", {true, false, 256}};
// sensors -> channel emulator: every sample a sensor produced (one writer per sensor process:
// depth for 64 sensors in one process x 100 Hz over 0.64 s).
inline constexpr Topic<wire::Measurement> raw_measurement{"netkf/measurement/raw", {true, false, 4096}};
// channel emulator -> estimator: the samples the lossy links delivered (one writer for
// all sensors: depth for 256 sensors x 100 Hz over 0.32 s).
inline constexpr Topic<wire::Measurement> delivered_measurement{"netkf/measurement/delivered", {true, false, 8192}};
// estimator -> everyone: x̂_{k|k}, P_{k|k} each period.
inline constexpr Topic<wire::Estimate> estimate{"netkf/estimate", {true, false, 512}};
// estimator -> plant: u_k = -L x̂_{k|k}.
inline constexpr Topic<wire::ControlInput> control_input{"netkf/control", {true, false, 256}};
// netkf ctl -> channel emulator: link changes.
inline constexpr Topic<wire::LinkControl> link_control{"netkf/link/control", {true, false, 64}};
// channel emulator -> netkf ctl: the answer to each link change.
inline constexpr Topic<wire::LinkControlReply> link_control_reply{"netkf/link/reply", {true, false, 64}};
// channel emulator -> everyone, transient-local so `netkf ctl status` sees it on joining.
inline constexpr Topic<wire::LinkStatus> link_status{"netkf/link/status", {true, true, 256}};
}  // namespace topics

}  // namespace netkf::dds
