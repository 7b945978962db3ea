// The live snapshot (LiveModel) and its terminal views, the theory worker, and the metrics.
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "netkf/cli/live/live_metrics.hpp"
#include "netkf/cli/live/live_model.hpp"
#include "netkf/cli/live/live_status.hpp"
#include "netkf/relay/relay_links.hpp"
#include "netkf/theory/operating_point.hpp"
#include "test_paths.hpp"
#include "netkf/cli/live/theory_worker.hpp"

namespace netkf::cli {
namespace {

LinkStatus link_status(int id, LinkModel model, std::uint64_t samples, std::uint64_t delivered,
                             std::uint64_t request = 0) {
  LinkStatus l;
  l.sensor_id = id;
  l.link = model;
  l.samples_in = samples;
  l.delivered = delivered;
  l.dropped = samples - delivered;
  l.observed_loss = samples ? static_cast<double>(samples - delivered) / static_cast<double>(samples) : 0.0;
  l.samples_total = samples;
  l.delivered_total = delivered;
  l.dropped_total = samples - delivered;
  l.last_request_id = request;
  return l;
}

Estimate estimate(std::uint64_t k, const std::vector<double>& x_hat, double trace, double trace_pred) {
  Estimate e;
  e.k = k;
  e.t = 0.01 * static_cast<double>(k);
  e.x_hat = Eigen::Map<const Vector>(x_hat.data(), static_cast<Eigen::Index>(x_hat.size()));
  e.P = Matrix::Identity(2, 2) * (trace / 2);
  e.trace_P_pred = trace_pred;
  e.fused = {1, 2};
  return e;
}

// An estimator restarted from its checkpoint: the estimates carry the restart count; the
// model counts the restart and the periods it predicted open-loop until it fused again.
TEST(LiveModel, ShowsAnEstimatorRestartAndItsGap) {
  LiveModel model(default_scenario());
  model.add_estimate(estimate(9, {0.0, 0.0}, 1.0, 1.0));
  model.take_events();
  for (std::int64_t k = 10; k < 16; ++k) {
    auto e = estimate(k, {0.0, 0.0}, 1.0, 1.0);
    e.restarts = 1;
    if (k < 14) e.fused.clear();  // periods 10..13 missed while the estimator was down
    model.add_estimate(e);
  }
  const auto& s = model.snapshot();
  EXPECT_EQ(s.estimator_restarts, 1u);
  EXPECT_EQ(s.restart_gap_periods, 4u);
  const auto events = model.take_events();
  ASSERT_EQ(events.size(), 2u);
  EXPECT_NE(events[0].text.find("estimator restarted (restart 1): resumed from its estimate of period 9"),
            std::string::npos) << events[0].text;
  EXPECT_NE(events[1].text.find("fusing again from period 14 (4 periods"), std::string::npos) << events[1].text;
}

// A sensor the channel never heard from is an error in the event log, not a quiet "ok".
TEST(LiveModel, NamesSensorsThatNeverSentAnything) {
  const Scenario scenario = default_scenario();
  ASSERT_GE(scenario.sensors.size(), 2u);
  LiveModel model(scenario);
  const int silent_id = scenario.sensors.back().id;
  for (const auto& sensor : scenario.sensors)
    if (sensor.id != silent_id) model.add_link_status(link_status(sensor.id, sensor.link.loss, 100, 90));
  model.take_events();
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(LiveModel::kSilentSensorCheck); ++k)
    model.add_estimate(estimate(k, {0.0, 0.0}, 1.0, 1.0));
  const auto events = model.take_events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].level, LiveEvent::Level::error);
  EXPECT_EQ(events[0].text.rfind("sensors " + std::to_string(silent_id) + " have sent nothing", 0), 0u) << events[0].text;
}

