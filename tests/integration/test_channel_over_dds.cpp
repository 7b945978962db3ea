// The channel logic over DDS: samples published on the raw topic are relayed to the
// delivered topic exactly as an offline ChannelLinks with the same scenario seed decides
// (reliable transport, so the only losses are the link model's), and a LinkControl
// request changes the link from the next sample on with a reply and a status.
#include <gtest/gtest.h>
#include <unistd.h>

#include <utility>  // before Asio (docs/dds-notes.md)

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <set>
#include <thread>

#include "netkf/dds/dds.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/nodes/channel_links.hpp"

namespace {

using namespace std::chrono_literals;
namespace wire = netkf::wire;
namespace dds = netkf::dds;

int test_domain() { return 1 + static_cast<int>((::getpid() + 100) % 200); }

netkf::Scenario scenario() {
  netkf::Scenario s;
  s.name = "it-channel";
  s.seed = 2024;
  s.plant.A = netkf::Matrix::Identity(1, 1);
  s.plant.Q = netkf::Matrix::Identity(1, 1);
  for (int id : {1, 2}) {
    netkf::SensorSpec sp;
    sp.id = id;
    sp.C = netkf::Matrix::Identity(1, 1);
    sp.R = netkf::Matrix::Identity(1, 1);
    sp.link = id == 1 ? netkf::LinkModel(netkf::BernoulliLink{0.3})
                      : netkf::LinkModel(netkf::GilbertElliottLink{0.1, 0.3, 0.0, 1.0});
    s.sensors.push_back(sp);
  }
  return s;
}

/// A channel emulator in-process: the same wiring as channel_emulator/src/main.cpp.
class Relay {
 public:
  explicit Relay(const netkf::Scenario& sc)
      : links_(sc),
        participant_(make_options()),
        delivered_(participant_, dds::topics::delivered_measurement),
        reply_(participant_, dds::topics::link_control_reply),
        status_(participant_, dds::topics::link_status),
        raw_(participant_, dds::topics::raw_measurement,
             dds::post_to<wire::Measurement>(io_.get_executor(),
                                             [this](wire::Measurement m) {
                                               if (links_.on_sample(m.sensor_id()) ==
                                                   netkf::nodes::ChannelLinks::Verdict::delivered)
                                                 delivered_.write(m);
                                             })),
        control_(participant_, dds::topics::link_control,
                 dds::post_to<wire::LinkControl>(io_.get_executor(), [this](wire::LinkControl c) {
                   const netkf::LinkReply r = links_.request(c.request_id(), c.sensor_id(), dds::link_keys_of(c));
                   reply_.write(dds::to_wire(r));
                   for (const auto& status : links_.statuses()) status_.write(dds::to_wire(status, 0));
                 })),
        work_(io_.get_executor()),
        thread_([this] { io_.run(); }) {}
  /// Both ends of a match must see it: a volatile writer sends nothing to a reader it has not
  /// matched yet, even when the reader already matched the writer.
  bool wait_for_delivered_readers(int n, std::chrono::milliseconds timeout) const {
    return delivered_.wait_for_matched(n, timeout);
  }
  ~Relay() {
    work_.reset();
    io_.stop();
    thread_.join();
  }

