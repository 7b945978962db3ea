// In-process DDS: every wire type round-trips between two participants with full double
// precision; the default participant is localhost-only; profile files are honoured and a
// bad one is a clear error. Runs inside scripts/in-netns.sh (see tests/CMakeLists.txt),
// on a domain derived from the process id so parallel tests do not see each other.
#include <gtest/gtest.h>

#include "test_paths.hpp"
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include <fastrtps/utils/IPLocator.h>

#include "netkf/dds/dds.hpp"
#include "netkf/dds/presence.hpp"
#include "netkf/links/link_keys.hpp"

namespace {

using namespace std::chrono_literals;
namespace wire = netkf::wire;
namespace dds = netkf::dds;

int test_domain() { return 1 + static_cast<int>(::getpid() % 200); }

dds::ParticipantOptions options(const std::string& name) {
  dds::ParticipantOptions o;
  o.domain = test_domain();
  o.name = name;
  return o;
}

/// Collects samples from a Reader callback (listener thread) for the test thread.
template <class T>
class Inbox {
 public:
  std::function<void(T&&)> callback() {
    return [this](T&& s) {
      std::lock_guard lock(m_);
      q_.push_back(std::move(s));
      cv_.notify_all();
    };
  }
  bool wait_for(std::size_t n, std::chrono::milliseconds timeout) {
    std::unique_lock lock(m_);
    return cv_.wait_for(lock, timeout, [&] { return q_.size() >= n; });
  }
  std::deque<T> take() {
    std::lock_guard lock(m_);
    return std::exchange(q_, {});
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  std::deque<T> q_;
};

template <class T>
T roundtrip(const dds::Topic<T>& topic, const T& sample) {
  dds::Participant a(options("rt-a")), b(options("rt-b"));
  Inbox<T> inbox;
  dds::Reader<T> reader(b, topic, inbox.callback());
  dds::Writer<T> writer(a, topic);
  EXPECT_TRUE(writer.wait_for_matched(1, 10s)) << "no discovery on " << topic.name;
  EXPECT_TRUE(reader.wait_for_matched(1, 10s));
  EXPECT_TRUE(writer.write(sample));
  EXPECT_TRUE(inbox.wait_for(1, 10s)) << "nothing received on " << topic.name;
  auto got = inbox.take();
  return got.empty() ? T{} : got.front();
}

// Values that lose bits in anything but full double precision.
const std::vector<double> kTricky = {1.0 / 3.0, -2.718281828459045, 1e-300, 6.02214076e23, 0.1 + 0.2};

TEST(DdsRoundTrip, Truth) {
  const auto sent = dds::make_truth(42, 0.42, netkf::Vector::Map(kTricky.data(), 5), netkf::Vector{{0.5}});
  const auto got = roundtrip(dds::topics::truth, sent);
  EXPECT_EQ(got, sent);
  EXPECT_EQ(got.x(), kTricky);
}

TEST(DdsRoundTrip, Tick) {
  const auto sent = dds::make_tick(7, 0.07, netkf::Vector{{1.0 / 7.0, -3.0}}, true);
  EXPECT_EQ(roundtrip(dds::topics::tick, sent), sent);
}

TEST(DdsRoundTrip, MeasurementOnBothTopics) {
  const auto sent = dds::make_measurement(3, 99, 123456789, netkf::Vector::Map(kTricky.data(), 3));
  EXPECT_EQ(roundtrip(dds::topics::raw_measurement, sent), sent);
  EXPECT_EQ(roundtrip(dds::topics::delivered_measurement, sent), sent);
}

TEST(DdsRoundTrip, MeasurementBatchOnBothTopics) {
  std::vector<wire::Measurement> samples;
  for (int id = 1; id <= 3; ++id)
    samples.push_back(dds::make_measurement(id, 42, 123456789 + id, netkf::Vector::Constant(id, kTricky[id])));
  auto batches = dds::make_measurement_batches(samples);
  ASSERT_EQ(batches.size(), 1u);
  EXPECT_EQ(roundtrip(dds::topics::raw_measurement_batch, batches.front()).samples(), samples);
  EXPECT_EQ(roundtrip(dds::topics::delivered_measurement_batch, batches.front()).samples(), samples);
}

TEST(DdsRoundTrip, EstimateConvertsBackToTheSameRecord) {
  netkf::Estimate r;
  r.k = 5;
  r.t = 0.05;
  r.x_hat = netkf::Vector{{1.0 / 3.0, -2.0 / 7.0}};
  r.P = netkf::Matrix{{2.0 / 3.0, 0.1}, {0.2, 5.0 / 9.0}};  // not symmetric: checks row-major order
  r.fused = {1, 3};
  r.late = 2;
  r.late_sensors = {3, 1};  // in order of arrival, not sorted
  r.late_periods = {40, 38};
  r.late_total = 10;
  r.rejected_total = 4;
  r.state = netkf::FilterState::diverging;
  r.fused_at_ns = 111;
  r.stamp_ns = 222;
  r.last_sample_stamp_ns = 100;
  const auto got = dds::from_wire(roundtrip(dds::topics::estimate, dds::to_wire(r)), 2);
  EXPECT_EQ(got.k, r.k);
  EXPECT_EQ(got.x_hat, r.x_hat);
  EXPECT_EQ(got.P, r.P);
  EXPECT_EQ(got.fused, r.fused);
  EXPECT_EQ(got.late, r.late);
  EXPECT_EQ(got.late_sensors, r.late_sensors);
  EXPECT_EQ(got.late_periods, r.late_periods);
  EXPECT_EQ(got.late_total, r.late_total);
  EXPECT_EQ(got.rejected_total, r.rejected_total);
  EXPECT_EQ(got.state, r.state);
  EXPECT_EQ(got.last_sample_stamp_ns, r.last_sample_stamp_ns);
}

TEST(DdsRoundTrip, ControlInput) {
  const auto sent = dds::make_control_input(8, netkf::Vector{{-1.0 / 3.0}});
  EXPECT_EQ(roundtrip(dds::topics::control_input, sent), sent);
}

// Exclusive ownership (topics.hpp): the estimate and the control input, as a hot standby
// publishes them. Two writers of different strengths write the same periods; the reader takes
// only the stronger one's while its liveliness holds (each write asserts it, MANUAL_BY_TOPIC),
// and the weaker one's once the stronger stopped writing for longer than dds::kOwnershipLease.
TEST(DdsOwnership, TheStrongestLiveWriterOwnsTheControlInput) {
  dds::Participant primary_p(options("own-primary")), standby_p(options("own-standby")), plant_p(options("own-plant"));
  Inbox<wire::ControlInput> inbox;
  dds::Reader<wire::ControlInput> reader(plant_p, dds::topics::control_input, inbox.callback());
  dds::Writer<wire::ControlInput> primary(primary_p, dds::topics::control_input,
                                          dds::WriterOptions{.ownership_strength = 2});
  dds::Writer<wire::ControlInput> standby(standby_p, dds::topics::control_input,
                                          dds::WriterOptions{.ownership_strength = 1});
  ASSERT_TRUE(reader.wait_for_matched(2, 10s));
  ASSERT_TRUE(primary.wait_for_matched(1, 10s));
  ASSERT_TRUE(standby.wait_for_matched(1, 10s));
  // Both write every period; the primary's input is +k, the standby's -k.
  std::uint64_t k = 0;
  for (; k < 30; ++k) {
    primary.write(dds::make_control_input(k, netkf::Vector{{static_cast<double>(k)}}));
    standby.write(dds::make_control_input(k, netkf::Vector{{-static_cast<double>(k)}}));
    std::this_thread::sleep_for(10ms);
  }
  ASSERT_TRUE(inbox.wait_for(20, 5s));
  auto got = inbox.take();
  std::size_t from_primary = 0, from_standby = 0;
  for (const auto& c : got) (c.u().at(0) > 0 ? from_primary : from_standby) += c.u().at(0) != 0.0;
  // Until the reader knows both writers alive, a first sample of the standby may pass.
  EXPECT_GE(from_primary, 20u) << from_standby << " from the standby";
  EXPECT_LE(from_standby, 2u);
  // The primary stops (a process killed or stopped): after its lease the standby's inputs pass.
  for (; k < 60; ++k) {
    standby.write(dds::make_control_input(k, netkf::Vector{{-static_cast<double>(k)}}));
    std::this_thread::sleep_for(10ms);
  }
  ASSERT_TRUE(inbox.wait_for(20, 5s));
  got = inbox.take();
  std::size_t standby_after = 0;
  for (const auto& c : got) standby_after += c.u().at(0) < 0;
  EXPECT_GE(standby_after, 20u) << "the standby's inputs did not pass after the primary's lease";
}

TEST(DdsRoundTrip, LinkControlAndReply) {
  const netkf::LinkKeys keys{{"model", std::string("gilbert_elliott")}, {"p", 0.05},        {"r", 0.4},
                             {"loss_good", 0.02},                         {"loss_bad", 0.9}, {"jitter_ms", 1.0 / 3.0}};
  const auto got = roundtrip(dds::topics::link_control, dds::make_link_control(17, 2, keys));
  EXPECT_EQ(got.request_id(), 17u);
  EXPECT_EQ(got.sensor_id(), 2);
  EXPECT_EQ(dds::link_keys_of(got), keys);
  const auto reply = dds::to_wire(netkf::LinkReply{17, 2, false, "loss must be in [0,1]"});
  EXPECT_EQ(roundtrip(dds::topics::link_control_reply, reply), reply);
}

TEST(DdsRoundTrip, LinkStatusReachesLateJoiners) {
  // Transient-local: a reader created after the status was written still receives it.
  dds::Participant a(options("status-writer"));
  dds::Writer<wire::LinkStatus> writer(a, dds::topics::link_status);
  netkf::LinkStatistics stats;
  for (bool d : {true, true, false, true, false}) stats.record(d);
  const netkf::LinkSpec link{netkf::BernoulliLink{0.3}, {4.0, 2.0, netkf::DelayDistribution::uniform}};
  netkf::LinkStatus status;
  status.sensor_id = 2;
  status.link = link;
  status.in_time = 0.75;
  status.count(stats, stats);
  status.last_request_id = 4;
  const auto sent = dds::to_wire(status, 1);
  ASSERT_TRUE(writer.write(sent));
  dds::Participant b(options("status-late-joiner"));
  Inbox<wire::LinkStatus> inbox;
  dds::Reader<wire::LinkStatus> reader(b, dds::topics::link_status, inbox.callback());
  ASSERT_TRUE(inbox.wait_for(1, 10s));
  const auto got = inbox.take().front();
  EXPECT_EQ(got, sent);
  EXPECT_EQ(got.samples_in(), 5u);
  EXPECT_EQ(got.dropped(), 3u);
  EXPECT_DOUBLE_EQ(got.observed_loss(), 0.6);
  EXPECT_DOUBLE_EQ(got.mean_burst_length(), 1.5);  // runs of drops: 2 and 1
  EXPECT_EQ(netkf::dds::link_of(got), link);
}

TEST(DdsRoundTrip, LinkJournalReachesLateJoiners) {
  // The journal is transient-local too: a recorder that joins late still gets every change.
  dds::Participant a(options("journal-writer"));
  dds::Writer<wire::LinkChange> writer(a, dds::topics::link_change);
  const netkf::LinkSpec link{netkf::GilbertElliottLink{0.05, 0.2, 0.0, 1.0}, {}};
  using Origin = netkf::LinkChange::Origin;
  ASSERT_TRUE(writer.write(dds::to_wire(netkf::LinkChange{3, 312, Origin::request, 9, link, {}, {}}, 1)));
  ASSERT_TRUE(writer.write(dds::to_wire(netkf::LinkChange{3, 600, Origin::timeline, 0, netkf::BernoulliLink{0.1}, {}, {}}, 2)));
  dds::Participant b(options("journal-late-joiner"));
  Inbox<wire::LinkChange> inbox;
  dds::Reader<wire::LinkChange> reader(b, dds::topics::link_change, inbox.callback());
  ASSERT_TRUE(inbox.wait_for(2, 10s));
  const auto got = inbox.take();
  EXPECT_EQ(got[0].at_period(), 312u);
  EXPECT_EQ(got[0].origin(), "request");
  EXPECT_EQ(dds::from_wire(got[0].link()), link);
  EXPECT_EQ(got[1].origin(), "timeline");
}

TEST(DdsParticipant, RunsInsideThePrivateNetworkNamespace) {
  // tests/CMakeLists.txt runs this suite through scripts/in-netns.sh.
  const char* flag = std::getenv("NETKF_IN_NETNS");
  ASSERT_NE(flag, nullptr);
  EXPECT_STREQ(flag, "1");
}

TEST(DdsParticipant, DefaultQosIsLocalhostOnly) {
  const auto qos = dds::localhost_participant_qos("check");
  EXPECT_FALSE(qos.transport().use_builtin_transports);
  EXPECT_TRUE(qos.wire_protocol().builtin.metatrafficMulticastLocatorList.empty());
  ASSERT_FALSE(qos.wire_protocol().builtin.metatrafficUnicastLocatorList.empty());
  for (const auto& loc : qos.wire_protocol().builtin.metatrafficUnicastLocatorList) {
    EXPECT_EQ(eprosima::fastrtps::rtps::IPLocator::toIPv4string(loc), "127.0.0.1");
  }
  for (const auto& loc : qos.wire_protocol().builtin.initialPeersList) {
    EXPECT_EQ(eprosima::fastrtps::rtps::IPLocator::toIPv4string(loc), "127.0.0.1");
  }
  dds::Participant p(options("default"));
  EXPECT_EQ(p.domain(), test_domain());
  // The participant really announces only loopback locators.
  const auto attrs = p.get()->get_qos();
  EXPECT_TRUE(attrs.wire_protocol().builtin.metatrafficMulticastLocatorList.empty());
}

// A grouped sensor process was named after all its sensors ("netkf-sensor-129,130,...,192",
// 268 characters): Fast DDS keeps 255 of a participant's name, and a peer then drops that
// participant's announcement, so nothing of it was ever discovered (256 sensors in four
// processes: the plant waited for sensors 129-256 in vain).
TEST(DdsParticipant, AParticipantWithAVeryLongNameIsDiscovered) {
  std::string name = "netkf-sensor-";
  for (int id = 129; id <= 192; ++id) name += std::to_string(id) + (id < 192 ? "," : "");
  ASSERT_GT(name.size(), 255u);
  dds::Participant a(options(name)), b(options("short"));
  dds::Writer<wire::Measurement> writer(a, dds::topics::raw_measurement);
  Inbox<wire::Measurement> inbox;
  dds::Reader<wire::Measurement> reader(b, dds::topics::raw_measurement, inbox.callback());
  ASSERT_TRUE(writer.wait_for_matched(1, 10s)) << "the long-named participant was never discovered";
  ASSERT_TRUE(writer.write(dds::make_measurement(129, 1, 0, netkf::Vector{{1.0}})));
  EXPECT_TRUE(inbox.wait_for(1, 10s));
  EXPECT_LE(std::string(a.get()->get_qos().name().c_str()).size(), 255u);
}

TEST(DdsParticipant, ShippedLocalhostProfileDiscovers) {
  auto o = options("profile-a");
  o.profile_file = netkf::test::source_dir() / "deploy/dds/localhost.xml";
  dds::Participant a(o);
  o.name = "profile-b";
  dds::Participant b(o);
  EXPECT_TRUE(b.get()->get_qos().wire_protocol().builtin.metatrafficMulticastLocatorList.empty());
  EXPECT_FALSE(b.get()->get_qos().transport().use_builtin_transports);
  // The file announces as often as the built-in profile (participant.cpp).
  EXPECT_EQ(b.get()->get_qos().wire_protocol().builtin.discovery_config.leaseDuration_announcementperiod,
            dds::localhost_participant_qos("x").wire_protocol().builtin.discovery_config.leaseDuration_announcementperiod);
  EXPECT_EQ(b.get()->get_qos().wire_protocol().builtin.discovery_config.leaseDuration_announcementperiod,
            eprosima::fastrtps::Duration_t(1, 0));
  Inbox<wire::Tick> inbox;
  dds::Reader<wire::Tick> reader(b, dds::topics::tick, inbox.callback());
  dds::Writer<wire::Tick> writer(a, dds::topics::tick);
  ASSERT_TRUE(writer.wait_for_matched(1, 10s));
  writer.write(dds::make_tick(1, 0.01, netkf::Vector(), false));
  EXPECT_TRUE(inbox.wait_for(1, 10s));
}

TEST(DdsParticipant, ShippedDiscoveryServerProfileLoads) {
  // No server runs here: the participant is created as a Discovery Server client.
  auto o = options("ds-client");
  o.profile_file = netkf::test::source_dir() / "deploy/dds/discovery-server.xml";
  dds::Participant p(o);
  const auto qos = p.get()->get_qos();
  EXPECT_EQ(qos.wire_protocol().builtin.discovery_config.discoveryProtocol,
            eprosima::fastrtps::rtps::DiscoveryProtocol_t::CLIENT);
  EXPECT_TRUE(qos.wire_protocol().builtin.metatrafficMulticastLocatorList.empty());
}

TEST(DdsParticipant, MissingProfileFileIsAClearError) {
  auto o = options("missing");
  o.profile_file = "/nonexistent/netkf-profile.xml";
  try {
    dds::Participant p(o);
    FAIL() << "expected DdsError";
  } catch (const dds::DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
}

TEST(DdsParticipant, MalformedProfileFileIsAClearError) {
  const auto file = std::filesystem::temp_directory_path() / ("netkf-bad-profile-" + std::to_string(::getpid()) + ".xml");
  std::ofstream(file) << "<dds><profiles><participant profile_name=\"x\"><rtps><oops></dds>";
  auto o = options("malformed");
  o.profile_file = file;
  try {
    dds::Participant p(o);
    FAIL() << "expected DdsError";
  } catch (const dds::DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("not a valid Fast DDS XML profile"), std::string::npos) << e.what();
  }
  std::filesystem::remove(file);
}

TEST(DdsParticipant, DomainAndProfileResolution) {
  ::setenv(dds::kDomainEnv, "17", 1);
  EXPECT_EQ(dds::resolve_domain(std::nullopt), 17);
  EXPECT_EQ(dds::resolve_domain(3), 3);
  ::setenv(dds::kDomainEnv, "x7", 1);
  EXPECT_THROW(dds::resolve_domain(std::nullopt), dds::DdsError);
  ::unsetenv(dds::kDomainEnv);
  EXPECT_EQ(dds::resolve_domain(std::nullopt), 0);
  EXPECT_THROW(dds::resolve_domain(500), dds::DdsError);
  ::setenv(dds::kProfileEnv, "/tmp/p.xml", 1);
  EXPECT_EQ(dds::resolve_profile(std::nullopt).value(), "/tmp/p.xml");
  EXPECT_EQ(dds::resolve_profile(std::string("a.xml")).value(), "a.xml");
  ::unsetenv(dds::kProfileEnv);
  EXPECT_FALSE(dds::resolve_profile(std::nullopt).has_value());
}

}  // namespace

// Reliable writers heartbeat every 250 ms (Fast DDS's 3 s default let histories fill and
// turned every write into a heartbeat + acknowledgement, topics.hpp), and a writer's history
// holds three heartbeat periods of its rate, never less than the topic's depth.
TEST(DdsQos, HeartbeatPeriodAndHistoryDepthFollowTheWriterRate) {
  const auto q = netkf::dds::writer_qos(netkf::dds::topics::raw_measurement.qos);
  EXPECT_EQ(q.reliable_writer_qos().times.heartbeatPeriod, eprosima::fastrtps::Duration_t(0, 250000000u));
  EXPECT_EQ(q.reliable_writer_qos().times.nackSupressionDuration, eprosima::fastrtps::Duration_t(0, 50000000u));
  EXPECT_EQ(q.history().depth, 256);
  EXPECT_EQ(netkf::dds::history_depth_for_rate(0.0, 256), 256);
  EXPECT_EQ(netkf::dds::history_depth_for_rate(100.0, 256), 256);    // one sensor at 100 Hz: 75 < 256
  EXPECT_EQ(netkf::dds::history_depth_for_rate(1600.0, 256), 1200);  // 16 sensors in one process
  EXPECT_EQ(netkf::dds::history_depth_for_rate(12800.0, 4096), 9600);  // the channel, 128 sensors
  EXPECT_EQ(netkf::dds::history_depth_for_rate(333.3, 1), 250);      // rounds up

  netkf::dds::Participant p(options("qos-test"));
  netkf::dds::Writer<wire::Measurement> fast(p, netkf::dds::topics::raw_measurement, 3200.0);  // 32 sensors at 100 Hz
  eprosima::fastdds::dds::DataWriterQos applied;
  ASSERT_EQ(fast.get()->get_qos(applied), eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK);
  EXPECT_EQ(applied.history().depth, 2400);
  EXPECT_EQ(applied.resource_limits().max_samples, 2400);
  EXPECT_EQ(applied.reliable_writer_qos().times.heartbeatPeriod, eprosima::fastrtps::Duration_t(0, 250000000u));
  EXPECT_EQ(applied.endpoint().history_memory_policy, eprosima::fastrtps::rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE);

  // Batches: payloads sized by the sample, not by the type's ~84 kB largest, on both ends.
  netkf::dds::Writer<wire::MeasurementBatch> batches(p, netkf::dds::topics::delivered_measurement_batch, 12800.0);
  ASSERT_EQ(batches.get()->get_qos(applied), eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK);
  EXPECT_EQ(applied.history().depth, 9600);
  EXPECT_EQ(applied.endpoint().history_memory_policy, eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE);
  netkf::dds::Reader<wire::MeasurementBatch> batch_reader(p, netkf::dds::topics::delivered_measurement_batch, {});
  eprosima::fastdds::dds::DataReaderQos reader_applied;
  ASSERT_EQ(batch_reader.get()->get_qos(reader_applied), eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK);
  EXPECT_EQ(reader_applied.endpoint().history_memory_policy, eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE);
}

namespace {

dds::ParticipantOptions with_run(const std::string& name, std::uint64_t run) {
  auto o = options(name);
  o.run = run;
  return o;
}

// Two launches on one domain by mistake: each stamps its run id and drops the other's samples
// (counted); a process without a run id (0) neither stamps nor drops. The samples written
// last by run 7's writer prove delivery still works, so the drop is not a lost match.
TEST(DdsRunId, SamplesOfAnotherRunAreDroppedAndCounted) {
  dds::Participant ours(with_run("run-7-reader", 7)), theirs(with_run("run-9-writer", 9)),
      same(with_run("run-7-writer", 7)), any(with_run("run-0-reader", 0));
  Inbox<wire::Measurement> ours_in, any_in;
  dds::Reader<wire::Measurement> ours_reader(ours, dds::topics::delivered_measurement, ours_in.callback());
  dds::Reader<wire::Measurement> any_reader(any, dds::topics::delivered_measurement, any_in.callback());
  dds::Writer<wire::Measurement> foreign_writer(theirs, dds::topics::delivered_measurement);
  dds::Writer<wire::Measurement> own_writer(same, dds::topics::delivered_measurement);
  ASSERT_TRUE(foreign_writer.wait_for_matched(2, 10s));
  ASSERT_TRUE(own_writer.wait_for_matched(2, 10s));
  for (std::uint64_t k = 0; k < 5; ++k)
    ASSERT_TRUE(foreign_writer.write(dds::make_measurement(3, k, 0, netkf::Vector{{1.0}})));
  ASSERT_TRUE(foreign_writer.wait_for_acknowledgments(10s));
  ASSERT_TRUE(own_writer.write(dds::make_measurement(3, 99, 0, netkf::Vector{{2.0}})));
  ASSERT_TRUE(ours_in.wait_for(1, 10s));
  ASSERT_TRUE(any_in.wait_for(6, 10s));
  const auto got = ours_in.take();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got.front().k(), 99u);
  EXPECT_EQ(got.front().run(), 7u);
  EXPECT_EQ(ours.foreign_samples(), 5u);
  EXPECT_EQ(any.foreign_samples(), 0u);
  for (const auto& m : any_in.take()) EXPECT_EQ(m.run(), m.k() == 99 ? 7u : 9u);
}

}  // namespace

