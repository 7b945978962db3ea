// The nodes' real wiring in process: PlantApp, SensorApp, ChannelApp and EstimatorApp, each on
// its own participant as the processes are, on one domain. Every observable result is checked
// against an independent offline computation with the same scenario and seed: which samples
// the channel delivers (ChannelLinks), what each sensor measured from the truth it received
// (SensorSimulator), and the estimates (IntermittentKalmanFilter over the samples each
// estimate says it fused). And ChannelApp answers a link change request.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <utility>

#include "netkf/dds/dds.hpp"
#include "netkf/filter/kalman_filter.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/nodes/channel_app.hpp"
#include "netkf/nodes/channel_links.hpp"
#include "netkf/nodes/estimator_app.hpp"
#include "netkf/nodes/plant_app.hpp"
#include "netkf/nodes/sensor_app.hpp"
#include "netkf/nodes/sensor_simulator.hpp"

namespace {

using namespace std::chrono_literals;
namespace wire = netkf::wire;
namespace dds = netkf::dds;
namespace nodes = netkf::nodes;

int test_domain() { return 1 + static_cast<int>((::getpid() + 50) % 200); }

dds::ParticipantOptions options(const std::string& name) {
  dds::ParticipantOptions o;
  o.domain = test_domain();
  o.name = name;
  return o;
}

// Open loop, a stable plant (no state bound reached), two sensors: link 1 lossless, link 2 a
// Bernoulli link that drops about 40 %.
netkf::Scenario scenario() {
  netkf::Scenario s;
  s.name = "it-node-apps";
  s.seed = 11;
  s.period_ms = 100;
  s.plant.A = netkf::Matrix{{0.95, 0.1}, {0.0, 0.9}};
  s.plant.Q = netkf::Matrix{{0.2, 0.02}, {0.02, 0.1}};
  s.plant.x0 = netkf::Vector{{1.0, -0.5}};
  s.plant.P0 = netkf::Matrix{{1.0, 0.0}, {0.0, 1.0}};
  for (int id : {1, 2}) {
    netkf::SensorSpec sp;
    sp.id = id;
    sp.C = id == 1 ? netkf::Matrix{{1.0, 0.0}} : netkf::Matrix{{0.5, 1.0}};
    sp.R = netkf::Matrix{{0.3 * id}};
    sp.link = netkf::BernoulliLink{id == 1 ? 0.0 : 0.4};
    s.sensors.push_back(sp);
  }
  return s;
}

/// One node: its participant, its app and the thread running it (stopped and joined on scope exit).
template <class App>
class Running {
 public:
  template <class... Options>
  Running(const std::string& name, const netkf::Scenario& sc, Options&&... o)
      : participant_(options(name)), app_(sc, participant_, std::forward<Options>(o)...), thread_([this] { app_.run(); }) {}
  ~Running() {
    app_.stop();
    thread_.join();
  }
  App& app() { return app_; }

 private:
  dds::Participant participant_;
  App app_;
  std::thread thread_;
};

/// Poll `done` until it holds or `timeout` passes (discovery has no event to wait on here).
bool eventually(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(10ms);
  }
  return true;
}

/// What the test's own participant saw.
struct Seen {
  std::mutex m;
  std::condition_variable cv;
  std::map<std::uint64_t, netkf::Vector> truth;
  std::map<std::pair<int, std::uint64_t>, netkf::Vector> delivered;
  std::map<std::uint64_t, netkf::Estimate> estimates;
  std::uint64_t duplicates = 0;
  template <class Pred>
  bool wait(Pred pred, std::chrono::milliseconds timeout) {
    std::unique_lock lock(m);
    return cv.wait_for(lock, timeout, pred);
  }
};

