// The estimator's real wiring (EstimatorApp) in process, driven by a test plant and channel:
// its estimates equal an offline run of the filter over the same samples and inputs, and an
// estimator stopped and restarted from its last estimate (the checkpoint `netkf launch`
// writes) continues exactly: the periods it missed are predicted with the inputs the plant
// acknowledged in its (transient-local) ticks and fused with nothing.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>
#include <thread>

#include "netkf/dds/dds.hpp"
#include "netkf/filter/kalman_filter.hpp"
#include "netkf/nodes/estimator_app.hpp"

namespace {

using namespace std::chrono_literals;
namespace wire = netkf::wire;
namespace dds = netkf::dds;

int test_domain() { return 1 + static_cast<int>((::getpid() + 150) % 200); }

dds::ParticipantOptions options(const std::string& name) {
  dds::ParticipantOptions o;
  o.domain = test_domain();
  o.name = name;
  return o;
}

// Two states, one input (acknowledged in the ticks, no controller), two sensors.
netkf::Scenario scenario() {
  netkf::Scenario s;
  s.name = "it-estimator";
  s.seed = 7;
  s.period_ms = 100;
  s.plant.A = netkf::Matrix{{1.02, 0.1}, {0.0, 0.97}};
  s.plant.Q = netkf::Matrix{{0.3, 0.05}, {0.05, 0.2}};
  s.plant.B = netkf::Matrix{{0.0}, {1.0}};
  s.plant.x0 = netkf::Vector{{1.0, -1.0}};
  s.plant.P0 = netkf::Matrix{{2.0, 0.0}, {0.0, 2.0}};
  for (int id : {1, 2}) {
    netkf::SensorSpec sp;
    sp.id = id;
    sp.C = id == 1 ? netkf::Matrix{{1.0, 0.0}} : netkf::Matrix{{0.5, 1.0}};
    sp.R = netkf::Matrix{{0.4 * id}};
    s.sensors.push_back(sp);
  }
  return s;
}

netkf::Vector input_of(std::uint64_t k) { return netkf::Vector{{0.1 * static_cast<double>(k % 7) - 0.3}}; }
netkf::Vector sample_of(int id, std::uint64_t k) { return netkf::Vector{{static_cast<double>(id) + 0.01 * k}}; }

/// An EstimatorApp on its own participant and thread.
class RunningEstimator {
 public:
  RunningEstimator(const netkf::Scenario& sc, netkf::nodes::EstimatorAppOptions o)
      : participant_(options("it-estimator")), app_(sc, participant_, std::move(o)), thread_([this] { app_.run(); }) {}
  ~RunningEstimator() {
    app_.stop();
    thread_.join();
  }
  netkf::nodes::EstimatorAppStats stats() const { return app_.stats(); }
  bool wait_for_estimate_readers(int n, std::chrono::milliseconds timeout) const {
    return app_.wait_for_estimate_readers(n, timeout);
  }