namespace {

// Presence: what a process announces reaches a watcher that joins later (transient-local), its
// end is seen, and so is its leaving (the writer's instance becomes not-alive).
TEST(DdsPresence, AnnouncedEndedAndGoneAsTheyHappen) {
  auto sensor = std::make_unique<dds::Participant>(with_run("presence-sensor", 5));
  auto announcer = std::make_unique<dds::PresenceAnnouncer>(*sensor, dds::presence_role::sensors,
                                                            std::vector<int>{1, 2}, 0xabcdefULL);
  dds::Participant observer(options("presence-watcher"));
  dds::PresenceWatcher watcher(observer);
  auto find = [&]() -> std::optional<dds::PresenceRecord> {
    for (const auto& p : watcher.processes())
      if (p.pid == ::getpid() && p.role == dds::presence_role::sensors) return p;
    return std::nullopt;
  };
  ASSERT_TRUE(dds::detail::wait_until([&] { return find() ? 1 : 0; }, 1, 10s)) << "the late watcher sees the presence";
  auto p = *find();
  EXPECT_EQ(p.host, dds::this_host());
  EXPECT_EQ(p.sensor_ids, (std::vector<int>{1, 2}));
  EXPECT_EQ(p.scenario_hash, 0xabcdefULL);
  EXPECT_EQ(p.run, 5u);
  EXPECT_TRUE(p.running());
  EXPECT_EQ(p.who(), "sensors 1,2 (pid " + std::to_string(::getpid()) + " on " + dds::this_host() + ")");

  announcer->end("the run ended");
  ASSERT_TRUE(dds::detail::wait_until([&] { return find() && find()->ended ? 1 : 0; }, 1, 10s));
  EXPECT_EQ(find()->detail, "the run ended");
  EXPECT_TRUE(find()->alive);

  announcer.reset();
  sensor.reset();
  ASSERT_TRUE(dds::detail::wait_until([&] { return find() && !find()->alive ? 1 : 0; }, 1, 10s))
      << "a process that left is no longer alive";
}

dds::PresenceRecord present(const std::string& role, std::vector<int> ids, std::uint64_t run, std::uint64_t hash) {
  dds::PresenceRecord p;
  p.host = "host-x";
  p.pid = 100 + static_cast<int>(ids.empty() ? role.size() : ids.front());
  p.role = role;
  p.sensor_ids = std::move(ids);
  p.run = run;
  p.scenario_hash = hash;
  return p;
}

TEST(DdsPresence, ReadinessNamesWhatIsMissingAndRefusesAnotherScenario) {
  namespace role = dds::presence_role;
  std::vector<dds::PresenceRecord> seen{present(role::sensors, {1, 2}, 7, 42), present(role::launch, {}, 7, 42)};
  auto r = dds::assess_readiness(seen, {1, 2, 3}, 7, 42);
  EXPECT_FALSE(r.ready);
  EXPECT_EQ(r.missing, (std::vector<std::string>{"sensor 3", "the channel emulator", "the estimator"}));
  EXPECT_EQ(r.truth_readers, 2);
  EXPECT_EQ(dds::assess_readiness(seen, {1, 2, 3, 4, 5, 7, 9, 10}, 7, 42).missing,
            (std::vector<std::string>{"sensors 3-5", "sensor 7", "sensors 9-10", "the channel emulator",
                                      "the estimator"}));

  seen.push_back(present(role::sensors, {3}, 0, 42));  // started by hand: run 0 belongs to any run
  seen.push_back(present(role::channel, {}, 7, 42));
  seen.push_back(present(role::estimator, {}, 9, 42));  // another run's estimator does not count
  seen.push_back(present(role::record, {}, 0, 0));     // a recorder without a scenario hash
  r = dds::assess_readiness(seen, {1, 2, 3}, 7, 42);
  EXPECT_FALSE(r.ready);
  EXPECT_EQ(r.missing, (std::vector<std::string>{"the estimator"}));
  EXPECT_EQ(r.truth_readers, 4);  // two sensor processes, the launch, the recorder
  ASSERT_EQ(dds::other_runs(seen, 7).size(), 1u);
  EXPECT_EQ(dds::other_runs(seen, 7).front().role, role::estimator);

  auto gone = present(role::estimator, {}, 7, 42);
  gone.alive = false;
  seen.push_back(gone);
  EXPECT_FALSE(dds::assess_readiness(seen, {1, 2, 3}, 7, 42).ready) << "an estimator that left is not present";
  seen.push_back(present(role::estimator, {}, 7, 42));
  r = dds::assess_readiness(seen, {1, 2, 3}, 7, 42);
  EXPECT_TRUE(r.ready);
  EXPECT_TRUE(r.missing.empty());

  seen.push_back(present(role::channel, {}, 7, 43));  // same run, another scenario
  r = dds::assess_readiness(seen, {1, 2, 3}, 7, 42);
  EXPECT_FALSE(r.ready);
  ASSERT_TRUE(r.conflict.has_value());
  EXPECT_NE(r.conflict->find("channel (pid 107 on host-x) loaded another scenario"), std::string::npos) << *r.conflict;
}

TEST(DdsDiscoveryServer, AddressesAreCheckedAndTheRouteGivesTheOwnAddress) {
  const auto s = dds::parse_discovery_server("10.1.2.3:12000");
  EXPECT_EQ(s.address, "10.1.2.3");
  EXPECT_EQ(s.port, 12000);
  EXPECT_EQ(dds::parse_discovery_server("10.1.2.3").port, 11811);
  for (const char* bad : {"server:11811", "10.1.2.3:0", "10.1.2.3:70000", "10.1.2.3:x", "0.0.0.0:11811", ""})
    EXPECT_THROW(dds::parse_discovery_server(bad), dds::DdsError) << bad;
  EXPECT_EQ(dds::local_address_towards(dds::parse_discovery_server("127.0.0.5:11811")), "127.0.0.1");
}

// Clients have no multicast and no initial peers: they find each other only through the server.
// Without it (a port where nothing serves) nothing matches; with it, a sample arrives.
TEST(DdsDiscoveryServer, ClientsFindEachOtherOnlyThroughTheServer) {
  const auto port = static_cast<std::uint16_t>(20000 + ::getpid() % 20000);
  auto client = [&](const std::string& name, std::uint16_t server_port) {
    auto o = options(name);
    o.discovery_server = dds::DiscoveryServerAddress{"127.0.0.1", server_port};
    return o;
  };
  {
    dds::Participant a(client("lonely-writer", static_cast<std::uint16_t>(port + 1)));
    dds::Participant b(client("lonely-reader", static_cast<std::uint16_t>(port + 1)));
    dds::Writer<wire::Measurement> w(a, dds::topics::raw_measurement);
    dds::Reader<wire::Measurement> r(b, dds::topics::raw_measurement, {});
    EXPECT_FALSE(w.wait_for_matched(1, 3s)) << "clients matched without a discovery server";
  }
  auto server_options = options("discovery-server");
  server_options.discovery_server = dds::DiscoveryServerAddress{"127.0.0.1", port};
  server_options.serve_discovery = true;
  dds::Participant server(server_options);
  dds::Participant a(client("client-writer", port));
  dds::Participant b(client("client-reader", port));
  Inbox<wire::Measurement> in;
  dds::Writer<wire::Measurement> w(a, dds::topics::raw_measurement);
  dds::Reader<wire::Measurement> r(b, dds::topics::raw_measurement, in.callback());
  ASSERT_TRUE(w.wait_for_matched(1, 15s)) << "clients of the server did not match";
  ASSERT_TRUE(w.write(dds::make_measurement(4, 12, 0, netkf::Vector{{1.5}})));
  ASSERT_TRUE(in.wait_for(1, 10s));
  EXPECT_EQ(in.take().front().k(), 12u);
}

}  // namespace