TEST(NodeApps, TheFourNodesInOneProcessMatchTheOfflineComputation) {
  const auto sc = scenario();
  const int n = sc.state_dim();
  const std::uint64_t periods = 50;

  dds::Participant harness(options("it-harness"));
  Seen seen;
  dds::Reader<wire::Truth> truth(harness, dds::topics::truth, [&](wire::Truth&& t) {
    const auto x = dds::truth_state(t, n);
    std::lock_guard lock(seen.m);
    if (!seen.truth.emplace(t.k(), x).second) ++seen.duplicates;
    seen.cv.notify_all();
  });
  const auto on_delivered = [&](const wire::Measurement& m) {
    const auto s = dds::to_sensor_sample(m);
    std::lock_guard lock(seen.m);
    if (!seen.delivered.emplace(std::pair{s.sensor_id, m.k()}, s.y).second) ++seen.duplicates;
    seen.cv.notify_all();
  };
  dds::Reader<wire::Measurement> delivered(harness, dds::topics::delivered_measurement,
                                           [&](wire::Measurement&& m) { on_delivered(m); });
  // The sensor process hosts both sensors: its samples travel in batches.
  dds::Reader<wire::MeasurementBatch> delivered_batches(harness, dds::topics::delivered_measurement_batch,
                                                        [&](wire::MeasurementBatch&& b) {
                                                          for (const auto& m : b.samples()) on_delivered(m);
                                                        });
  dds::Reader<wire::Estimate> estimates(harness, dds::topics::estimate, [&](wire::Estimate&& w) {
    const auto e = dds::from_wire(w, n);
    std::lock_guard lock(seen.m);
    if (!seen.estimates.emplace(e.k, e).second) ++seen.duplicates;
    seen.cv.notify_all();
  });

  {
    // The plant (the clock) last, as `netkf launch` starts them.
    Running<nodes::ChannelApp> channel("it-channel", sc, nodes::ChannelAppOptions{});
    Running<nodes::EstimatorApp> estimator("it-estimator", sc, nodes::EstimatorAppOptions{});
    Running<nodes::SensorApp> sensors("it-sensors", sc, nodes::SensorAppOptions{{1, 2}});
    // A volatile writer sends nothing to a reader it has not matched yet: the sensors' raw
    // writer must match the channel, the channel's delivered writer the estimator and us.
    ASSERT_TRUE(eventually([&] { return sensors.app().stats().raw_readers >= 1; }, 10s));
    ASSERT_TRUE(eventually([&] { return channel.app().stats().delivered_readers >= 2; }, 10s));
    ASSERT_TRUE(estimates.wait_for_matched(1, 10s));

    nodes::PlantAppOptions plant_options;
    plant_options.max_periods = periods;
    plant_options.truth_readers = 2;  // the sensors' process and this test
    Running<nodes::PlantApp> plant("it-plant", sc, plant_options);

    // 50 periods of 100 ms after the plant's start-up wait; generous for a loaded machine.
    ASSERT_TRUE(seen.wait([&] { return seen.estimates.contains(periods - 1); }, 60s))
        << "no estimate for the last period";
    ASSERT_TRUE(eventually([&] { return plant.app().stats().finished; }, 5s));
    const auto plant_stats = plant.app().stats();
    EXPECT_EQ(plant_stats.periods, periods);
    EXPECT_EQ(plant_stats.missing_inputs, 0u) << "open loop: no input is expected";

    // The last period's estimate may have been fused at its deadline, before its last samples
    // were measured or relayed: wait (bounded) for the counts to reach every period.
    EXPECT_TRUE(eventually(
        [&] {
          const auto s = sensors.app().stats().sensors;
          return std::all_of(s.begin(), s.end(), [&](auto& e) { return e.measured >= periods; });
        },
        5s));
    const auto sensor_stats = sensors.app().stats();
    ASSERT_EQ(sensor_stats.sensors.size(), 2u);
    for (const auto& s : sensor_stats.sensors) {
      EXPECT_EQ(s.measured, periods) << "sensor " << s.id;
      EXPECT_EQ(s.skipped, 0u) << "sensor " << s.id;
    }
    EXPECT_TRUE(eventually(
        [&] {
          const auto l = channel.app().stats().links;
          return std::all_of(l.begin(), l.end(), [&](auto& r) { return r.samples_total >= periods; });
        },
        5s));
    const auto channel_stats = channel.app().stats();
    ASSERT_EQ(channel_stats.links.size(), 2u);
    for (const auto& r : channel_stats.links) EXPECT_EQ(r.samples_total, periods) << "link " << r.sensor_id;
    EXPECT_EQ(channel_stats.unknown_sensor_samples, 0u);
  }

  // Offline: which samples the channel delivers, from identical, independently constructed links.
  nodes::ChannelLinks offline_links(sc);
  std::set<std::pair<int, std::uint64_t>> expected_delivered;
  for (std::uint64_t k = 0; k < periods; ++k) {
    for (int id : {1, 2}) {
      const auto fate = offline_links.on_sample(id, static_cast<std::int64_t>(k));
      if (fate.verdict == nodes::SampleFate::Verdict::delivered) expected_delivered.emplace(id, k);
    }
  }
  ASSERT_TRUE(seen.wait([&] { return seen.delivered.size() >= expected_delivered.size(); }, 10s))
      << "delivered " << seen.delivered.size() << " of " << expected_delivered.size();

  std::lock_guard lock(seen.m);
  EXPECT_EQ(seen.duplicates, 0u);
  std::set<std::pair<int, std::uint64_t>> got_delivered;
  for (const auto& [key, y] : seen.delivered) got_delivered.insert(key);
  EXPECT_EQ(got_delivered, expected_delivered);
  // The model did drop some of link 2 and none of link 1 (else this run checks little).
  const auto delivered_of = [&](int id) {
    return std::count_if(expected_delivered.begin(), expected_delivered.end(), [&](auto& e) { return e.first == id; });
  };
  EXPECT_EQ(delivered_of(1), static_cast<long>(periods));
  EXPECT_LT(delivered_of(2), static_cast<long>(periods));
  EXPECT_GT(delivered_of(2), 0);

  // Offline: each delivered value is what the sensor measures from that period's truth.
  ASSERT_EQ(seen.truth.size(), periods);
  for (int id : {1, 2}) {
    nodes::SensorSimulator offline_sensor(sc, id);
    for (std::uint64_t k = 0; k < periods; ++k) {
      const auto y = offline_sensor.measure(k, seen.truth.at(k));
      ASSERT_TRUE(y.has_value());
      const auto it = seen.delivered.find({id, k});
      if (it == seen.delivered.end()) continue;
      ASSERT_EQ(it->second.size(), y->size());
      for (Eigen::Index i = 0; i < y->size(); ++i)
        EXPECT_NEAR(it->second(i), (*y)(i), 1e-12 * (1 + std::abs((*y)(i)))) << "sensor " << id << " period " << k;
    }
  }

  // Offline: the same recursion with exactly the samples each estimate says it fused.
  netkf::FilterModel model;
  model.A = sc.plant.A;
  model.Q = sc.plant.Q;
  for (const auto& s : sc.sensors) model.sensors.push_back({s.id, s.C, s.R});
  netkf::IntermittentKalmanFilter offline(model, sc.plant.x0, sc.plant.P0);
  std::uint64_t fused_total = 0;
  for (std::uint64_t k = 0; k < periods; ++k) {
    ASSERT_TRUE(seen.estimates.contains(k)) << "no estimate for period " << k;
    const auto& live = seen.estimates.at(k);
    if (k > 0) offline.predict();
    std::vector<netkf::SensorSample> fused;
    for (int id : live.fused) {
      const auto it = seen.delivered.find({id, k});
      ASSERT_NE(it, seen.delivered.end()) << "period " << k << " fused sensor " << id << ", never delivered";
      fused.push_back({id, it->second});
    }
    fused_total += fused.size();
    offline.update(fused);
    for (int i = 0; i < n; ++i) {
      EXPECT_NEAR(live.x_hat(i), offline.x()(i), 1e-12 * (1 + std::abs(offline.x()(i)))) << "x̂ at " << k;
      for (int j = 0; j < n; ++j)
        EXPECT_NEAR(live.P(i, j), offline.P()(i, j), 1e-12 * (1 + std::abs(offline.P()(i, j)))) << "P at " << k;
    }
  }
  EXPECT_GT(fused_total, 0u);
}

