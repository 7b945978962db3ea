// ChannelLinks: per-link seeded loss, runtime changes with validation, statistics.
// Expectations: binomial tolerance around the configured loss, and the Gilbert-Elliott
// closed forms (stationary loss p/(p+r) and mean burst 1/r for loss_good=0, loss_bad=1).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "netkf/fit/loss_fit.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/nodes/channel_links.hpp"
#include "netkf/support/random.hpp"
#include "netkf/support/release_queue.hpp"

namespace {

using netkf::nodes::ChannelLinks;
using netkf::nodes::SampleFate;

netkf::LinkKeys loss_keys(double loss) { return {{"model", std::string("bernoulli")}, {"loss", loss}}; }

netkf::Scenario links_scenario() {
  netkf::Scenario s;
  s.name = "unit-links";
  s.seed = 1234;
  s.plant.A = netkf::Matrix::Identity(1, 1);
  s.plant.Q = netkf::Matrix::Identity(1, 1);
  s.plant.x0 = netkf::Vector::Zero(1);
  s.plant.P0 = netkf::Matrix::Identity(1, 1);
  for (int id : {1, 2, 3}) {
    netkf::SensorSpec sp;
    sp.id = id;
    sp.C = netkf::Matrix::Identity(1, 1);
    sp.R = netkf::Matrix::Identity(1, 1);
    sp.link = netkf::BernoulliLink{0.3};
    s.sensors.push_back(sp);
  }
  s.sensors[2].link = netkf::GilbertElliottLink{0.05, 0.5, 0.0, 1.0};
  return s;
}

TEST(ChannelLogic, BernoulliLossWithinBinomialTolerance) {
  ChannelLinks links(links_scenario());
  const int n = 20000;
  int dropped = 0;
  for (int i = 0; i < n; ++i) dropped += links.on_sample(1) == ChannelLinks::Verdict::dropped;
  const double sigma = std::sqrt(0.3 * 0.7 / n);
  EXPECT_NEAR(dropped / double(n), 0.3, 4 * sigma);
  const auto r = links.status(1);
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->samples_in, static_cast<std::uint64_t>(n));
  EXPECT_EQ(r->dropped, static_cast<std::uint64_t>(dropped));
}

TEST(ChannelLogic, GilbertElliottMatchesTheory) {
  ChannelLinks links(links_scenario());
  const int n = 100000;
  for (int i = 0; i < n; ++i) links.on_sample(3);
  const auto r = links.status(3);
  const double p = 0.05, rr = 0.5;
  EXPECT_NEAR(r->observed_loss, p / (p + rr), 0.01);
  EXPECT_NEAR(r->mean_burst_length, 1.0 / rr, 0.1);
}

// Every report carries the model the link's last 5000 samples since its model was set show:
// the batch fitter (loss_fit.hpp) over the decisions seen here gives the same; a change
// empties the window.
TEST(ChannelLogic, ReportsFitTheLinksRecentSamples) {
  ChannelLinks links(links_scenario());
  std::vector<std::uint8_t> delivered;
  for (int i = 0; i < 12000; ++i) delivered.push_back(links.on_sample(3) == ChannelLinks::Verdict::delivered);
  const auto fit_of = [&](int id) {
    for (const auto& r : links.statuses())
      if (r.sensor_id == id) return r.recent_fit;
    return std::optional<netkf::fit::RecentLossFit>{};
  };
  const auto f = fit_of(3);
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->samples, 5000u);
  const std::vector<std::uint8_t> last(delivered.end() - 5000, delivered.end());
  netkf::fit::LossFitOptions o;
  o.family = netkf::fit::LossFamily::simple_gilbert;
  const auto batch = netkf::fit::fit_loss_model(last, o).fit();
  ASSERT_EQ(f->family, netkf::fit::LossFamily::simple_gilbert);  // p 0.05, r 0.5: bursty
  const auto& chain = std::get<netkf::GilbertElliottLink>(f->link);
  EXPECT_DOUBLE_EQ(chain.p, std::get<netkf::GilbertElliottLink>(batch.link).p);
  EXPECT_DOUBLE_EQ(chain.r, std::get<netkf::GilbertElliottLink>(batch.link).r);
  EXPECT_FALSE(fit_of(1).has_value());  // no sample yet
  ASSERT_TRUE(links.request(1, 3, loss_keys(0.5)).applied);
  EXPECT_FALSE(fit_of(3).has_value());
  links.on_sample(3);
  EXPECT_EQ(fit_of(3)->samples, 1u);
}

