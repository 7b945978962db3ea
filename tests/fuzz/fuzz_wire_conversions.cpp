// Fuzzes the wire -> core conversions (dds/src/conversions.cpp) on what a network peer
// can send: arbitrary bytes deserialised by the generated PubSubType, as Fast DDS does on
// receipt, then converted. A conversion must return finite, consistent values or throw
// ConversionError / LinkError; anything else (a crash, a sanitizer report, another
// exception, a NaN let through) is a finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <cstdio>

#include <fastdds/rtps/common/SerializedPayload.h>

#include "netkf/dds/conversions.hpp"
#include "netkf/dds/topics.hpp"
#include "netkf/links/link.hpp"
#include "netkf/links/link_delay.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_statistics.hpp"
#include "wire_fuzz_input.hpp"

namespace {

using namespace netkf;
using namespace netkf::dds;
using netkf::fuzz::WireKind;

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz_wire_conversions: %s\n", what);
  std::abort();
}

void check(bool ok, const char* what) {
  if (!ok) finding(what);
}

// A link that passed validation: its theory must be usable by the estimator and the
// analysis (probabilities, a finite delay), and it must survive a trip over the wire.
void check_link(const LinkSpec& link) {
  const double loss = stationary_loss(link.loss);
  check(std::isfinite(loss) && loss >= 0.0 && loss <= 1.0, "stationary loss of a valid link outside [0, 1]");
  check(std::isfinite(link.delay.delay_ms) && std::isfinite(link.delay.jitter_ms), "non-finite delay of a valid link");
  const double in_time = probability_within(link.delay, 10.0);
  check(in_time >= 0.0 && in_time <= 1.0, "P(delay <= deadline) of a valid link outside [0, 1]");
  check(from_wire(to_wire(link)) == link, "a valid link changed on a round trip over the wire");
}

// Deserialises `payload` into a T with the type support netkf registers for it, as Fast
// DDS does for a received sample. It must refuse what it cannot read, never throw.
// (LinkSpec is no topic of its own, only a member: checked like the others.)
template <class T>
struct TypeSupportOf : PubSubTypeOf<T> {};
template <>
struct TypeSupportOf<wire::LinkSpec> {
  using type = CheckedPubSubType<wire::LinkSpecPubSubType>;
};
template <class T>
bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t& payload, T& sample) {
  static typename TypeSupportOf<T>::type type;  // one per type: constructing a TopicDataType is not free
  return type.deserialize(&payload, &sample);
}

void fuzz_measurement(eprosima::fastrtps::rtps::SerializedPayload_t& payload) {
  wire::Measurement m;
  if (!deserialize<wire::Measurement>(payload, m)) return;
  for (const int expected : {-1, 2}) {
    try {
      const SensorSample s = to_sensor_sample(m, expected);
      check(s.y.allFinite(), "measurement: non-finite y accepted");
      check(expected < 0 || s.y.size() == expected, "measurement: wrong size accepted");
    } catch (const ConversionError&) {
    }
  }
}

// A batch is read sample by sample as the channel and the estimator read it (a foreign writer's
// batch may hold more than netkf's 100: the generated code does not check the bound on reading).
void fuzz_measurement_batch(eprosima::fastrtps::rtps::SerializedPayload_t& payload) {
  wire::MeasurementBatch b;
  if (!deserialize<wire::MeasurementBatch>(payload, b)) return;
  for (const auto& m : b.samples()) {
    try {
      check(to_sensor_sample(m).y.allFinite(), "batch: non-finite y accepted");
    } catch (const ConversionError&) {
    }
  }
}

void fuzz_truth(eprosima::fastrtps::rtps::SerializedPayload_t& payload) {
  wire::Truth t;
  if (!deserialize<wire::Truth>(payload, t)) return;
  try {
    check(truth_state(t, -1).allFinite(), "truth: non-finite x accepted");
  } catch (const ConversionError&) {
  }
}

void fuzz_tick(eprosima::fastrtps::rtps::SerializedPayload_t& payload) {
  wire::Tick t;
  if (!deserialize<wire::Tick>(payload, t)) return;
  try {
    const Vector u = tick_applied_input(t, 1);
    check(u.allFinite() && (u.size() == 0 || u.size() == 1), "tick: bad applied_input accepted");
  } catch (const ConversionError&) {
  }
}