TEST(NodeApps, ChannelAppDecidesEachSampleOfABatchOnItsOwnLink) {
  const auto sc = scenario();
  Running<nodes::ChannelApp> channel("it-channel-batch", sc, nodes::ChannelAppOptions{});

  dds::Participant ends(options("it-batch-ends"));
  std::mutex m;
  std::condition_variable cv;
  std::set<std::pair<int, std::uint64_t>> delivered;
  std::uint64_t batches_out = 0, singles_out = 0;
  dds::Reader<wire::MeasurementBatch> sink(ends, dds::topics::delivered_measurement_batch,
                                           [&](wire::MeasurementBatch&& b) {
                                             std::lock_guard lock(m);
                                             ++batches_out;
                                             for (const auto& s : b.samples()) delivered.emplace(s.sensor_id(), s.k());
                                             cv.notify_all();
                                           });
  dds::Reader<wire::Measurement> single_sink(ends, dds::topics::delivered_measurement, [&](wire::Measurement&&) {
    std::lock_guard lock(m);
    ++singles_out;
  });
  dds::Writer<wire::MeasurementBatch> raw(ends, dds::topics::raw_measurement_batch);
  ASSERT_TRUE(raw.wait_for_matched(1, 10s));
  ASSERT_TRUE(sink.wait_for_matched(1, 10s));
  ASSERT_TRUE(eventually([&] { return channel.app().stats().delivered_readers >= 1; }, 10s));

  // Each batch: sensors 2, 1 and an unknown id 9, in that order. Offline links see the same
  // sequence one sample at a time, as from processes of their own.
  nodes::ChannelLinks offline(sc);
  std::set<std::pair<int, std::uint64_t>> expected;
  const std::uint64_t periods = 150;
  for (std::uint64_t k = 0; k < periods; ++k) {
    std::vector<wire::Measurement> samples;
    for (int id : {2, 1, 9}) {
      if (offline.on_sample(id, static_cast<std::int64_t>(k)).verdict == nodes::SampleFate::Verdict::delivered)
        expected.emplace(id, k);
      samples.push_back(dds::make_measurement(id, k, dds::steady_now_ns(), netkf::Vector{{0.5}}));
    }
    auto batches = dds::make_measurement_batches(std::move(samples));
    ASSERT_EQ(batches.size(), 1u);
    ASSERT_TRUE(raw.write(std::move(batches.front())));
    std::this_thread::sleep_for(1ms);  // pacing only (a keep-last writer must not outrun the relay)
  }
  std::unique_lock lock(m);
  ASSERT_TRUE(cv.wait_for(lock, 10s, [&] { return delivered.size() >= expected.size(); }));
  EXPECT_EQ(delivered, expected);
  EXPECT_EQ(singles_out, 0u) << "no delay: what a batch brought leaves in batches";
  EXPECT_LE(batches_out, periods);
  const auto stats = channel.app().stats();
  EXPECT_EQ(stats.raw_batches, periods);
  EXPECT_EQ(stats.unknown_sensor_samples, periods) << "id 9 is no sensor of the scenario: counted, never relayed";
  EXPECT_GT(std::count_if(expected.begin(), expected.end(), [](auto& e) { return e.first == 1; }),
            std::count_if(expected.begin(), expected.end(), [](auto& e) { return e.first == 2; }))
      << "the lossless link 1 delivers more than link 2 (loss 0.4)";
}