TEST(ChannelLogic, SeededPerLinkAndReproducible) {
  ChannelLinks a(links_scenario()), b(links_scenario());
  int same_link_differs = 0, other_link_differs = 0;
  for (int i = 0; i < 1000; ++i) {
    const auto va = a.on_sample(1);
    same_link_differs += va != b.on_sample(1);
    other_link_differs += va != a.on_sample(2);
  }
  EXPECT_EQ(same_link_differs, 0);
  EXPECT_GT(other_link_differs, 100);  // links 1 and 2 draw from different streams
}

TEST(ChannelLogic, TheActuationLinkHasStreamsOfItsOwn) {
  // Adding plant.control.link changes no sensor's decisions; the control link draws from
  // derive_seed(seed, "actuation-link", 0) (a loss process built here from that seed decides
  // the same), and its deadline is the time to the plant's next tick.
  netkf::Scenario with_control = links_scenario();
  with_control.period_ms = 20;
  with_control.estimator.deadline_ms = 15;
  with_control.plant.B = netkf::Matrix::Identity(1, 1);
  netkf::ControlSpec control;
  control.gain = netkf::Matrix::Constant(1, 1, 0.5);
  control.link = netkf::LinkSpec(netkf::BernoulliLink{0.4});
  with_control.plant.control = control;
  netkf::Scenario without = links_scenario();
  without.period_ms = 20;
  without.estimator.deadline_ms = 15;
  ChannelLinks a(with_control), b(without);
  netkf::LinkLossProcess reference(netkf::BernoulliLink{0.4},
                                   netkf::derive_seed(with_control.seed, netkf::kActuationLinkStream, 0));
  int sensor_differs = 0, control_differs = 0, delivered = 0;
  for (std::int64_t k = 0; k < 2000; ++k) {
    const auto fate = a.on_sample(netkf::kControlLinkId, k);
    control_differs += (fate.verdict == SampleFate::Verdict::dropped) != reference.next_dropped();
    delivered += fate.verdict == SampleFate::Verdict::delivered;
    for (int id : {1, 2, 3}) sensor_differs += a.on_sample(id, k).verdict != b.on_sample(id, k).verdict;
  }
  EXPECT_EQ(sensor_differs, 0);
  EXPECT_EQ(control_differs, 0);
  EXPECT_NEAR(delivered / 2000.0, 0.6, 4.0 * std::sqrt(0.24 / 2000));
  ASSERT_TRUE(a.status(netkf::kControlLinkId).has_value());
  EXPECT_EQ(a.deadline_ms(netkf::kControlLinkId), 5.0);
  EXPECT_FALSE(b.status(netkf::kControlLinkId).has_value());
  // A live change reaches it by its id, as any link's.
  EXPECT_TRUE(a.request(7, netkf::kControlLinkId, loss_keys(0.9)).applied);
  EXPECT_EQ(a.status(netkf::kControlLinkId)->link.loss, netkf::LinkModel(netkf::BernoulliLink{0.9}));
}

TEST(ChannelLogic, ChangeAppliesFromTheNextSampleAndResetsStatistics) {
  ChannelLinks links(links_scenario());
  for (int i = 0; i < 50; ++i) links.on_sample(2);
  auto res = links.request(7, 2, loss_keys(1.0));
  EXPECT_TRUE(res.applied);
  EXPECT_TRUE(res.reason.empty());
  for (int i = 0; i < 100; ++i) EXPECT_EQ(links.on_sample(2), ChannelLinks::Verdict::dropped);
  const auto r = links.status(2);
  EXPECT_EQ(r->samples_in, 100u);
  EXPECT_EQ(r->last_request_id, 7u);
  EXPECT_TRUE(r->rejection_reason.empty());
  EXPECT_EQ(std::get<netkf::BernoulliLink>(r->link.loss).loss, 1.0);
  links.request(8, 2, loss_keys(0.0));
  for (int i = 0; i < 100; ++i) EXPECT_EQ(links.on_sample(2), ChannelLinks::Verdict::delivered);
}

