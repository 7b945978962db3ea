// Writes the wire fuzzer's seed corpus: valid samples of every wire type the fuzzer
// converts, serialised with their PubSubType as a writer would, each prefixed with its
// WireKind byte (wire_fuzz_input.hpp). Usage: make_wire_corpus DIR
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <fastdds/rtps/common/SerializedPayload.h>

#include "netkf/dds/conversions.hpp"
#include "netkf/links/link_keys.hpp"
#include "wire_fuzz_input.hpp"

namespace {

using namespace netkf;
using namespace netkf::dds;
using netkf::fuzz::WireKind;

std::filesystem::path g_dir;

template <class PubSubType, class T>
void write(const std::string& name, WireKind kind, T sample) {
  PubSubType type;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(type.getSerializedSizeProvider(&sample)());
  if (!type.serialize(&sample, &payload)) {
    std::fprintf(stderr, "make_wire_corpus: cannot serialise %s\n", name.c_str());
    std::exit(1);
  }
  std::ofstream out(g_dir / name, std::ios::binary);
  out.put(static_cast<char>(kind));
  out.write(reinterpret_cast<const char*>(payload.data), payload.length);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_wire_corpus DIR\n");
    return 2;
  }
  g_dir = argv[1];
  std::filesystem::create_directories(g_dir);

  Vector y(2);
  y << 0.5, -1.25;
  write<wire::MeasurementPubSubType>("measurement", WireKind::measurement, make_measurement(2, 42, 123456789, y));
  Vector x(2);
  x << 1.0, 0.1;
  Vector u(1);
  u << -0.3;
  {
    std::vector<wire::Measurement> group{make_measurement(1, 42, 123456789, y), make_measurement(3, 42, 123456790, y)};
    write<wire::MeasurementBatchPubSubType>("measurement_batch", WireKind::measurement_batch,
                                            make_measurement_batches(std::move(group)).front());
  }
  write<wire::TruthPubSubType>("truth", WireKind::truth, make_truth(42, 0.42, x, u));
  write<wire::TickPubSubType>("tick", WireKind::tick, make_tick(42, 0.42, u, false));
  write<wire::ControlInputPubSubType>("control_input", WireKind::control_input, make_control_input(42, u));

  netkf::Estimate e;
  e.k = 42;
  e.t = 0.42;
  e.x_hat = x;
  e.P = Matrix::Identity(2, 2) * 0.5;
  e.trace_P_pred = 1.5;
  e.fused = {1, 3};
  e.late = 1;
  e.late_sensors = {2};
  e.late_periods = {40};
  e.late_total = 7;
  e.state = FilterState::ok;
  write<wire::EstimatePubSubType>("estimate", WireKind::estimate, to_wire(e));

  const LinkSpec bernoulli(BernoulliLink{0.2}, LinkDelay{3.0, 1.0, DelayDistribution::normal});
  const LinkSpec gilbert(GilbertElliottLink{0.05, 0.4, 0.0, 1.0}, LinkDelay{5.0, 2.0, DelayDistribution::paretonormal});
  write<wire::LinkSpecPubSubType>("link_spec_bernoulli", WireKind::link_spec, to_wire(bernoulli));
  write<wire::LinkSpecPubSubType>("link_spec_gilbert", WireKind::link_spec, to_wire(gilbert));

  write<wire::LinkControlPubSubType>("link_control_loss", WireKind::link_control,
                                     make_link_control(7, 2, LinkKeys{{"loss", 0.3}}));
  write<wire::LinkControlPubSubType>(
      "link_control_model", WireKind::link_control,
      make_link_control(8, 2, LinkKeys{{"model", std::string("gilbert_elliott")}, {"loss", 0.2}, {"mean_burst", 4.0},
                                       {"delay_distribution", std::string("pareto")}}));

  LinkStatus facts;
  facts.sensor_id = 2;
  facts.link = gilbert;
  facts.in_time = 0.9;
  facts.last_request_id = 8;
  write<wire::LinkStatusPubSubType>("link_status", WireKind::link_status, to_wire(facts, 99));
  write<wire::LinkChangePubSubType>("link_change", WireKind::link_change,
                                    to_wire(LinkChange{2, 300, LinkChange::Origin::request, 8, bernoulli, {}, {}}, 99));
  return 0;
}