TEST(NodeApps, ChannelAppAppliesALinkControlRequest) {
  const auto sc = scenario();
  Running<nodes::ChannelApp> channel("it-channel-ctl", sc, nodes::ChannelAppOptions{});

  dds::Participant ctl(options("it-ctl"));
  std::mutex m;
  std::condition_variable cv;
  std::map<std::uint64_t, wire::LinkControlReply> replies;
  std::map<int, wire::LinkStatus> last_status;
  std::set<std::uint64_t> delivered;  // periods of sensor 2
  dds::Reader<wire::LinkControlReply> reply_reader(ctl, dds::topics::link_control_reply, [&](wire::LinkControlReply&& r) {
    std::lock_guard lock(m);
    replies[r.request_id()] = r;
    cv.notify_all();
  });
  dds::Reader<wire::LinkStatus> status_reader(ctl, dds::topics::link_status, [&](wire::LinkStatus&& s) {
    std::lock_guard lock(m);
    last_status[s.sensor_id()] = s;
    cv.notify_all();
  });
  dds::Reader<wire::Measurement> sink(ctl, dds::topics::delivered_measurement, [&](wire::Measurement&& s) {
    std::lock_guard lock(m);
    if (s.sensor_id() == 2) delivered.insert(s.k());
    cv.notify_all();
  });
  dds::Writer<wire::LinkControl> control(ctl, dds::topics::link_control);
  dds::Writer<wire::Measurement> raw(ctl, dds::topics::raw_measurement);
  ASSERT_TRUE(control.wait_for_matched(1, 10s));
  ASSERT_TRUE(raw.wait_for_matched(1, 10s));
  ASSERT_TRUE(reply_reader.wait_for_matched(1, 10s));
  ASSERT_TRUE(status_reader.wait_for_matched(1, 10s));
  ASSERT_TRUE(sink.wait_for_matched(1, 10s));  // only the single topic: the samples below come alone

  const netkf::LinkKeys lossier{{"model", std::string("bernoulli")}, {"loss", 0.9}};
  ASSERT_TRUE(control.write(dds::make_link_control(7, 2, lossier)));
  ASSERT_TRUE(control.write(dds::make_link_control(8, 2, {{"model", std::string("bernoulli")}, {"loss", 1.5}})));
  {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, 10s, [&] {
      const auto s = last_status.find(2);
      return replies.contains(7) && replies.contains(8) && s != last_status.end() && s->second.last_request_id() == 8;
    }));
    EXPECT_TRUE(replies.at(7).applied()) << replies.at(7).reason();
    EXPECT_EQ(replies.at(7).sensor_id(), 2);
    EXPECT_FALSE(replies.at(8).applied());
    EXPECT_NE(replies.at(8).reason().find("loss"), std::string::npos) << replies.at(8).reason();
    // The status shows the applied change and the rejected request, which changed nothing.
    const auto& status = last_status.at(2);
    EXPECT_TRUE(status.last_request_rejected());
    EXPECT_EQ(dds::link_of(status), netkf::LinkSpec(netkf::BernoulliLink{0.9}));
    EXPECT_DOUBLE_EQ(status.stationary_loss(), 0.9);
    EXPECT_EQ(dds::link_of(last_status.at(1)), netkf::LinkSpec(netkf::BernoulliLink{0.0}));
  }
  const auto reports = channel.app().stats().links;
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[1].sensor_id, 2);
  EXPECT_EQ(reports[1].link, netkf::LinkSpec(netkf::BernoulliLink{0.9}));

  // From its next sample, link 2 drops as offline links given the same request decide.
  nodes::ChannelLinks offline(sc);
  ASSERT_TRUE(offline.request(7, 2, lossier).applied);
  std::set<std::uint64_t> expected;
  const std::uint64_t samples = 200;
  for (std::uint64_t k = 0; k < samples; ++k) {
    if (offline.on_sample(2, static_cast<std::int64_t>(k)).verdict == nodes::SampleFate::Verdict::delivered)
      expected.insert(k);
    ASSERT_TRUE(raw.write(dds::make_measurement(2, k, dds::steady_now_ns(), netkf::Vector{{0.0}})));
    std::this_thread::sleep_for(1ms);  // pacing only (a keep-last writer must not outrun the relay)
  }
  std::unique_lock lock(m);
  ASSERT_TRUE(cv.wait_for(lock, 10s, [&] { return delivered.size() >= expected.size(); }));
  EXPECT_EQ(delivered, expected);
  EXPECT_LT(expected.size(), samples / 2) << "a 90 % loss link delivers far fewer than half";
}

}  // namespace

TEST(NodeApps, SensorIdsAreShownAsRunsOfConsecutiveIds) {
  using netkf::nodes::describe_sensor_ids;
  EXPECT_EQ(describe_sensor_ids({3}), "3");
  EXPECT_EQ(describe_sensor_ids({1, 2}), "1,2");
  EXPECT_EQ(describe_sensor_ids({1, 3, 5, 6, 7}), "1,3,5-7");
  EXPECT_EQ(describe_sensor_ids({3, 3}), "3,3");  // a repeated id stays visible (the error names it)
  EXPECT_EQ(describe_sensor_ids({7, 6, 5}), "7,6,5");
  std::vector<int> group;
  for (int id = 129; id <= 192; ++id) group.push_back(id);
  EXPECT_EQ(describe_sensor_ids(group), "129-192");
}