// 768 sensors at 100 ms ran "ok" while most samples reached the estimator after their period
// was fused: a late share beyond what the links' delays explain is a warning, raised once per
// stretch of late windows and again only after a window back to normal.
TEST(LiveModel, WarnsWhenMoreSamplesArriveLateThanTheLinksExplain) {
  const Scenario scenario = default_scenario();  // links without delay: none explained late
  LiveModel model(scenario);
  model.take_events();
  const auto run_window = [&](std::int64_t first_k, std::uint32_t late_per_period) {
    for (std::int64_t k = first_k; k < first_k + static_cast<std::int64_t>(LiveModel::kLateWindow); ++k) {
      auto e = estimate(k, {0.0, 0.0}, 1.0, 1.0);  // 2 fused per period
      e.late = late_per_period;
      model.add_estimate(e);
    }
    std::vector<LiveEvent> late_warnings;  // (no link status is fed: the silent-sensor error is not this test's)
    for (auto& ev : model.take_events())
      if (ev.text.find("arrived after their period was fused") != std::string::npos) late_warnings.push_back(ev);
    return late_warnings;
  };
  EXPECT_TRUE(run_window(0, 0).empty());
  // 20 late of 220 per window: 9 %, below 0 % + 10 %.
  {
    LiveModel quiet(scenario);
    quiet.take_events();
    for (std::int64_t k = 0; k < 100; ++k) {
      auto e = estimate(k, {0.0, 0.0}, 1.0, 1.0);
      e.late = k % 5 == 0 ? 1 : 0;
      quiet.add_estimate(e);
    }
    EXPECT_TRUE(quiet.take_events().empty());
  }
  const auto events = run_window(100, 1);  // 100 late of 300: 33 %
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].level, LiveEvent::Level::warning);
  EXPECT_EQ(events[0].text.rfind("100 of 300 samples of the last 100 periods arrived after their period was fused (33 %", 0),
            0u)
      << events[0].text;
  EXPECT_TRUE(run_window(200, 3).empty()) << "still late: not repeated";
  EXPECT_TRUE(run_window(300, 0).empty());
  EXPECT_EQ(run_window(400, 2).size(), 1u) << "late again after a normal window: warned again";
}

TEST(LiveModel, JoinsTruthAndEstimateWhicheverComesFirst) {
  LiveModel model(default_scenario());
  model.add_truth({3, 0.03, {1.0, 2.0}, {}});
  model.add_estimate(estimate(3, {1.0, 5.0}, 0.5, 0.9));  // error 3
  model.add_estimate(estimate(4, {0.0, 0.0}, 0.7, 1.1));
  model.add_truth({4, 0.04, {3.0, 4.0}, {}});  // error 5, truth after the estimate
  const auto& s = model.snapshot();
  ASSERT_TRUE(s.period);
  EXPECT_EQ(s.period->estimate.k, 4u);
  EXPECT_EQ(s.period->truth, (std::vector<double>{3.0, 4.0}));
  EXPECT_DOUBLE_EQ(*s.error_norm, 5.0);
  EXPECT_DOUBLE_EQ(*s.rms_error, std::sqrt((9.0 + 25.0) / 2.0));
  EXPECT_EQ(s.estimates, 2u);
  EXPECT_DOUBLE_EQ(s.mean_trace_P, 0.6);
  EXPECT_DOUBLE_EQ(s.mean_trace_P_pred, 1.0);
}

TEST(LiveModel, NonFiniteEstimateIsCountedNeverShown) {
  LiveModel model(default_scenario());
  model.add_estimate(estimate(1, {0.0, std::nan("")}, 0.5, 0.9));
  EXPECT_FALSE(model.snapshot().period);
  EXPECT_EQ(model.snapshot().invalid_samples, 1u);
  EXPECT_TRUE(model.saw_non_finite());
}