 private:
  dds::Participant participant_;
  netkf::nodes::EstimatorApp app_;
  std::thread thread_;
};

struct Estimates {
  std::mutex m;
  std::condition_variable cv;
  std::map<std::uint64_t, netkf::Estimate> by_k;
  std::uint64_t duplicates = 0;
  bool wait_for(std::uint64_t k, std::chrono::milliseconds timeout) {
    std::unique_lock lock(m);
    return cv.wait_for(lock, timeout, [&] { return by_k.contains(k); });
  }
};

TEST(EstimatorApp, ResumesExactlyFromItsLastEstimate) {
  const auto sc = scenario();
  dds::Participant harness(options("it-harness"));
  dds::Writer<wire::Tick> ticks(harness, dds::topics::tick);
  dds::Writer<wire::Measurement> delivered(harness, dds::topics::delivered_measurement);
  Estimates got;
  dds::Reader<wire::Estimate> estimates(harness, dds::topics::estimate, [&](wire::Estimate&& w) {
    const auto e = dds::from_wire(w, 2);
    std::lock_guard lock(got.m);
    if (!got.by_k.emplace(e.k, e).second) ++got.duplicates;
    got.cv.notify_all();
  });

  // Which samples reach the estimator: period k, sensor id (a fixed irregular pattern).
  auto arrives = [](int id, std::uint64_t k) { return (k * 3 + static_cast<std::uint64_t>(id)) % 4 != 0; };
  auto run_period = [&](std::uint64_t k) {
    ASSERT_TRUE(ticks.write(dds::make_tick(k, 0.1 * static_cast<double>(k), k ? input_of(k - 1) : netkf::Vector(), false)));
    for (int id : {1, 2}) {
      if (!arrives(id, k)) continue;
      ASSERT_TRUE(delivered.write(dds::make_measurement(id, k, dds::steady_now_ns(), sample_of(id, k))));
    }
    // Periods whose samples do not all arrive end at the deadline (100 ms) or the next tick.
    ASSERT_TRUE(got.wait_for(k, 5s) || !(arrives(1, k) && arrives(2, k))) << "period " << k;
  };

  const std::uint64_t first_life = 10, gap = 6, second_life = 8;
  {
    RunningEstimator estimator(sc, {});
    ASSERT_TRUE(ticks.wait_for_matched(1, 10s));
    ASSERT_TRUE(delivered.wait_for_matched(1, 10s));
    ASSERT_TRUE(estimates.wait_for_matched(1, 10s));
    ASSERT_TRUE(estimator.wait_for_estimate_readers(1, 10s));  // both sides: period 0's estimate is not lost
    for (std::uint64_t k = 0; k < first_life; ++k) run_period(k);
    ASSERT_TRUE(got.wait_for(first_life - 1, 5s));
    EXPECT_EQ(estimator.stats().restarts, 0u);
  }
  // The estimator is gone: the plant goes on (ticks kept in its transient-local history), and
  // the samples of these periods are lost (the delivered topic keeps nothing for late joiners).
  for (std::uint64_t k = first_life; k < first_life + gap; ++k) {
    ASSERT_TRUE(ticks.write(dds::make_tick(k, 0.1 * static_cast<double>(k), input_of(k - 1), false)));
    for (int id : {1, 2}) delivered.write(dds::make_measurement(id, k, dds::steady_now_ns(), sample_of(id, k)));
  }
  netkf::Estimate checkpoint;  // the last estimate the first life published
  {
    std::lock_guard lock(got.m);
    checkpoint = got.by_k.at(first_life - 1);
  }
  {
    netkf::nodes::EstimatorAppOptions o;
    o.resume = checkpoint;
    RunningEstimator estimator(sc, o);
    ASSERT_TRUE(delivered.wait_for_matched(1, 10s));
    // The missed periods come from the tick history: all but the last are closed by a later tick.
    ASSERT_TRUE(got.wait_for(first_life + gap - 2, 10s));
    for (std::uint64_t k = first_life + gap; k < first_life + gap + second_life; ++k) run_period(k);
    ASSERT_TRUE(got.wait_for(first_life + gap + second_life - 1, 5s));
    EXPECT_EQ(estimator.stats().restarts, 1u);
  }

  // Offline: the same recursion with exactly the samples each estimate says it fused.
  netkf::FilterModel model;
  model.A = sc.plant.A;
  model.Q = sc.plant.Q;
  model.B = sc.plant.B;
  for (const auto& s : sc.sensors) model.sensors.push_back({s.id, s.C, s.R});
  netkf::IntermittentKalmanFilter offline(model, sc.plant.x0, sc.plant.P0);
  std::lock_guard lock(got.m);
  EXPECT_EQ(got.duplicates, 0u);
  const std::uint64_t periods = first_life + gap + second_life;
  for (std::uint64_t k = 0; k < periods; ++k) {
    ASSERT_TRUE(got.by_k.contains(k)) << "no estimate for period " << k;
    const auto& live = got.by_k.at(k);
    if (k > 0) {
      const netkf::Vector u = input_of(k - 1);
      offline.predict(&u);
    }
    std::vector<netkf::SensorSample> fused;
    for (int id : live.fused) fused.push_back({id, sample_of(id, k)});
    offline.update(fused);
    const bool missed = k >= first_life && k < first_life + gap;
    if (missed) {
      EXPECT_TRUE(live.fused.empty()) << "period " << k << " was missed: nothing to fuse";
    } else if (k + 1 < periods) {
      EXPECT_FALSE(live.fused.empty()) << "period " << k;
    }
    EXPECT_EQ(live.restarts, k < first_life ? 0u : 1u) << "period " << k;
    for (int i = 0; i < 2; ++i) {
      EXPECT_NEAR(live.x_hat(i), offline.x()(i), 1e-12 * (1 + std::abs(offline.x()(i)))) << "x̂ at " << k;
      for (int j = 0; j < 2; ++j) EXPECT_NEAR(live.P(i, j), offline.P()(i, j), 1e-12 * (1 + offline.P()(i, j))) << "P at " << k;
    }
  }
}

// A standby takes over when the primary's writers lose their liveliness (dds::kOwnershipLease,
// 50 ms). At a period of 100 ms and while the plant is silent, nothing is written for longer
// than that: the estimator must assert its writers' liveliness on its own, or every reader would
// hand the topic to a standby between two periods. The reader's own liveliness tracking (Fast
// DDS's, MANUAL_BY_TOPIC) is the judge.
TEST(EstimatorApp, KeepsItsWritersAliveBetweenSlowPeriodsAndWhileThePlantIsSilent) {
  const auto sc = scenario();  // 100 ms periods: twice the lease
  dds::Participant harness(options("it-alive-harness"));
  dds::Writer<wire::Tick> ticks(harness, dds::topics::tick);
  Estimates got;
  dds::Reader<wire::Estimate> estimates(harness, dds::topics::estimate, [&](wire::Estimate&& w) {
    std::lock_guard lock(got.m);
    got.by_k.emplace(w.k(), dds::from_wire(w, 2));
    got.cv.notify_all();
  });
  // Polled every 5 ms: a writer that lost its liveliness stays lost until its next write (tens
  // of ms here), so no loss goes unseen.
  int least_alive = 1, most_not_alive = 0;
  auto watch = [&](std::chrono::milliseconds how_long) {
    const auto until = std::chrono::steady_clock::now() + how_long;
    while (std::chrono::steady_clock::now() < until) {
      eprosima::fastdds::dds::LivelinessChangedStatus st;
      estimates.get()->get_liveliness_changed_status(st);
      least_alive = std::min(least_alive, st.alive_count);
      most_not_alive = std::max(most_not_alive, st.not_alive_count);
      std::this_thread::sleep_for(5ms);
    }
  };
  RunningEstimator estimator(sc, {});
  ASSERT_TRUE(ticks.wait_for_matched(1, 10s));
  ASSERT_TRUE(estimator.wait_for_estimate_readers(1, 10s));
  ASSERT_TRUE(ticks.write(dds::make_tick(0, 0.0, input_of(0), false)));
  ASSERT_TRUE(got.wait_for(0, 5s));  // the writer is alive for this reader from its first write on
  // Periods without samples (each ends at its deadline), then 0.8 s without a tick, then more.
  for (std::uint64_t k = 1; k < 5; ++k) {
    watch(100ms);
    ASSERT_TRUE(ticks.write(dds::make_tick(k, 0.1 * static_cast<double>(k), input_of(k), false)));
  }
  watch(800ms);
  for (std::uint64_t k = 5; k < 8; ++k) {
    ASSERT_TRUE(ticks.write(dds::make_tick(k, 0.1 * static_cast<double>(k), input_of(k), false)));
    watch(100ms);
  }
  ASSERT_TRUE(got.wait_for(7, 5s));
  EXPECT_EQ(least_alive, 1) << "the estimate writer was not alive for this reader at some moment";
  EXPECT_EQ(most_not_alive, 0) << "the estimate writer lost its liveliness between periods or while the plant "
                                  "was silent";
}

TEST(EstimatorApp, RefusesACheckpointOfAnotherShape) {
  const auto sc = scenario();
  dds::Participant p(options("it-refuse"));
  netkf::nodes::EstimatorAppOptions o;
  netkf::Estimate wrong_size;  // of another scenario: three states
  wrong_size.k = 3;
  wrong_size.x_hat = netkf::Vector::Zero(3);
  wrong_size.P = netkf::Matrix::Identity(3, 3);
  o.resume = wrong_size;
  EXPECT_THROW(netkf::nodes::EstimatorApp(sc, p, o), std::invalid_argument);
}

}  // namespace
