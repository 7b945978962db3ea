// One live model per launch (issue 39): the MCAP recorder and the run summary read the
// launch's LiveModel instead of keeping their own. Fed once, in the launch's order
// (launch.hpp's recording_handlers: the model first, then the recording and the summary),
// they must write what the recorder and the summary with models of their own write from the
// same records: the recording byte for byte, the summary's JSON to the last digit; and the
// counts they share (late samples per link, the scored error) must be the hand-made records'.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "netkf/cli/live/live_model.hpp"
#include "netkf/cli/live/run_summary.hpp"
#include "record_mcap.hpp"
#include "mcap_reader.hpp"

namespace netkf::cli {
namespace {

/// The records of a short run, in an order of arrival that mixes the topics.
struct Records {
  std::vector<Truth> truths;
  std::vector<Estimate> estimates;
  std::vector<LinkStatus> statuses;
  std::vector<LinkChange> changes;
};

constexpr int kPeriods = 40;

Records make_run(const Scenario& s) {
  Records run;
  const auto n = static_cast<Eigen::Index>(s.state_dim());
  for (int k = 0; k < kPeriods; ++k) {
    std::vector<double> x(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) x[static_cast<std::size_t>(i)] = 0.1 * k + static_cast<double>(i);
    run.truths.push_back(Truth{k, k * s.period_s(), x, {}});
    Estimate e;
    e.k = static_cast<std::uint64_t>(k);
    e.t = k * s.period_s();
    e.x_hat = Vector::Constant(n, 0.05 * k);
    e.P = Matrix::Identity(n, n) * (1.0 + 0.01 * k);
    e.trace_P_pred = 2.0 * e.P.trace();
    e.fused = {s.sensors[0].id};
    // Sensor 2 is late in every third period, sensor 3 in every fifth.
    if (k % 3 == 0) e.late_sensors.push_back(s.sensors[1].id);
    if (k % 5 == 0) e.late_sensors.push_back(s.sensors[2].id);
    e.late = static_cast<std::uint32_t>(e.late_sensors.size());
    e.late_total = 0;
    run.estimates.push_back(e);
  }
  for (const auto& sensor : s.sensors) {
    LinkStatus l;
    l.sensor_id = sensor.id;
    l.link = sensor.link;
    l.samples_total = 100;
    l.delivered_total = 90;
    l.dropped_total = 10;
    run.statuses.push_back(l);
  }
  LinkStatus own = run.statuses[1];  // the answer to a request of this process (id 77)
  own.last_request_id = 77;
  own.link.loss = BernoulliLink{0.5};
  own.samples_total = 200;
  run.statuses.push_back(own);
  LinkStatus other = run.statuses[0];  // the answer to another client's request
  other.last_request_id = 78;
  other.link.loss = BernoulliLink{0.25};
  run.statuses.push_back(other);
  LinkChange c;
  c.sensor_id = s.sensors[1].id;
  c.at_period = 12;
  c.origin = LinkChange::Origin::request;
  c.request_id = 77;
  c.link = own.link;
  LinkChange step = c;
  step.origin = LinkChange::Origin::timeline;
  step.request_id = 0;
  step.at_period = 20;
  run.changes = {c, c, step, step};  // each twice: transient-local repeats
  return run;
}

/// What reads the records: a recorder and a summary, standalone or on one model.
struct Readers {
  std::ostringstream mcap;
  LiveModel* model;  // nullptr: each keeps its own
  McapRecorder recorder;
  RunSummaryBuilder summary;
  Readers(const Scenario& s, LiveModel* shared)
      : model(shared),
        recorder(shared ? McapRecorder(mcap, *shared, true) : McapRecorder(mcap, s, true)),
        summary(shared ? RunSummaryBuilder(*shared) : RunSummaryBuilder(s)) {}
};

/// The records in one order of arrival, each to the model first (once), then to the readers.
void feed(const Records& run, Readers& r) {
  auto truth = [&](const Truth& t) {
    if (r.model) r.model->add_truth(t);
    r.recorder.truth(t);
    r.summary.add_truth(t);
  };
  auto estimate = [&](const Estimate& e) {
    if (r.model && e.revision == 0) r.model->add_estimate(e);
    r.recorder.estimate(e);
    r.summary.add_estimate(e);
  };
  auto status = [&](const LinkStatus& l) {
    if (r.model) r.model->add_link_status(l);
    r.recorder.link_status(l);
    r.summary.add_link_status(l);
  };
  auto change = [&](const LinkChange& c) {
    if (r.model) r.model->add_link_change(c);
    r.recorder.link_change(c);
  };
  for (int k = 0; k < kPeriods; ++k) {
    const auto i = static_cast<std::size_t>(k);
    // Truth first in even periods, the estimate first in odd ones: the join sees both orders.
    if (k % 2 == 0) truth(run.truths[i]);
    estimate(run.estimates[i]);
    if (k % 2 == 1) truth(run.truths[i]);
    if (k == 10)
      for (const auto& l : run.statuses) status(l);
    if (k == 15)
      for (const auto& c : run.changes) change(c);
    if (k == 16) {
      Estimate revised = run.estimates[14];  // a late revision: plotted, never in the model
      revised.revision = 1;
      revised.x_hat *= 0.5;
      estimate(revised);
    }
    if (k == 30 && r.model) {
      // The theory's crossings are the console's events, not the recording's.
      TheoryView theory;
      theory.ready = true;
      theory.configured.result.stable = theory::Verdict::yes;
      r.model->set_theory(theory);
      theory.configured.result.stable = theory::Verdict::no;
      r.model->set_theory(theory);
    }
  }
  r.recorder.finish();
}

/// The recording's messages on `topic`, read back with the MCAP reader.
std::vector<nlohmann::json> recorded(const std::string& mcap, const std::string& topic) {
  std::vector<nlohmann::json> out;
  std::istringstream in(mcap);
  read_mcap_messages(in, "the recording", [&](const McapMessage& m) {
    if (m.topic == topic) out.push_back(nlohmann::json::parse(m.data));
  });
  return out;
}

TEST(OneLiveModel, TheRecorderAndTheSummaryReadingTheLaunchsModelWriteWhatTheirOwnModelsWrote) {
  Scenario s = default_scenario();
  const Records run = make_run(s);
  Readers own(s, nullptr);
  feed(run, own);
  LiveModel model(s);
  model.note_own_request(77, "dashboard");
  Readers shared(s, &model);
  feed(run, shared);

  // Fed once: 40 in-time estimates (not the revision, not one per reader).
  EXPECT_EQ(model.snapshot().estimates, static_cast<std::uint64_t>(kPeriods));
  EXPECT_EQ(shared.mcap.str(), own.mcap.str());
  EXPECT_EQ(shared.recorder.events(), own.recorder.events());
  const std::vector<CheckResult> none;
  EXPECT_EQ(summary_json(shared.summary.summary(), none).dump(), summary_json(own.summary.summary(), none).dump());

  // The summary's error, by hand: |x_k − x̂_k|² = Σ_i (0.1k + i − 0.05k)², every period scored.
  double sum = 0.0;
  for (int k = 0; k < kPeriods; ++k)
    for (int i = 0; i < s.state_dim(); ++i) sum += std::pow(0.05 * k + i, 2);
  EXPECT_EQ(shared.summary.summary().periods_scored, static_cast<std::uint64_t>(kPeriods));
  EXPECT_NEAR(measure(shared.summary.summary(), "rms_error").value, std::sqrt(sum / kPeriods), 1e-12);
  EXPECT_EQ(*model.snapshot().rms_error, measure(shared.summary.summary(), "rms_error").value);

  // Late samples per link: sensor 2 in periods 0, 3, ..., 39 (14), sensor 3 in 0, 5, ..., 35 (8).
  // The recording's last status of each link was written at period 10: 4 and 3 by then.
  const std::map<int, std::uint64_t> expected{{s.sensors[0].id, 0}, {s.sensors[1].id, 14}, {s.sensors[2].id, 8}};
  const std::map<int, std::uint64_t> expected_at_10{{s.sensors[0].id, 0}, {s.sensors[1].id, 4}, {s.sensors[2].id, 3}};
  std::map<int, std::uint64_t> recorded_late;
  for (const auto& m : recorded(shared.mcap.str(), "netkf/link/status"))
    recorded_late[m["sensor_id"].get<int>()] = m["late_total"].get<std::uint64_t>();
  EXPECT_EQ(recorded_late, expected_at_10);
  for (const auto& [id, late] : expected) {
    EXPECT_EQ(model.find_link(id)->late_total, late) << "link " << id;
    EXPECT_EQ(measure(shared.summary.summary(), "link." + std::to_string(id) + ".late").value,
              static_cast<double>(late))
        << "link " << id;
  }

  // The console (the model's first reader) sees every event: the dashboard's request named,
  // each timeline step as often as it came, the theory's crossing.
  std::vector<std::string> console;
  for (const auto& e : model.take_events()) console.push_back(e.text);
  auto has = [&](const std::string& text) {
    for (const auto& line : console)
      if (line.find(text) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(has("loss=0.5 (from dashboard)"));
  EXPECT_TRUE(has("loss=0.25 (from netkf ctl or another client)"));
  EXPECT_TRUE(has("below the critical arrival rate"));
  EXPECT_EQ(std::count_if(console.begin(), console.end(),
                          [](const std::string& l) { return l.find("timeline: link") != std::string::npos; }),
            2);
  // The recording's events: the requests as any reader words them, the timeline step once,
  // not the theory's.
  std::vector<std::string> logged;
  for (const auto& m : recorded(shared.mcap.str(), "netkf/events")) logged.push_back(m["message"].get<std::string>());
  ASSERT_EQ(logged.size(), 3u);
  EXPECT_NE(logged[0].find("loss=0.5 (from netkf ctl or another client)"), std::string::npos) << logged[0];
  EXPECT_NE(logged[1].find("loss=0.25 (from netkf ctl or another client)"), std::string::npos) << logged[1];
  EXPECT_NE(logged[2].find("timeline: link"), std::string::npos) << logged[2];
}

}  // namespace
}  // namespace netkf::cli