TEST(LiveModel, TheTheorysObservedRatesAreTheRatesSinceChange) {
  LiveModel model(default_scenario());
  EXPECT_FALSE(model.observed_rates_since_change());
  model.add_link_status(link_status(1, BernoulliLink{0.1}, 100, 90));
  model.add_link_status(link_status(2, BernoulliLink{0.2}, 100, 80));
  EXPECT_FALSE(model.observed_rates_since_change()) << "link 3 not reported yet";
  model.add_link_status(link_status(3, GilbertElliottLink{0.05, 0.5, 0.0, 1.0}, 100, 91));
  auto rates = model.observed_rates_since_change();
  ASSERT_TRUE(rates);
  EXPECT_EQ(*rates, (std::vector<double>{0.9, 0.8, 0.91}));
  // Next report of link 2: 100 more samples, 50 more delivered: 130/200 since the change
  // (0.5 over the last 100 alone: that is no window of the views).
  model.add_link_status(link_status(2, BernoulliLink{0.2}, 200, 130));
  EXPECT_DOUBLE_EQ((*model.observed_rates_since_change())[1], 0.65);
  // The configured rate is the channel's model, not the scenario's.
  EXPECT_DOUBLE_EQ(model.snapshot().links[1].arrival_rate(), 0.8);
  EXPECT_EQ(model.configured_scenario().sensors[1].link, LinkSpec(BernoulliLink{0.2}));
}

TEST(LiveModel, ALinkChangeNamesItsSource) {
  LiveModel model(default_scenario());
  model.add_link_status(link_status(2, BernoulliLink{0.2}, 100, 80));
  model.note_own_request(77, "dashboard");
  model.add_link_status(link_status(2, BernoulliLink{0.97}, 0, 0, 77));
  model.add_link_status(link_status(2, BernoulliLink{0.5}, 0, 0, 78));
  const auto events = model.take_events();
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].text, "link 2: bernoulli loss=0.97 (from dashboard)");
  EXPECT_EQ(events[1].text, "link 2: bernoulli loss=0.5 (from netkf ctl or another client)");
  EXPECT_TRUE(model.take_events().empty());
  // The counts restarted with the change: the rate is taken afresh, not as a difference.
  model.add_link_status(link_status(2, BernoulliLink{0.5}, 10, 4, 78));
  EXPECT_DOUBLE_EQ(*model.snapshot().links[1].observed_rate_since_change, 0.4);
  EXPECT_DOUBLE_EQ(*model.snapshot().links[1].observed_rate_window, 0.4);
}

TEST(LiveModel, CrossingTheCriticalBoundaryRaisesAWarning) {
  // The scalar example of Sinopoli et al. (A = -1.25): λ_c = 0.36 with one sensor.
  Scenario s = load_scenario_file(netkf::test::source_dir() / "deploy/scenarios/sinopoli-scalar.yaml");
  LiveModel model(s);
  TheoryRequest request;
  request.configured = s;
  model.set_theory(compute_theory(request));
  EXPECT_EQ(model.snapshot().theory.configured.result.stable, theory::Verdict::yes);
  EXPECT_TRUE(model.take_events().empty());
  request.configured.sensors[0].link = BernoulliLink{0.97};  // λ = 0.03 < 0.36
  model.set_theory(compute_theory(request));
  auto events = model.take_events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].level, LiveEvent::Level::warning);
  EXPECT_NE(events[0].text.find("below the critical arrival rate"), std::string::npos);
  request.configured.sensors[0].link = BernoulliLink{0.1};
  model.set_theory(compute_theory(request));
  events = model.take_events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_NE(events[0].text.find("back above"), std::string::npos);
}

// late_policy fuse_within: the live theory adds the final estimates' verdict at the horizon
// deadline + D periods; its rates are the links' (1 - loss)·P(delay <= horizon), here
// 0.45·P(U[0, 20] <= 18) = 0.405 against 0.45·0.4 = 0.18 in time (the scenario's comment).
TEST(LiveModel, FuseWithinShowsTheFinalEstimatesVerdictBesideTheInTimeOne) {
  const auto dir = netkf::test::source_dir() / "deploy/scenarios";
  Scenario s = load_scenario_file(dir / "late-fusion-boundary.yaml");
  TheoryRequest request;
  request.configured = s;
  const TheoryView view = compute_theory(request);
  EXPECT_EQ(view.configured.result.stable, theory::Verdict::no);
  ASSERT_TRUE(view.final_estimate.has_value());
  EXPECT_EQ(view.final_estimate->result.stable, theory::Verdict::yes);
  ASSERT_EQ(view.final_estimate->arrival_rates.size(), 1u);
  EXPECT_NEAR(view.final_estimate->arrival_rates[0], 0.405, 1e-12);
  EXPECT_NEAR(view.configured.arrival_rates[0], 0.18, 1e-12);
  LiveModel model(s);
  model.set_theory(view);
  const std::string status = render_status(model.snapshot(), false);
  EXPECT_NE(status.find("theory (final estimates, late_policy fuse_within): stable=yes"), std::string::npos) << status;

  request.configured = load_scenario_file(dir / "late-fusion-boundary-drop.yaml");
  EXPECT_FALSE(compute_theory(request).final_estimate.has_value());
}