 private:
  static dds::ParticipantOptions make_options() {
    dds::ParticipantOptions o;
    o.domain = test_domain();
    o.name = "it-channel";
    return o;
  }
  boost::asio::io_context io_;
  netkf::nodes::ChannelLinks links_;
  dds::Participant participant_;
  dds::Writer<wire::Measurement> delivered_;
  dds::Writer<wire::LinkControlReply> reply_;
  dds::Writer<wire::LinkStatus> status_;
  dds::Reader<wire::Measurement> raw_;
  dds::Reader<wire::LinkControl> control_;
  boost::asio::executor_work_guard<boost::asio::io_context::executor_type> work_;
  std::thread thread_;
};

struct Collected {
  std::mutex m;
  std::condition_variable cv;
  std::set<std::pair<int, std::uint64_t>> delivered;
  std::vector<wire::LinkControlReply> replies;
};

TEST(ChannelOverDds, DropsExactlyAsTheSeededModelDecides) {
  const auto sc = scenario();
  Relay relay(sc);
  dds::ParticipantOptions o;
  o.domain = test_domain();
  o.name = "it-ends";
  dds::Participant ends(o);
  Collected c;
  dds::Reader<wire::Measurement> sink(ends, dds::topics::delivered_measurement, [&](wire::Measurement&& m) {
    std::lock_guard lock(c.m);
    c.delivered.emplace(m.sensor_id(), m.k());
    c.cv.notify_all();
  });
  dds::Writer<wire::Measurement> raw(ends, dds::topics::raw_measurement);
  ASSERT_TRUE(raw.wait_for_matched(1, 10s));
  ASSERT_TRUE(sink.wait_for_matched(1, 10s));
  ASSERT_TRUE(relay.wait_for_delivered_readers(1, 10s));

  // Offline expectation from an identical, independently constructed set of links.
  netkf::nodes::ChannelLinks offline(sc);
  std::set<std::pair<int, std::uint64_t>> expected;
  const std::uint64_t periods = 1000;
  for (std::uint64_t k = 0; k < periods; ++k) {
    for (int id : {1, 2}) {
      if (offline.on_sample(id) == netkf::nodes::ChannelLinks::Verdict::delivered) expected.emplace(id, k);
      ASSERT_TRUE(raw.write(dds::make_measurement(id, k, dds::steady_now_ns(), netkf::Vector{{double(k)}})));
    }
    // Pace the writer well below what a loaded 2-core machine relays (docs/dds-notes.md: a keep-last
    // writer that outruns its reader loses samples, which here would look like link drops).
    std::this_thread::sleep_for(1ms);
  }
  std::unique_lock lock(c.m);
  c.cv.wait_for(lock, 20s, [&] { return c.delivered.size() >= expected.size(); });
  std::this_thread::sleep_for(200ms);  // nothing extra may arrive either
  EXPECT_EQ(c.delivered, expected);
  // Sanity on the model itself: link 1 delivered about 70 %.
  const auto link1 = std::count_if(expected.begin(), expected.end(), [](auto& e) { return e.first == 1; });
  EXPECT_NEAR(double(link1) / periods, 0.7, 4 * std::sqrt(0.21 / periods));
}

TEST(ChannelOverDds, LinkControlChangesTheLinkAndRepliesAndRejectsBadRequests) {
  Relay relay(scenario());
  dds::ParticipantOptions o;
  o.domain = test_domain();
  o.name = "it-ctl";
  dds::Participant ctl(o);
  Collected c;
  dds::Reader<wire::LinkControlReply> replies(ctl, dds::topics::link_control_reply,
                                              [&](wire::LinkControlReply&& r) {
                                                std::lock_guard lock(c.m);
                                                c.replies.push_back(r);
                                                c.cv.notify_all();
                                              });
  dds::Reader<wire::Measurement> sink(ctl, dds::topics::delivered_measurement, [&](wire::Measurement&& m) {
    std::lock_guard lock(c.m);
    c.delivered.emplace(m.sensor_id(), m.k());
    c.cv.notify_all();
  });
  dds::Writer<wire::LinkControl> control(ctl, dds::topics::link_control);
  dds::Writer<wire::Measurement> raw(ctl, dds::topics::raw_measurement);
  ASSERT_TRUE(control.wait_for_matched(1, 10s));
  ASSERT_TRUE(replies.wait_for_matched(1, 10s));
  ASSERT_TRUE(raw.wait_for_matched(1, 10s));
  ASSERT_TRUE(sink.wait_for_matched(1, 10s));
  ASSERT_TRUE(relay.wait_for_delivered_readers(1, 10s));

  const auto bernoulli = [](double loss) {
    return netkf::LinkKeys{{"model", std::string("bernoulli")}, {"loss", loss}};
  };
  control.write(dds::make_link_control(1, 1, bernoulli(1.0)));
  control.write(dds::make_link_control(2, 1, bernoulli(1.5)));
  control.write(dds::make_link_control(3, 1, {{"model", std::string("pareto")}, {"loss", 0.0}}));
  control.write(dds::make_link_control(4, 9, bernoulli(0.0)));
  {
    std::unique_lock lock(c.m);
    ASSERT_TRUE(c.cv.wait_for(lock, 10s, [&] { return c.replies.size() >= 4; }));
    EXPECT_TRUE(c.replies[0].applied());
    EXPECT_FALSE(c.replies[1].applied());
    EXPECT_NE(c.replies[1].reason().find("loss"), std::string::npos) << c.replies[1].reason();
    EXPECT_FALSE(c.replies[2].applied());
    EXPECT_NE(c.replies[2].reason().find("pareto"), std::string::npos);
    EXPECT_FALSE(c.replies[3].applied());
    EXPECT_NE(c.replies[3].reason().find("unknown sensor"), std::string::npos);
  }
  // Link 1 now drops everything (the rejected requests changed nothing); link 2 still delivers.
  for (std::uint64_t k = 0; k < 200; ++k) {
    raw.write(dds::make_measurement(1, k, 0, netkf::Vector{{0.0}}));
    std::this_thread::sleep_for(200us);
  }
  raw.write(dds::make_measurement(2, 0, 0, netkf::Vector{{0.0}}));  // GE starts Good, loss_good 0: delivered
  std::unique_lock lock(c.m);
  EXPECT_TRUE(c.cv.wait_for(lock, 10s, [&] { return c.delivered.contains({2, 0}); }));
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(std::count_if(c.delivered.begin(), c.delivered.end(), [](auto& e) { return e.first == 1; }), 0);
}

}  // namespace