TEST(ChannelLogic, BadRequestsChangeNothing) {
  ChannelLinks links(links_scenario());
  auto res = links.request(3, 1, loss_keys(1.5));
  EXPECT_FALSE(res.applied);
  EXPECT_NE(res.reason.find("loss"), std::string::npos) << res.reason;
  const auto r = links.status(1);
  EXPECT_EQ(std::get<netkf::BernoulliLink>(r->link.loss).loss, 0.3);
  EXPECT_FALSE(r->rejection_reason.empty());
  EXPECT_EQ(r->last_request_id, 3u);

  auto unknown = links.request(4, 42, loss_keys(0.1));
  EXPECT_FALSE(unknown.applied);
  EXPECT_NE(unknown.reason.find("unknown sensor"), std::string::npos);

  EXPECT_EQ(links.on_sample(42), ChannelLinks::Verdict::unknown_sensor);
  EXPECT_EQ(links.unknown_sensor_samples(), 1u);
  EXPECT_EQ(links.statuses().size(), 3u);
}

TEST(ChannelLogic, ADelayChangeKeepsTheLossModelAndItsChainState) {
  // Two identical channels; one also gets a delay on link 3 (Gilbert-Elliott) at sample 500.
  // The loss decisions must stay identical (a delay never touches the loss stream or chain).
  ChannelLinks plain(links_scenario()), delayed(links_scenario());
  for (std::int64_t k = 0; k < 2000; ++k) {
    if (k == 500) {
      const auto res = delayed.request(1, 3, {{"delay_ms", 6.0}, {"jitter_ms", 4.0}});
      ASSERT_TRUE(res.applied) << res.reason;
    }
    const SampleFate a = plain.on_sample(3, k);
    const SampleFate b = delayed.on_sample(3, k);
    ASSERT_EQ(a.verdict, b.verdict) << "period " << k;
    if (b.verdict == SampleFate::Verdict::delivered && k >= 500) {
      EXPECT_GE(b.delay_ms, 2.0);
      EXPECT_LE(b.delay_ms, 10.0);
    }
  }
  const auto r = delayed.status(3);
  EXPECT_TRUE(std::holds_alternative<netkf::GilbertElliottLink>(r->link.loss));
  EXPECT_EQ(r->link.delay.delay_ms, 6.0);
}

TEST(ChannelLogic, ALiveChangeIsJournaledAtThePeriodOfTheLinksNextSample) {
  ChannelLinks links(links_scenario());
  for (std::int64_t k = 0; k < 10; ++k) links.on_sample(1, k);
  ASSERT_TRUE(links.request(5, 1, loss_keys(0.9)).applied);
  EXPECT_TRUE(links.take_changes().empty());  // the period is not known yet
  links.on_sample(2, 10);                     // another link's sample says nothing about link 1
  EXPECT_TRUE(links.take_changes().empty());
  links.on_sample(1, 10);
  const auto changes = links.take_changes();
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].sensor_id, 1);
  EXPECT_EQ(changes[0].at_period, 10);
  EXPECT_EQ(changes[0].request_id, 5u);
  EXPECT_EQ(changes[0].origin, netkf::LinkChange::Origin::request);
  EXPECT_EQ(std::get<netkf::BernoulliLink>(changes[0].link.loss).loss, 0.9);
}

TEST(ChannelLogic, AReplayedJournalMakesTheSameDecisionsAsTheLiveSession) {
  // Live: requests at arbitrary moments between samples. Replay: the journal as events.
  auto scenario = links_scenario();
  ChannelLinks live(scenario);
  std::vector<std::pair<int, std::int64_t>> live_delivered;
  std::vector<netkf::LinkEvent> journal;
  for (std::int64_t k = 0; k < 3000; ++k) {
    if (k == 700) live.request(11, 3, {{"mean_burst", 8.0}, {"loss", 0.4}});
    if (k == 1200) live.request(12, 1, {{"delay_ms", 3.0}, {"jitter_ms", 1.0}});
    if (k == 2500) live.request(13, 2, loss_keys(0.05));
    for (int id : {1, 2, 3}) {
      if (live.on_sample(id, k).verdict == SampleFate::Verdict::delivered) live_delivered.emplace_back(id, k);
    }
    for (const auto& c : live.take_changes())
      journal.push_back({c.at_period, c.sensor_id, netkf::LinkEvent::Kind::set, netkf::link_keys(c.link.loss), 0});
  }
  ASSERT_EQ(journal.size(), 3u);
  netkf::add_replayed_events(scenario, journal);
  ChannelLinks replay(scenario);
  std::vector<std::pair<int, std::int64_t>> replay_delivered;
  for (std::int64_t k = 0; k < 3000; ++k)
    for (int id : {1, 2, 3})
      if (replay.on_sample(id, k).verdict == SampleFate::Verdict::delivered) replay_delivered.emplace_back(id, k);
  EXPECT_EQ(live_delivered, replay_delivered);
}