TEST(TheoryWorker, ComputesOffTheCallersThreadAndMatchesTheDirectAssessment) {
  const Scenario s = load_scenario_file(netkf::test::source_dir() / "deploy/scenarios/liu-goldsmith-diag.yaml");
  std::mutex m;
  std::condition_variable cv;
  std::optional<TheoryView> result;
  std::thread::id worker_thread;
  {
    TheoryWorker worker([&](TheoryView v) {
      const std::lock_guard lock(m);
      worker_thread = std::this_thread::get_id();
      result = std::move(v);
      cv.notify_one();
    });
    TheoryRequest r;
    r.configured = s;
    r.observed_rates = std::vector<double>{0.9, 0.8};
    r.k = 12;
    r.with_region = true;
    worker.request(r);
    std::unique_lock lock(m);
    // Generous: the sanitizer build computes the region (21 LMI bisections) many times slower.
    ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(600), [&] { return result.has_value(); }));
  }
  EXPECT_NE(worker_thread, std::this_thread::get_id());
  EXPECT_EQ(result->k, 12);
  const auto direct = theory::assess_operating_point(s, {0.9, 0.8});
  ASSERT_TRUE(result->observed);
  EXPECT_EQ(result->observed->result.stable, direct.stable);
  EXPECT_EQ(result->observed->result.upper_trace, direct.upper_trace);
  // Two sensors: the Liu-Goldsmith region comes along (21 points over λ1 in [0, 1]).
  EXPECT_EQ(result->region.size(), 21u);
}

TEST(TheoryWorker, DestructionDoesNotWaitForAComputation) {
  // A 200-state plant whose assessment takes long: destroying the worker must not wait.
  Scenario s = default_scenario();
  const int n = 200;
  s.plant.A = Matrix::Identity(n, n) * 1.01;
  s.plant.Q = Matrix::Identity(n, n);
  s.plant.B.reset();
  s.plant.control.reset();
  s.plant.x0 = Vector::Zero(n);
  s.plant.P0 = Matrix::Identity(n, n);
  for (auto& sensor : s.sensors) sensor.C = Matrix::Identity(1, n);
  const auto start = std::chrono::steady_clock::now();
  {
    TheoryWorker worker([](TheoryView) {});
    TheoryRequest r;
    r.configured = s;
    worker.request(r);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    EXPECT_TRUE(worker.busy());
  }
  // Not a timing assertion on the theory: only that the destructor returned while it ran.
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(30));
}

TEST(LiveStatusText, ShowsBothCovariancesAndTheBoundsOnThePrediction) {
  LiveModel model(default_scenario());
  model.add_truth({3, 0.03, {1.0, 2.0}, {}});
  model.add_estimate(estimate(3, {1.0, 5.0}, 0.5, 0.9));
  model.add_link_status(link_status(2, BernoulliLink{1.0}, 100, 0));
  std::string text = render_status(model.snapshot(), false);
  EXPECT_NE(text.find("period 3"), std::string::npos) << text;
  EXPECT_NE(text.find("Tr P_k|k=0.5"), std::string::npos) << text;
  EXPECT_NE(text.find("Tr P_k|k-1=0.9"), std::string::npos) << text;
  EXPECT_NE(text.find("|x-x̂|=3"), std::string::npos) << text;
  EXPECT_NE(text.find("bernoulli loss=1"), std::string::npos) << text;
  EXPECT_NE(text.find("0.000"), std::string::npos) << text;  // observed arrival rate of link 2
  EXPECT_NE(text.find("theory: pending"), std::string::npos) << text;
  TheoryRequest r;
  r.configured = model.configured_scenario();
  model.set_theory(compute_theory(r));
  text = render_status(model.snapshot(), false);
  EXPECT_NE(text.find("theory (configured links)"), std::string::npos) << text;
  EXPECT_NE(text.find("E[P_k|k-1]"), std::string::npos) << text;
  const std::string screen = render_status_screen("header line", model.snapshot(), false, {"an event"});
  EXPECT_EQ(screen.rfind("\x1b[H\x1b[2J", 0), 0u);
  EXPECT_NE(screen.find("header line"), std::string::npos);
  EXPECT_NE(screen.find("an event"), std::string::npos);
}