void fuzz_control_input(eprosima::fastrtps::rtps::SerializedPayload_t& payload) {
  wire::ControlInput c;
  if (!deserialize<wire::ControlInput>(payload, c)) return;
  try {
    check(control_input_u(c, -1).allFinite(), "control input: non-finite u accepted");
  } catch (const ConversionError&) {
  }
}

void fuzz_estimate(eprosima::fastrtps::rtps::SerializedPayload_t& payload) {
  wire::Estimate e;
  if (!deserialize<wire::Estimate>(payload, e)) return;
  for (const int state_dim : {-1, 2}) {
    try {
      const netkf::Estimate r = from_wire(e, state_dim);
      const auto n = r.x_hat.size();
      check(state_dim < 0 || n == state_dim, "estimate: wrong state dimension accepted");
      check(r.P.rows() == n && r.P.cols() == n, "estimate: P is not n x n");
      check(r.x_hat.allFinite() && r.P.allFinite() && std::isfinite(r.trace_P_pred), "estimate: non-finite value accepted");
      check(r.late == r.late_sensors.size() && r.late_periods.size() == r.late_sensors.size(),
            "estimate: late disagrees with late_sensors or late_periods");
      // What a recorder or the dashboard republishes must convert back to the same record.
      const netkf::Estimate again = from_wire(to_wire(r), state_dim);
      check(again.x_hat == r.x_hat && again.P == r.P && again.fused == r.fused &&
                again.late_sensors == r.late_sensors && again.late_periods == r.late_periods && again.state == r.state,
            "estimate: changed on a round trip over the wire");
    } catch (const ConversionError&) {
    }
  }
}

void fuzz_link_spec(eprosima::fastrtps::rtps::SerializedPayload_t& payload) {
  wire::LinkSpec w;
  if (!deserialize<wire::LinkSpec>(payload, w)) return;
  try {
    check_link(from_wire(w));
  } catch (const ConversionError&) {
  }
}

void fuzz_link_control(eprosima::fastrtps::rtps::SerializedPayload_t& payload) {
  wire::LinkControl c;
  if (!deserialize<wire::LinkControl>(payload, c)) return;
  const LinkKeys keys = link_keys_of(c);
  // What the channel does with a request: apply the keys to its current link.
  const LinkSpec bernoulli{BernoulliLink{0.1}};
  const LinkSpec gilbert{GilbertElliottLink{0.05, 0.4, 0.0, 1.0}};
  for (const LinkSpec& current : {bernoulli, gilbert}) {
    try {
      check_link(apply_link_keys(current, keys));
    } catch (const LinkError&) {
    }
  }
}

void fuzz_link_status(eprosima::fastrtps::rtps::SerializedPayload_t& payload) {
  wire::LinkStatus s;
  if (!deserialize<wire::LinkStatus>(payload, s)) return;
  try {
    // What every reader of statuses does (the launch, ctl, record): the whole record, validated.
    const LinkStatus status = from_wire(s);
    check_link(status.link);
    if (!(status.in_time >= 0.0 && status.in_time <= 1.0)) std::abort();
  } catch (const ConversionError&) {
  }
}

void fuzz_link_change(eprosima::fastrtps::rtps::SerializedPayload_t& payload) {
  wire::LinkChange c;
  if (!deserialize<wire::LinkChange>(payload, c)) return;
  try {
    check_link(from_wire(c).link);
  } catch (const ConversionError&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(static_cast<std::uint32_t>(size - 1));
  if (size > 1) std::memcpy(payload.data, data + 1, size - 1);
  payload.length = static_cast<std::uint32_t>(size - 1);
  switch (static_cast<WireKind>(data[0] % netkf::fuzz::kWireKinds)) {
    case WireKind::measurement: fuzz_measurement(payload); break;
    case WireKind::truth: fuzz_truth(payload); break;
    case WireKind::tick: fuzz_tick(payload); break;
    case WireKind::control_input: fuzz_control_input(payload); break;
    case WireKind::estimate: fuzz_estimate(payload); break;
    case WireKind::link_spec: fuzz_link_spec(payload); break;
    case WireKind::link_control: fuzz_link_control(payload); break;
    case WireKind::link_status: fuzz_link_status(payload); break;
    case WireKind::link_change: fuzz_link_change(payload); break;
    case WireKind::measurement_batch: fuzz_measurement_batch(payload); break;
  }
  return 0;
}