TEST(ChannelLogic, TimelineSetsAndRampsApplyFromTheFirstSampleOfTheirPeriod) {
  auto scenario = links_scenario();
  scenario.events.push_back({300, 2, netkf::LinkEvent::Kind::set, {{"loss", 1.0}}, 0});
  scenario.events.push_back({600, 2, netkf::LinkEvent::Kind::set, {{"loss", 0.0}}, 0});
  scenario.events.push_back({1000, 1, netkf::LinkEvent::Kind::ramp, {{"loss", 0.8}}, 10});
  netkf::validate_scenario(scenario);
  ChannelLinks links(scenario);
  for (std::int64_t k = 0; k < 1100; ++k) {
    const auto fate = links.on_sample(2, k);
    if (k >= 300 && k < 600) {
      EXPECT_EQ(fate.verdict, SampleFate::Verdict::dropped) << k;
    } else if (k >= 600) {
      EXPECT_EQ(fate.verdict, SampleFate::Verdict::delivered) << k;
    }
    links.on_sample(1, k);
    // The ramp: loss 0.3 at period 1000, then linearly to 0.8 at period 1010.
    const double loss = std::get<netkf::BernoulliLink>(links.status(1)->link.loss).loss;
    if (k < 1000) {
      EXPECT_EQ(loss, 0.3);
    } else if (k <= 1010) {
      EXPECT_NEAR(loss, 0.3 + 0.5 * static_cast<double>(k - 1000) / 10.0, 1e-12) << k;
    } else {
      EXPECT_EQ(loss, 0.8);
    }
  }
}

TEST(ChannelLogic, CountsTheSamplesItDelaysBeyondTheDeadline) {
  // Deadline 8 ms (80 % of the 10 ms period); delay uniform on [4, 12] ms: P(delay > 8) = 1/2.
  ChannelLinks links(links_scenario());
  ASSERT_TRUE(links.request(1, 1, {{"delay_ms", 8.0}, {"jitter_ms", 4.0}}).applied);
  std::uint64_t beyond = 0;
  for (std::int64_t k = 0; k < 20000; ++k) {
    const auto fate = links.on_sample(1, k);
    beyond += fate.verdict == SampleFate::Verdict::delivered && fate.delay_ms > 8.0;
  }
  const auto r = links.status(1);
  EXPECT_EQ(r->past_deadline, beyond);  // the report counts exactly the draws above the deadline
  const double n = static_cast<double>(r->delivered);
  EXPECT_NEAR(static_cast<double>(r->past_deadline) / n, 0.5, 4.0 * std::sqrt(0.25 / n));
  ASSERT_TRUE(links.request(2, 1, {{"delay_ms", 0.0}, {"jitter_ms", 0.0}}).applied);
  EXPECT_EQ(links.status(1)->past_deadline, 0u);  // since the current link was set, as the other counts
}

TEST(ReleaseQueue, ReleasesInTimeOrderTiesFirstInFirstOut) {
  netkf::ReleaseQueue<int> q;
  const auto t0 = netkf::ReleaseQueue<int>::Clock::time_point{} + std::chrono::seconds(100);
  using std::chrono::milliseconds;
  EXPECT_TRUE(q.hold(t0 + milliseconds(12), 1, 1));   // first: earliest
  EXPECT_TRUE(q.hold(t0 + milliseconds(4), 2, 2));    // earlier: the timer must move
  EXPECT_FALSE(q.hold(t0 + milliseconds(8), 1, 3));
  EXPECT_FALSE(q.hold(t0 + milliseconds(8), 1, 4));   // same time as 3: after it
  EXPECT_EQ(q.held(1), 3u);
  EXPECT_EQ(q.held(2), 1u);
  EXPECT_TRUE(q.take_due(t0 + milliseconds(3)).empty());
  EXPECT_EQ(q.take_due(t0 + milliseconds(8)), (std::vector<int>{2, 3, 4}));
  EXPECT_EQ(*q.next_release(), t0 + milliseconds(12));
  EXPECT_EQ(q.take_due(t0 + milliseconds(20)), (std::vector<int>{1}));
  EXPECT_EQ(q.size(), 0u);
  EXPECT_EQ(q.held(1), 0u);
  EXPECT_FALSE(q.next_release());
}

}  // namespace