// A large network: the status counts the fused sensors and lists the links furthest below
// their configured rate, plus one line over all, instead of 40 ids and 40 rows a second.
TEST(LiveStatusText, ALargeNetworkShowsTheLinksFurthestBelowTheirRate) {
  Scenario s = default_scenario();
  const SensorSpec first = s.sensors[0];
  s.sensors.clear();
  for (int id = 1; id <= 40; ++id) {
    SensorSpec sensor = first;
    sensor.id = id;
    sensor.link = BernoulliLink{0.1};
    s.sensors.push_back(sensor);
  }
  LiveModel model(s);
  Estimate e = estimate(3, {1.0, 5.0}, 0.5, 0.9);
  e.fused.clear();
  for (int id = 1; id <= 36; ++id) e.fused.push_back(id);
  model.add_estimate(e);
  // Observed rates 0.9 everywhere but link 17 (0.5) and link 33 (0.8); link 40 not reported.
  for (int id = 1; id <= 39; ++id)
    model.add_link_status(link_status(id, BernoulliLink{0.1}, 100, id == 17 ? 50 : id == 33 ? 80 : 90));
  const std::string text = render_status(model.snapshot(), false);
  EXPECT_NE(text.find("fused=36/40 "), std::string::npos) << text;
  EXPECT_NE(text.find("(8 of 40 links: those furthest below their rate)"), std::string::npos) << text;
  // Order: no rate yet (40), then 17 (0.9 - 0.5), then 33 (0.9 - 0.8), then equal ones by id.
  const auto row = [&](int id) { return text.find("\n  " + std::to_string(id) + " "); };
  ASSERT_NE(row(40), std::string::npos) << text;
  ASSERT_NE(row(17), std::string::npos) << text;
  ASSERT_NE(row(33), std::string::npos) << text;
  EXPECT_LT(row(40), row(17));
  EXPECT_LT(row(17), row(33));
  EXPECT_EQ(row(25), std::string::npos) << text;  // one of the 34 on target: not listed
  // Mean over the 39 reported: (37 * 0.9 + 0.5 + 0.8) / 39 = 0.8872 (printed 0.887).
  EXPECT_NE(text.find("all 40 links: λ since change mean 0.887, min 0.500; late 0.000; 1 without a rate yet"),
            std::string::npos)
      << text;
  // The theory answers for 40 sensors (it refused more than 16 before). Sensor 1 of the default
  // scenario, C = [0, 1], never sees the mode 1.25 of the upper-triangular A (C v = 0 for its
  // eigenvector e1), so that block's rate is 1 and the criterion is 1.25² = 1.5625: unstable
  // (multi-sensor paper Thm 7).
  TheoryRequest r;
  r.configured = model.configured_scenario();
  model.set_theory(compute_theory(r));
  const std::string with_theory = render_status(model.snapshot(), false);
  EXPECT_NE(with_theory.find("stable=no"), std::string::npos) << with_theory;
  EXPECT_NE(with_theory.find("Markov criterion=1.562"), std::string::npos) << with_theory;
  EXPECT_EQ(with_theory.find("theory unavailable"), std::string::npos) << with_theory;
}

/// The value of one sample line of the text exposition ("name{labels} value").
double metric(const std::string& text, const std::string& series) {
  const auto at = text.find("\n" + series + " ");
  if (at == std::string::npos) return std::nan("");
  return std::stod(text.substr(at + series.size() + 2));
}

