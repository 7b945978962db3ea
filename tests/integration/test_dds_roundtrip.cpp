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

#include <fastrtps/utils/IPLocator.h>

#include "netkf/dds/dds.hpp"

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

TEST(DdsRoundTrip, EstimateConvertsBackToTheSameRecord) {
  dds::EstimateRecord r;
  r.k = 5;
  r.t = 0.05;
  r.x_hat = netkf::Vector{{1.0 / 3.0, -2.0 / 7.0}};
  r.P = netkf::Matrix{{2.0 / 3.0, 0.1}, {0.2, 5.0 / 9.0}};  // not symmetric: checks row-major order
  r.fused = {1, 3};
  r.late = 2;
  r.late_sensors = {3, 1};  // in order of arrival, not sorted
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
  EXPECT_EQ(got.late_total, r.late_total);
  EXPECT_EQ(got.rejected_total, r.rejected_total);
  EXPECT_EQ(got.state, r.state);
  EXPECT_EQ(got.last_sample_stamp_ns, r.last_sample_stamp_ns);
}

TEST(DdsRoundTrip, ControlInput) {
  const auto sent = dds::make_control_input(8, netkf::Vector{{-1.0 / 3.0}});
  EXPECT_EQ(roundtrip(dds::topics::control_input, sent), sent);
}

TEST(DdsRoundTrip, LinkControlAndReply) {
  const netkf::LinkKeys keys{{"model", std::string("gilbert_elliott")}, {"p", 0.05},        {"r", 0.4},
                             {"loss_good", 0.02},                         {"loss_bad", 0.9}, {"jitter_ms", 1.0 / 3.0}};
  const auto got = roundtrip(dds::topics::link_control, dds::make_link_control(17, 2, keys));
  EXPECT_EQ(got.request_id(), 17u);
  EXPECT_EQ(got.sensor_id(), 2);
  EXPECT_EQ(dds::link_keys_of(got), keys);
  const auto reply = dds::make_link_control_reply(17, 2, false, "loss must be in [0,1]");
  EXPECT_EQ(roundtrip(dds::topics::link_control_reply, reply), reply);
}

TEST(DdsRoundTrip, LinkStatusReachesLateJoiners) {
  // Transient-local: a reader created after the status was written still receives it.
  dds::Participant a(options("status-writer"));
  dds::Writer<wire::LinkStatus> writer(a, dds::topics::link_status);
  netkf::LinkStatistics stats;
  for (bool d : {true, true, false, true, false}) stats.record(d);
  const netkf::LinkSpec link{netkf::BernoulliLink{0.3}, {4.0, 2.0, netkf::DelayDistribution::uniform}};
  const auto sent = dds::make_link_status({2, link, 0.75, stats, stats, 4, false, "", 0}, 1);
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
  ASSERT_TRUE(writer.write(dds::make_link_change(3, 312, "request", 9, link, 1)));
  ASSERT_TRUE(writer.write(dds::make_link_change(3, 600, "timeline", 0, netkf::BernoulliLink{0.1}, 2)));
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

TEST(DdsParticipant, ShippedLocalhostProfileDiscovers) {
  auto o = options("profile-a");
  o.profile_file = netkf::test::source_dir() / "deploy/dds/localhost.xml";
  dds::Participant a(o);
  o.name = "profile-b";
  dds::Participant b(o);
  EXPECT_TRUE(b.get()->get_qos().wire_protocol().builtin.metatrafficMulticastLocatorList.empty());
  EXPECT_FALSE(b.get()->get_qos().transport().use_builtin_transports);
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
}

namespace {

// Two launches on one domain by mistake: each stamps its run id and drops the other's samples
// (counted); a process without a run id (0) neither stamps nor drops. The samples written
// last by run 7's writer prove delivery still works, so the drop is not a lost match.
TEST(DdsRunId, SamplesOfAnotherRunAreDroppedAndCounted) {
  auto with_run = [](const std::string& name, std::uint64_t run) {
    auto o = options(name);
    o.run = run;
    return o;
  };
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
