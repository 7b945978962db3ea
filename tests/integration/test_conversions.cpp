// Wire <-> core conversions (dds/src/conversions.cpp): untrusted wire data is validated —
// wrong sizes and non-finite numbers are errors, never a crash or a NaN in the math — and
// valid data converts without loss. No participant is created here.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "netkf/dds/conversions.hpp"
#include "netkf/dds/topics.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/relay/relay_links.hpp"

namespace {

namespace dds = netkf::dds;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Conversions, VectorsAndRowMajorMatrices) {
  const netkf::Matrix m{{1.0, 2.0, 3.0}, {4.0, 5.0, 6.0}};
  const auto w = dds::to_wire_row_major(m);
  EXPECT_EQ(w, (std::vector<double>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(dds::to_matrix(w, 2, 3, "m"), m);
  EXPECT_THROW(dds::to_matrix(w, 3, 3, "m"), dds::ConversionError);
  EXPECT_THROW(dds::to_vector({1.0, kNaN}, 2, "v"), dds::ConversionError);
  EXPECT_THROW(dds::to_vector({1.0, kInf}, -1, "v"), dds::ConversionError);
  EXPECT_THROW(dds::to_vector({1.0}, 2, "v"), dds::ConversionError);
  EXPECT_EQ(dds::to_vector({1.5, -2.5}, 2, "v"), (netkf::Vector{{1.5, -2.5}}));
}

TEST(Conversions, MeasurementValidation) {
  auto m = dds::make_measurement(2, 5, 10, netkf::Vector{{0.25}});
  const auto s = dds::to_sensor_sample(m, 1);
  EXPECT_EQ(s.sensor_id, 2);
  EXPECT_EQ(s.y, netkf::Vector{{0.25}});
  m.y({kNaN});
  try {
    dds::to_sensor_sample(m);
    FAIL() << "NaN accepted";
  } catch (const dds::ConversionError& e) {
    EXPECT_NE(std::string(e.what()).find("non-finite"), std::string::npos);
  }
  m.y({1.0, 2.0});
  EXPECT_THROW(dds::to_sensor_sample(m, 1), dds::ConversionError);
}

TEST(Conversions, TickAndControlInputs) {
  EXPECT_EQ(dds::tick_applied_input(dds::make_tick(1, 0.01, netkf::Vector(), false), 1).size(), 0);
  EXPECT_EQ(dds::tick_applied_input(dds::make_tick(1, 0.01, netkf::Vector{{0.5}}, false), 1), netkf::Vector{{0.5}});
  EXPECT_THROW(dds::tick_applied_input(dds::make_tick(1, 0.01, netkf::Vector{{0.5, 1.0}}, false), 1),
               dds::ConversionError);
  auto c = dds::make_control_input(3, netkf::Vector{{1.0}});
  c.u({kInf});
  EXPECT_THROW(dds::control_input_u(c, 1), dds::ConversionError);
  EXPECT_THROW(dds::truth_state(dds::make_truth(0, 0.0, netkf::Vector{{1.0}}, netkf::Vector()), 2),
               dds::ConversionError);
}

TEST(Conversions, EstimateRefusesNonFiniteAndBadShapes) {
  netkf::Estimate r;
  r.x_hat = netkf::Vector{{1.0, 2.0}};
  r.P = netkf::Matrix::Identity(2, 2);
  EXPECT_DOUBLE_EQ(dds::to_wire(r).trace_P(), 2.0);
  r.P(0, 1) = kNaN;
  EXPECT_THROW(dds::to_wire(r), dds::ConversionError);
  r.P = netkf::Matrix::Identity(3, 3);
  EXPECT_THROW(dds::to_wire(r), dds::ConversionError);
  r.P = netkf::Matrix::Identity(2, 2);
  r.x_hat(0) = kInf;
  EXPECT_THROW(dds::to_wire(r), dds::ConversionError);
  r.x_hat(0) = 1.0;
  auto w = dds::to_wire(r);
  w.state("exploded");
  EXPECT_THROW(dds::from_wire(w), dds::ConversionError);
  w.state("ok");
  w.P({1.0, 0.0, 0.0});
  EXPECT_THROW(dds::from_wire(w), dds::ConversionError);
}

TEST(Conversions, EstimateLateCountIsItsListOfSensors) {
  netkf::Estimate r;
  r.x_hat = netkf::Vector{{1.0}};
  r.P = netkf::Matrix::Identity(1, 1);
  r.late = 2;
  r.late_sensors = {2};  // one id for two late samples: inconsistent
  EXPECT_THROW(dds::to_wire(r), dds::ConversionError);
  r.late_sensors = {2, 2};  // the same sensor late twice
  r.late_periods = {7};     // ... but one period for two samples: inconsistent
  EXPECT_THROW(dds::to_wire(r), dds::ConversionError);
  r.late_periods = {7, 6};  // for two periods
  auto w = dds::to_wire(r);
  EXPECT_EQ(w.late(), 2u);
  EXPECT_EQ(w.late_sensors(), (std::vector<int32_t>{2, 2}));
  EXPECT_EQ(dds::from_wire(w).late_sensors, (std::vector<int>{2, 2}));
  EXPECT_EQ(dds::from_wire(w).late_periods, (std::vector<std::uint64_t>{7, 6}));
  w.late_periods({7});  // a sender whose periods disagree with its sensors
  EXPECT_THROW(dds::from_wire(w), dds::ConversionError);
  w.late_periods({7, 6});
  w.late(3);  // a sender whose count disagrees with its list
  EXPECT_THROW(dds::from_wire(w), dds::ConversionError);
}

TEST(Conversions, EstimateRevisionRoundTripsAndDefaultsToInTime) {
  netkf::Estimate r;
  r.k = 12;
  r.x_hat = netkf::Vector{{1.0}};
  r.P = netkf::Matrix::Identity(1, 1);
  EXPECT_EQ(dds::to_wire(r).revision(), 0u);  // an in-time estimate, as before revisions existed
  r.revision = 3;
  const auto w = dds::to_wire(r);
  EXPECT_EQ(w.revision(), 3u);
  EXPECT_EQ(dds::from_wire(w).revision, 3u);
  EXPECT_EQ(dds::from_wire(w).k, 12u);
}

TEST(Conversions, LinkRequestsCarryTheirKeysAndLinksRoundTrip) {
  const netkf::LinkKeys keys{{"model", std::string("gilbert_elliott")}, {"loss", 0.2}, {"mean_burst", 5.0},
                             {"delay_ms", 6.0}, {"delay_distribution", std::string("pareto")}};
  const auto c = dds::make_link_control(1, 2, keys);
  EXPECT_EQ(c.request_id(), 1u);
  EXPECT_EQ(c.sensor_id(), 2);
  EXPECT_EQ(dds::link_keys_of(c), keys);  // names and values exactly as sent
  // A whole link survives the wire bit for bit, and an invalid one is refused naming its key.
  netkf::LinkSpec link{netkf::GilbertElliottLink{0.0625, 0.2, 0.0, 1.0}, {6.0, 4.0, netkf::DelayDistribution::normal}};
  EXPECT_EQ(dds::from_wire(dds::to_wire(link)), link);
  auto w = dds::to_wire(link);
  w.r(-0.5);
  try {
    (void)dds::from_wire(w);
    FAIL() << "r = -0.5 accepted";
  } catch (const dds::ConversionError& e) {
    EXPECT_NE(std::string(e.what()).find("r must be a probability"), std::string::npos) << e.what();
  }
  w.r(kNaN);
  EXPECT_THROW((void)dds::from_wire(w), dds::ConversionError);
  w = dds::to_wire(link);
  w.model("bernouli");
  EXPECT_THROW((void)dds::from_wire(w), dds::ConversionError);
  w = dds::to_wire(link);
  w.delay_distribution("cauchy");
  EXPECT_THROW((void)dds::from_wire(w), dds::ConversionError);
  w = dds::to_wire(link);
  w.jitter_ms(-1.0);
  EXPECT_THROW((void)dds::from_wire(w), dds::ConversionError);
  netkf::LinkStatus status;
  status.sensor_id = 3;
  status.link = netkf::BernoulliLink{0.25};
  status.in_time = 0.5;
  status.held = 7;
  const auto s = dds::to_wire(status, 0);
  EXPECT_EQ(s.link().model(), "bernoulli");
  EXPECT_DOUBLE_EQ(s.stationary_loss(), 0.25);
  EXPECT_DOUBLE_EQ(s.in_time(), 0.5);
  EXPECT_EQ(s.held(), 7u);
  EXPECT_EQ(dds::link_of(s), netkf::LinkSpec(netkf::BernoulliLink{0.25}));
}

// The recent-samples fit travels whole (recent_loss_fit.hpp): a window's fit, written and read
// back, is the same fit; none before the first sample; a malformed one is refused.
TEST(Conversions, ARelayedTopicsStatusAndJournalNameTheTopicOfTheirLinkId) {
  const int id = netkf::relay_topic_link_id("rt/scan");
  netkf::LinkStatus status;
  status.sensor_id = id;
  status.link = netkf::BernoulliLink{0.25};
  status.topic = "rt/scan";
  const auto s = dds::to_wire(status, 0);
  EXPECT_EQ(s.topic(), "rt/scan");
  EXPECT_EQ(dds::relayed_topic_of(s.sensor_id(), s.topic()), "rt/scan");
  const auto c =
      dds::to_wire(netkf::LinkChange{id, 12, netkf::LinkChange::Origin::request, 3, netkf::BernoulliLink{0.0}, "rt/scan", {}}, 0);
  EXPECT_EQ(dds::relayed_topic_of(c.sensor_id(), c.topic()), "rt/scan");
  EXPECT_EQ(dds::relayed_topic_of(2, ""), "") << "a channel's link";
  EXPECT_THROW(dds::relayed_topic_of(2, "rt/scan"), dds::ConversionError) << "a sensor's id with a topic";
  EXPECT_THROW(dds::relayed_topic_of(id, "rt/other"), dds::ConversionError) << "another topic's id";
  EXPECT_THROW(dds::relayed_topic_of(id, ""), dds::ConversionError) << "a topic's id without its topic";
}

TEST(Conversions, RecentFitRoundTripsAndIsValidated) {
  netkf::fit::RecentArrivals bursty(50), one(5);
  for (int i = 0; i < 80; ++i) bursty.record(i % 10 < 4);  // runs of 4 drops, 6 deliveries
  one.record(true);
  for (const auto& window : {bursty, one}) {
    netkf::LinkStatus facts;
    facts.sensor_id = 3;
    facts.link = netkf::BernoulliLink{0.25};
    facts.recent_fit = window.fit();
    const auto back = dds::recent_fit_of(dds::to_wire(facts, 0));
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ(back->samples, facts.recent_fit->samples);
    EXPECT_EQ(back->dropped, facts.recent_fit->dropped);
    EXPECT_EQ(back->family, facts.recent_fit->family);
    EXPECT_EQ(back->link, facts.recent_fit->link);
    EXPECT_EQ(back->aic_gain, facts.recent_fit->aic_gain);
  }
  EXPECT_EQ(bursty.fit()->family, netkf::fit::LossFamily::simple_gilbert);
  EXPECT_FALSE(one.fit()->aic_gain.has_value());

  netkf::LinkStatus status;
  status.sensor_id = 3;
  status.link = netkf::BernoulliLink{0.25};
  auto s = dds::to_wire(status, 0);
  EXPECT_FALSE(dds::recent_fit_of(s).has_value());
  status.recent_fit = bursty.fit();
  s = dds::to_wire(status, 0);
  auto bad = s;
  bad.fit_family("gilbert_elliott");
  EXPECT_THROW((void)dds::recent_fit_of(bad), dds::ConversionError);
  bad = s;
  bad.fit_p(std::nan(""));
  EXPECT_THROW((void)dds::recent_fit_of(bad), dds::ConversionError);
  bad = s;
  bad.fit_dropped(bad.fit_samples() + 1);
  EXPECT_THROW((void)dds::recent_fit_of(bad), dds::ConversionError);
}

// A group's samples go out in batches of at most kMaxBatchSamples, in their order; that is the
// bound the IDL gives the sequence, so the largest batch netkf writes (each sample at
// Measurement's own largest, 100 values) fits the payload Fast DDS sizes for the type.
TEST(Conversions, MeasurementBatchesKeepTheOrderWithinTheWireBound) {
  std::vector<netkf::wire::Measurement> samples;
  for (int id = 1; id <= 250; ++id) samples.push_back(dds::make_measurement(id, 7, id, netkf::Vector{{0.5 * id}}));
  const auto batches = dds::make_measurement_batches(samples);
  ASSERT_EQ(batches.size(), 3u);
  EXPECT_EQ(batches[0].samples().size(), 100u);
  EXPECT_EQ(batches[1].samples().size(), 100u);
  EXPECT_EQ(batches[2].samples().size(), 50u);
  std::vector<netkf::wire::Measurement> joined;
  for (const auto& b : batches) joined.insert(joined.end(), b.samples().begin(), b.samples().end());
  EXPECT_EQ(joined, samples);
  EXPECT_TRUE(dds::make_measurement_batches({}).empty());

  using Payload = eprosima::fastrtps::rtps::SerializedPayload_t;
  dds::PubSubTypeOf<netkf::wire::MeasurementBatch>::type type;
  auto full = batches[0];
  Payload payload(type.getSerializedSizeProvider(&full)());
  EXPECT_TRUE(type.serialize(&full, &payload));
  netkf::wire::MeasurementBatch read;
  ASSERT_TRUE(type.deserialize(&payload, &read));
  EXPECT_EQ(read.samples(), batches[0].samples());

  std::vector<netkf::wire::Measurement> widest;
  for (int id = 1; id <= 100; ++id) widest.push_back(dds::make_measurement(id, 7, id, netkf::Vector::Constant(100, 0.5)));
  auto largest = dds::make_measurement_batches(widest);
  ASSERT_EQ(largest.size(), 1u);
  Payload at_type_size(type.m_typeSize);
  EXPECT_TRUE(type.serialize(&largest.front(), &at_type_size));
  EXPECT_GT(at_type_size.length, 80000u);
}

// A received payload Fast CDR cannot read is refused (the sample dropped), never an
// exception out of the reader (tests/fuzz/corpus/fuzz_wire_conversions/crash-unknown-encapsulation:
// an encapsulation kind other than CDR BE/LE made the generated deserialize throw).
TEST(Conversions, UnreadablePayloadIsRefusedNotThrown) {
  using Payload = eprosima::fastrtps::rtps::SerializedPayload_t;
  dds::PubSubTypeOf<netkf::wire::Measurement>::type type;
  auto sample = dds::make_measurement(2, 5, 10, netkf::Vector{{0.25, -1.0}});
  Payload valid(type.getSerializedSizeProvider(&sample)());
  ASSERT_TRUE(type.serialize(&sample, &valid));

  netkf::wire::Measurement read;
  ASSERT_TRUE(type.deserialize(&valid, &read));
  EXPECT_EQ(read.y(), sample.y());

  Payload bad(valid.length);
  std::memcpy(bad.data, valid.data, valid.length);
  bad.length = valid.length;
  bad.data[1] = 0xff;  // the encapsulation kind
  netkf::wire::MeasurementPubSubType generated;
  EXPECT_ANY_THROW(generated.deserialize(&bad, &read));  // why the checked type exists
  EXPECT_FALSE(type.deserialize(&bad, &read));

  bad.length = 3;  // shorter than the encapsulation header
  EXPECT_FALSE(type.deserialize(&bad, &read));
}

}  // namespace

// The link records cross the wire whole: every field a reader sees is the field the owner set
// (the one type each of issue 39: no field copied by hand on either side).
TEST(Conversions, LinkStatusChangeAndReplyRoundTripWhole) {
  netkf::LinkStatus status;
  status.sensor_id = netkf::kControlLinkId;
  status.link = netkf::LinkSpec(netkf::GilbertElliottLink{0.1, 0.4, 0.0, 1.0}, {3.0, 1.0});
  status.in_time = 0.75;
  status.held = 2;
  status.past_deadline = 5;
  netkf::LinkStatistics since_change, lifetime;
  for (int i = 0; i < 40; ++i) since_change.record(i % 5 == 0);
  for (int i = 0; i < 90; ++i) lifetime.record(i % 3 == 0);
  status.count(since_change, lifetime);
  status.last_request_id = 11;
  status.rejection_reason = "loss must be in [0, 1]";
  netkf::fit::RecentArrivals recent(50);
  for (int i = 0; i < 60; ++i) recent.record(i % 10 < 3);
  status.recent_fit = recent.fit();
  const netkf::LinkStatus back = dds::from_wire(dds::to_wire(status, 9));
  EXPECT_EQ(back.sensor_id, status.sensor_id);
  EXPECT_EQ(back.link, status.link);
  EXPECT_EQ(back.in_time, 0.75);
  EXPECT_EQ((std::tuple{back.held, back.past_deadline, back.samples_in, back.delivered, back.dropped}),
            (std::tuple{2ull, 5ull, 40ull, 32ull, 8ull}));
  EXPECT_EQ((std::tuple{back.samples_total, back.delivered_total, back.dropped_total}), (std::tuple{90ull, 60ull, 30ull}));
  EXPECT_DOUBLE_EQ(back.observed_loss, 0.2);
  EXPECT_DOUBLE_EQ(back.mean_burst_length, 1.0);
  EXPECT_EQ(back.last_request_id, 11u);
  EXPECT_EQ(back.rejection_reason, status.rejection_reason);
  ASSERT_TRUE(back.recent_fit.has_value());
  EXPECT_EQ(back.recent_fit->samples, status.recent_fit->samples);
  EXPECT_EQ(back.recent_fit->link, status.recent_fit->link);
  EXPECT_EQ(back.name(), "control");

  const netkf::LinkChange change{2, 312, netkf::LinkChange::Origin::timeline, 0, netkf::BernoulliLink{0.3}, "", "not sent"};
  const netkf::LinkChange change_back = dds::from_wire(dds::to_wire(change, 1));
  EXPECT_EQ((std::tuple{change_back.sensor_id, change_back.at_period, change_back.origin, change_back.request_id}),
            (std::tuple{2, std::int64_t{312}, netkf::LinkChange::Origin::timeline, std::uint64_t{0}}));
  EXPECT_EQ(change_back.link, change.link);
  EXPECT_TRUE(change_back.failure.empty()) << "a failed timeline event is logged, never on the wire";
  auto unknown_origin = dds::to_wire(change, 1);
  unknown_origin.origin("operator");
  EXPECT_THROW((void)dds::from_wire(unknown_origin), dds::ConversionError);

  const netkf::LinkReply reply{17, 2, false, "loss must be in [0,1]"};
  const netkf::LinkReply reply_back = dds::from_wire(dds::to_wire(reply));
  EXPECT_EQ((std::tuple{reply_back.request_id, reply_back.sensor_id, reply_back.applied, reply_back.reason}),
            (std::tuple{reply.request_id, reply.sensor_id, reply.applied, reply.reason}));
}