TEST(LiveMetrics, ARelaysLinksAreLabelledByTopicAndOnlyLinksAreServed) {
  LiveMetrics metrics(LiveMetrics::Scope::links);
  LiveSnapshot snapshot;
  LinkView view;
  static_cast<LinkStatus&>(view) = link_status(netkf::relay_topic_link_id("rt/scan"), BernoulliLink{0.3}, 50, 40);
  view.topic = "rt/scan";
  snapshot.links.push_back(view);
  metrics.update(snapshot);
  metrics.observe_pipeline_latency(0.001);  // no histogram: ignored
  metrics.count_restart("sensors");         // no processes: ignored
  const std::string text = metrics.serialize();
  EXPECT_EQ(metric(text, "netkf_link_samples_total{link=\"rt/scan\"}"), 50.0) << text;
  EXPECT_EQ(metric(text, "netkf_link_dropped_total{link=\"rt/scan\"}"), 10.0);
  EXPECT_EQ(text.find("netkf_estimator"), std::string::npos) << "a relay has no estimator";
  EXPECT_EQ(text.find("netkf_pipeline_latency"), std::string::npos);
  EXPECT_EQ(text.find("netkf_process_restarts"), std::string::npos);
  EXPECT_NE(render_link_table({view}).find("\nrt/scan "), std::string::npos) << "the table names the link by its topic";
}

TEST(LiveMetrics, CountersFollowTheTotalsAndNeverGoBack) {
  LiveModel model(default_scenario());
  LiveMetrics metrics;
  model.add_link_status(link_status(2, BernoulliLink{0.2}, 100, 80));
  model.add_estimate(estimate(9, {0.0, 0.0}, 0.5, 0.9));
  metrics.update(model.snapshot());
  std::string text = metrics.serialize();
  EXPECT_EQ(metric(text, "netkf_link_samples_total{link=\"2\"}"), 100.0) << text;
  EXPECT_EQ(metric(text, "netkf_link_delivered_total{link=\"2\"}"), 80.0);
  EXPECT_EQ(metric(text, "netkf_link_dropped_total{link=\"2\"}"), 20.0);
  EXPECT_EQ(metric(text, "netkf_link_configured_loss{link=\"2\"}"), 0.2);
  EXPECT_EQ(metric(text, "netkf_estimator_period"), 9.0);
  EXPECT_EQ(metric(text, "netkf_estimator_fused_sensors"), 2.0);
  EXPECT_EQ(metric(text, "netkf_estimator_diverging"), 0.0);
  // The channel restarted: its totals start again at 30; the counter goes on from 100.
  model.add_link_status(link_status(2, BernoulliLink{0.2}, 30, 30, 5));
  metrics.update(model.snapshot());
  text = metrics.serialize();
  EXPECT_EQ(metric(text, "netkf_link_samples_total{link=\"2\"}"), 130.0) << text;
  metrics.observe_pipeline_latency(0.0004);
  metrics.observe_pipeline_latency(0.003);
  metrics.count_restart("channel_emulator");
  text = metrics.serialize();
  EXPECT_EQ(metric(text, "netkf_pipeline_latency_seconds_count"), 2.0) << text;
  EXPECT_EQ(metric(text, "netkf_pipeline_latency_seconds_bucket{le=\"0.0005\"}"), 1.0) << text;
  EXPECT_EQ(metric(text, "netkf_process_restarts_total{process=\"channel_emulator\"}"), 1.0) << text;
}

}  // namespace
TEST(LiveModel, ObservedArrivalRateCountsOnlySamplesInTime) {
  // A delivered sample the channel delayed beyond the deadline is lost to the estimator.
  LiveModel model(default_scenario());
  auto status = link_status(1, BernoulliLink{0.0}, 100, 100);
  status.past_deadline = 40;
  model.add_link_status(status);
  EXPECT_DOUBLE_EQ(model.snapshot().links[0].observed_rate_since_change.value(), 0.6);
  status = link_status(1, BernoulliLink{0.0}, 200, 200);
  status.past_deadline = 50;  // 10 of the last 100 late: 150 of 200 in time
  model.add_link_status(status);
  EXPECT_DOUBLE_EQ(model.snapshot().links[0].observed_rate_since_change.value(), 0.75);
}

}  // namespace netkf::cli
