// The observed arrival rate (cli/live/include/netkf/cli/live/observed_rate.hpp) from a known sequence of channel
// reports, through every view: LinkView, `ctl status --json` (link_status_json), the
// dashboard's message, the theory's observed point, the terminal status, the ctl table,
// /metrics and the run summary. Every expected number is computed by hand in the comments.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "netkf/cli/live/channel_catalogue.hpp"
#include "netkf/cli/live/live_metrics.hpp"
#include "netkf/cli/live/live_model.hpp"
#include "netkf/cli/live/live_status.hpp"
#include "netkf/cli/live/observed_rate.hpp"
#include "netkf/cli/live/run_summary.hpp"
#include "netkf/cli/live/theory_worker.hpp"

namespace netkf::cli {
namespace {

// Link 2 of the default scenario, with a delay that makes some delivered samples late:
// uniform 6 ± 4 ms against the 8 ms deadline, P(in time) = 0.75.
const LinkSpec kLink2{BernoulliLink{0.3}, LinkDelay{6.0, 4.0, DelayDistribution::uniform}};

// One report of a link: counts since the model was set, and the lifetime count of samples.
LinkStatus report(int id, const LinkSpec& link, std::uint64_t samples_in, std::uint64_t delivered,
                        std::uint64_t past_deadline, std::uint64_t samples_total, std::uint64_t request = 0) {
  LinkStatus r;
  r.sensor_id = id;
  r.link = link;
  r.in_time = id == 2 ? 0.75 : 1.0;
  r.samples_in = samples_in;
  r.delivered = delivered;
  r.dropped = samples_in - delivered;
  r.past_deadline = past_deadline;
  r.observed_loss = samples_in ? static_cast<double>(r.dropped) / static_cast<double>(samples_in) : 0.0;
  r.samples_total = samples_total;
  r.delivered_total = delivered;  // (not read by the rates)
  r.dropped_total = samples_in - delivered;
  r.last_request_id = request;
  return r;
}

/// The value of one sample line of the text exposition ("name{labels} value"); NaN when absent.
double metric(const std::string& text, const std::string& series) {
  const auto at = text.find("\n" + series + " ");
  if (at == std::string::npos) return std::nan("");
  return std::stod(text.substr(at + series.size() + 2));
}

// Link 2's reports in one model (no change: samples_in grows as samples_total does), then a
// change. Columns: samples_in, delivered, past_deadline → in time = delivered − past_deadline.
//   R1   400   300   20 →  280   since 280/400  = 0.7    window = since (400 < 1000)
//   R2   800   620   40 →  580   since 580/800  = 0.725  window = since (800 < 1000)
//   R3  1200   900   60 →  840   since 840/1200 = 0.7    window from the change (1200 − 400 < 1000): 0.7 over 1200
//   R4  1600  1150   70 → 1080   since 1080/1600 = 0.675 window from R1 (1600 − 800 < 1000 ≤ 1600 − 400):
//                                 (1080 − 280)/(1600 − 400) = 800/1200 = 2/3 over 1200
//   R5  2000  1250   70 → 1180   since 1180/2000 = 0.59  window from R2: (1180 − 580)/(2000 − 800) = 0.5 over 1200
const std::vector<LinkStatus> kReports = {
    report(2, kLink2, 400, 300, 20, 400),     report(2, kLink2, 800, 620, 40, 800),
    report(2, kLink2, 1200, 900, 60, 1200),   report(2, kLink2, 1600, 1150, 70, 1600),
    report(2, kLink2, 2000, 1250, 70, 2000)};
const double kSince[] = {0.7, 0.725, 0.7, 0.675, 0.59};
const double kWindow[] = {0.7, 0.725, 0.7, 2.0 / 3.0, 0.5};
const std::uint64_t kSpan[] = {400, 800, 1200, 1200, 1200};

// Links 1 and 3, one report each: 450/500 = 0.9 in time; 400 delivered, 100 past the deadline: 300/500 = 0.6.
const LinkStatus kLink1 = report(1, BernoulliLink{0.2}, 500, 450, 0, 500);
const LinkStatus kLink3 = report(3, GilbertElliottLink{0.05, 0.3, 0.02, 1.0}, 500, 400, 100, 500);

TEST(ObservedRate, SinceChangeAndWindowFromKnownReports) {
  ObservedRateWindow window;
  for (std::size_t i = 0; i < kReports.size(); ++i) {
    window.add(kReports[i]);
    EXPECT_DOUBLE_EQ(observed_rate_since_change(kReports[i]).value(), kSince[i]) << "R" << i + 1;
    EXPECT_DOUBLE_EQ(window.rate().value(), kWindow[i]) << "R" << i + 1;
    EXPECT_EQ(window.samples(), kSpan[i]) << "R" << i + 1;
  }
  EXPECT_EQ(delivered_in_time(kReports[4]), 1180u);
  EXPECT_EQ(kWindowSamples, 1000u);
}

// The channel starts the counts since the change again when a model is set: by request (the
// status right after it has no sample), by a timeline's set (no new request id), or when the
// channel restarts. The window never reaches back over a change.
TEST(ObservedRate, TheWindowStartsAgainAtEveryChange) {
  ObservedRateWindow window;
  for (const auto& r : kReports) window.add(r);
  const LinkSpec half{BernoulliLink{0.5}};
  // A request: no sample since the change yet, no rate.
  auto r = report(2, half, 0, 0, 0, 2000, 7);
  window.add(r);
  EXPECT_FALSE(observed_rate_since_change(r));
  EXPECT_FALSE(window.rate());
  EXPECT_EQ(window.samples(), 0u);
  // 100 samples later: 50 delivered, 5 past the deadline: 45/100.
  window.add(report(2, half, 100, 50, 5, 2100, 7));
  EXPECT_DOUBLE_EQ(window.rate().value(), 0.45);
  EXPECT_EQ(window.samples(), 100u);
  // A timeline's set (same request id), seen as counts that went back: 60/60.
  window.add(report(2, half, 60, 60, 0, 2200, 7));
  EXPECT_DOUBLE_EQ(window.rate().value(), 1.0);
  EXPECT_EQ(window.samples(), 60u);
  // Another set after 20 more samples, then 280: samples_in grew (60 → 280) but by less than
  // the lifetime count (2200 → 2500), so the counts started again: 140/280, not (140−60)/(280−60).
  window.add(report(2, half, 280, 140, 0, 2500, 7));
  EXPECT_DOUBLE_EQ(window.rate().value(), 0.5);
  EXPECT_EQ(window.samples(), 280u);
  // A refused request changes the request id but not the counts: the window goes on.
  auto refused = report(2, half, 1300, 650, 0, 3520, 8);  // +1020 samples, +510 in time
  refused.rejection_reason = "mean burst 2 with loss 0.9 is no valid link";
  window.add(refused);
  // Newest report ≥ 1000 samples back: the 280 one: (650 − 140)/(1300 − 280) = 510/1020 = 0.5 over 1020.
  EXPECT_DOUBLE_EQ(window.rate().value(), 0.5);
  EXPECT_EQ(window.samples(), 1020u);
  // A channel restart: the lifetime count went back; it counts from its start again: 30/40.
  window.add(report(2, LinkSpec{BernoulliLink{0.3}}, 40, 30, 0, 40));
  EXPECT_DOUBLE_EQ(window.rate().value(), 0.75);
  EXPECT_EQ(window.samples(), 40u);
}

// Every view of the live model after R5, and after the change that follows.
TEST(ObservedRate, EveryViewShowsTheSameRatesUnderTheirNames) {
  const Scenario scenario = default_scenario();
  LiveModel model(scenario);
  RunSummaryBuilder summary(scenario);
  LiveMetrics metrics;
  const auto feed = [&](const LinkStatus& r) {
    model.add_link_status(r);
    summary.add_link_status(r);
  };
  feed(kLink1);
  feed(kLink3);
  for (const auto& r : kReports) feed(r);

  // LinkView: the one place every view reads.
  const LinkView& view = model.snapshot().links[1];
  ASSERT_EQ(view.sensor_id, 2);
  EXPECT_DOUBLE_EQ(view.observed_rate_since_change.value(), 0.59);
  EXPECT_DOUBLE_EQ(view.observed_rate_window.value(), 0.5);
  EXPECT_EQ(view.observed_window_samples, 1200u);
  EXPECT_DOUBLE_EQ(view.arrival_rate(), 0.7 * 0.75);  // configured: (1 − 0.3) · 0.75 = 0.525

  // The theory's observed operating point: the since-change rates, scenario order.
  const auto rates = model.observed_rates_since_change();
  ASSERT_TRUE(rates);
  EXPECT_EQ(*rates, (std::vector<double>{0.9, 0.59, 0.6}));
  TheoryRequest request;
  request.configured = model.configured_scenario();
  request.observed_rates = rates;
  model.set_theory(compute_theory(request));
  const auto theory = catalogue::theory_message(model.snapshot().theory);
  EXPECT_EQ(theory["observed"]["arrival_rates"], nlohmann::json({0.9, 0.59, 0.6}));
  EXPECT_EQ(theory["observed_rates_from"], "observed_arrival_rate_since_change");

  // ctl status --json: one report, so the since-change rate and its counts, no window.
  const auto ctl = catalogue::link_status_json(view);
  EXPECT_EQ(ctl["samples_in"], 2000);
  EXPECT_EQ(ctl["delivered"], 1250);
  EXPECT_EQ(ctl["past_deadline"], 70);
  EXPECT_EQ(ctl["delivered_in_time"], 1180);
  EXPECT_DOUBLE_EQ(ctl["observed_arrival_rate_since_change"].get<double>(), 0.59);
  EXPECT_DOUBLE_EQ(ctl["configured_arrival_rate"].get<double>(), 0.525);
  EXPECT_FALSE(ctl.contains("observed_arrival_rate_window"));
  EXPECT_FALSE(ctl.contains("observed_arrival_rate"));  // the old name, with no window named

  // The dashboard's (and the recording's) message: the same, and the window with its span.
  const auto message = catalogue::link_status_message(view);
  EXPECT_DOUBLE_EQ(message["observed_arrival_rate_since_change"].get<double>(), 0.59);
  EXPECT_EQ(message["delivered_in_time"], 1180);
  EXPECT_DOUBLE_EQ(message["observed_arrival_rate_window"].get<double>(), 0.5);
  EXPECT_EQ(message["observed_window_samples"], 1200);

  // The terminal status: each rate under its window's name, the since-change one with its counts.
  const std::string status = render_status(model.snapshot(), false);
  EXPECT_NE(status.find("λ since change (in time/samples)"), std::string::npos) << status;
  EXPECT_NE(status.find("λ last ≥1000 samples"), std::string::npos) << status;
  EXPECT_NE(status.find("\n  2      0.525  0.590 = 1180/2000"), std::string::npos) << status;
  EXPECT_NE(status.find("0.500 over 1200"), std::string::npos) << status;
  EXPECT_NE(status.find("0.900 = 450/500"), std::string::npos) << status;
  EXPECT_NE(status.find("0.600 = 300/500"), std::string::npos) << status;
  EXPECT_NE(status.find("theory (observed rates since change, i.i.d.)"), std::string::npos) << status;

  // The ctl table: the since-change rate and the in-time count beside samples_in.
  const std::string table = render_link_table({view});
  EXPECT_NE(table.find("λ since change"), std::string::npos) << table;
  EXPECT_NE(table.find(" 0.5900       2000       1250       1180        750"), std::string::npos) << table;

  // /metrics: one name, the window as a label, and the window's span.
  metrics.update(model.snapshot());
  std::string text = metrics.serialize();
  EXPECT_DOUBLE_EQ(metric(text, "netkf_link_observed_arrival_rate{link=\"2\",window=\"since_change\"}"), 0.59) << text;
  EXPECT_DOUBLE_EQ(metric(text, "netkf_link_observed_arrival_rate{link=\"2\",window=\"last_1000_samples\"}"), 0.5);
  EXPECT_EQ(metric(text, "netkf_link_observed_window_samples{link=\"2\"}"), 1200.0);
  EXPECT_DOUBLE_EQ(metric(text, "netkf_link_observed_arrival_rate{link=\"3\",window=\"since_change\"}"), 0.6);

  // The run summary: as last reported.
  const RunSummary& s = summary.summary();
  EXPECT_DOUBLE_EQ(measure(s, "link.2.observed_arrival_rate_since_change").value, 0.59);
  EXPECT_DOUBLE_EQ(measure(s, "link.2.observed_arrival_rate_window").value, 0.5);
  EXPECT_EQ(measure(s, "link.2.observed_window_samples").value, 1200.0);
  const auto json = summary_json(s, {});
  EXPECT_DOUBLE_EQ(json["link"]["2"]["observed_arrival_rate_since_change"].get<double>(), 0.59);
  EXPECT_DOUBLE_EQ(json["link"]["2"]["observed_arrival_rate_window"].get<double>(), 0.5);
  EXPECT_EQ(json["link"]["2"]["observed_window_samples"], 1200);

  // A request sets link 2 to loss 0.5: no sample since, so no observed rate anywhere (and no
  // observed operating point) until the next report.
  feed(report(2, LinkSpec{BernoulliLink{0.5}}, 0, 0, 0, 2000, 7));
  const LinkView& changed = model.snapshot().links[1];
  EXPECT_FALSE(changed.observed_rate_since_change);
  EXPECT_FALSE(changed.observed_rate_window);
  EXPECT_FALSE(model.observed_rates_since_change());
  EXPECT_TRUE(catalogue::link_status_json(changed)["observed_arrival_rate_since_change"].is_null());
  EXPECT_TRUE(catalogue::link_status_message(changed)["observed_arrival_rate_window"].is_null());
  // Configured (1 − 0.5) · 0.75 = 0.375; neither observed rate yet.
  const std::string after_change = render_status(model.snapshot(), false);
  EXPECT_NE(after_change.find("\n  2      0.375  -                                 -"), std::string::npos) << after_change;
  metrics.update(model.snapshot());
  text = metrics.serialize();
  EXPECT_EQ(text.find("netkf_link_observed_arrival_rate{link=\"2\""), std::string::npos) << text;
  EXPECT_EQ(measure(summary.summary(), "link.2.observed_arrival_rate_since_change").missing,
            "link 2 carried no sample since its model was last set");
  // 100 samples later: 45 in time.
  feed(report(2, LinkSpec{BernoulliLink{0.5}}, 100, 50, 5, 2100, 7));
  EXPECT_DOUBLE_EQ(model.snapshot().links[1].observed_rate_since_change.value(), 0.45);
  EXPECT_DOUBLE_EQ(model.snapshot().links[1].observed_rate_window.value(), 0.45);
  EXPECT_EQ(*model.observed_rates_since_change(), (std::vector<double>{0.9, 0.45, 0.6}));
  EXPECT_DOUBLE_EQ(measure(summary.summary(), "link.2.observed_arrival_rate_window").value, 0.45);
}

}  // namespace
}  // namespace netkf::cli
