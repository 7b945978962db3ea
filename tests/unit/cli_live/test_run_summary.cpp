// The run summary and the pass/fail checks of `netkf launch --summary/--check`
// (cli/run_summary): parsing of good and bad checks, their evaluation (a value that was not
// measured never passes), and the summary's numbers against hand computations on a small
// record set and against a second, straightforward computation on a random one.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <random>

#include "netkf/cli/live/relay_summary.hpp"
#include "netkf/cli/live/run_summary.hpp"

namespace netkf::cli {
namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

/// A scenario with the given sensor ids (only the ids and n = 2 matter to the summary).
Scenario scenario_with(const std::vector<int>& ids) {
  Scenario s;
  s.name = "unit-summary";
  s.plant.A = Matrix::Identity(2, 2);
  s.plant.Q = Matrix::Identity(2, 2);
  for (int id : ids) {
    SensorSpec sensor;
    sensor.id = id;
    sensor.C = Matrix::Identity(1, 2);
    sensor.R = Matrix::Identity(1, 1);
    s.sensors.push_back(sensor);
  }
  return s;
}

/// The message of the std::invalid_argument that parsing `text` throws ("" if none).
std::string parse_error(const std::string& text, const std::vector<int>& ids = {1, 2, 3}) {
  try {
    parse_check(text, ids);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

Truth truth(std::int64_t k, std::vector<double> x) { return Truth{k, 0.01 * static_cast<double>(k), x, {}}; }

Estimate estimate(std::uint64_t k, const std::vector<double>& x_hat, double trace_P, std::vector<int> fused,
                  std::vector<int> late_sensors, const std::string& state, double latency_ms) {
  Estimate e;
  e.k = k;
  const auto n = static_cast<Eigen::Index>(x_hat.size());
  e.x_hat = Eigen::Map<const Vector>(x_hat.data(), n);
  e.P = Matrix::Identity(n, n) * (trace_P / static_cast<double>(n));
  e.trace_P_pred = 2.0 * trace_P + 1.0;  // any value above Tr P_{k|k}, distinct per period
  e.fused = std::move(fused);
  e.late = static_cast<std::uint32_t>(late_sensors.size());
  e.late_sensors = std::move(late_sensors);
  e.state = state == "diverging" ? FilterState::diverging : FilterState::ok;
  // Stamps: 100 s into the clock, the estimate latency_ms after its newest sample.
  constexpr std::int64_t kStart = 100'000'000'000;
  e.last_sample_stamp_ns = latency_ms >= 0.0 ? kStart : 0;
  e.stamp_ns = kStart + std::llround(latency_ms * 1e6);
  return e;
}

LinkStatus status(int id, std::uint64_t samples, std::uint64_t delivered, std::uint64_t dropped) {
  LinkStatus l;
  l.sensor_id = id;
  l.samples_total = samples;
  l.delivered_total = delivered;
  l.dropped_total = dropped;
  return l;
}

double value_of(const RunSummary& s, const std::string& name) {
  const Measured m = measure(s, name);
  EXPECT_TRUE(m.measured()) << name << ": " << m.missing;
  return m.value;
}

// ---------------------------------------------------------------- parsing

TEST(CheckParsing, AcceptsTheFourOperatorsWithOrWithoutSpaces) {
  const std::vector<int> ids{1, 2, 3};
  auto c = parse_check("rms_error<0.8", ids);
  EXPECT_EQ(c.name, "rms_error");
  EXPECT_EQ(c.op, CheckOp::less);
  EXPECT_EQ(c.threshold, 0.8);
  EXPECT_EQ(c.text, "rms_error<0.8");

  c = parse_check("  link.2.observed_loss  <=  0.35 ", ids);
  EXPECT_EQ(c.name, "link.2.observed_loss");
  EXPECT_EQ(c.op, CheckOp::less_equal);
  EXPECT_EQ(c.threshold, 0.35);

  c = parse_check("periods>=100", ids);
  EXPECT_EQ(c.op, CheckOp::greater_equal);
  EXPECT_EQ(c.threshold, 100.0);

  c = parse_check("mean_trace_P > 1e-3", ids);
  EXPECT_EQ(c.op, CheckOp::greater);
  EXPECT_EQ(c.threshold, 1e-3);

  c = parse_check("pipeline_latency_p99_ms\t<\t-2.5", ids);
  EXPECT_EQ(c.name, "pipeline_latency_p99_ms");
  EXPECT_EQ(c.threshold, -2.5);

  for (const auto& name : summary_names(ids)) EXPECT_EQ(parse_check(name + "<1", ids).name, name);
}

TEST(CheckParsing, NamesAreTheSummarysPerLinkForTheScenariosIds) {
  const auto names = summary_names({4, 9});
  const std::vector<std::string> expected{
      "periods", "rms_error", "rms_error_final", "mean_trace_P", "mean_trace_P_pred", "late_fraction", "fused_fraction",
      "periods_diverging",
      "pipeline_latency_p50_ms", "pipeline_latency_p99_ms", "cost",
      "link.4.samples", "link.4.delivered", "link.4.dropped", "link.4.observed_loss",
      "link.4.observed_arrival_rate_since_change", "link.4.observed_arrival_rate_window", "link.4.observed_window_samples",
      "link.4.late", "link.4.fused",
      "link.9.samples", "link.9.delivered", "link.9.dropped", "link.9.observed_loss",
      "link.9.observed_arrival_rate_since_change", "link.9.observed_arrival_rate_window", "link.9.observed_window_samples",
      "link.9.late", "link.9.fused"};
  EXPECT_EQ(names, expected);
  // The actuation link (plant.control.link) is named `control`.
  const auto with_control = summary_names({4, netkf::kControlLinkId});
  EXPECT_NE(std::find(with_control.begin(), with_control.end(), "link.control.observed_loss"), with_control.end());
  EXPECT_EQ(parse_check("link.control.observed_loss<0.5", {4, netkf::kControlLinkId}).name, "link.control.observed_loss");
  EXPECT_THROW(parse_check("link.control.observed_loss<0.5", {4, 9}), std::invalid_argument);
}

TEST(CheckParsing, RefusesMalformedChecksSayingWhy) {
  struct Case {
    const char* text;
    const char* says;
  };
  const Case cases[] = {
      {"rms_error", "no comparison"},
      {"", "no comparison"},
      {"rms_error==0.8", "unsupported operator"},
      {"rms_error=<0.8", "unsupported operator"},
      {"rms_error!=0.8", "unsupported operator"},
      {"rms_error=0.8", "unsupported operator"},
      {"<0.8", "no name"},
      {"   >= 1", "no name"},
      {"rms_error<", "finite number, got ''"},
      {"rms_error<abc", "finite number, got 'abc'"},
      {"rms_error<0.8x", "finite number"},
      {"rms_error<0.8 1", "finite number"},
      {"rms_error<nan", "finite number"},
      {"rms_error<inf", "finite number"},
      {"rms_error<-inf", "finite number"},
      {"rms_error<1e999", "finite number"},  // out of range of a double
      {"rms_error<0x10", "finite number"},
      {"rms_error<0.8<1", "finite number"},
      {"rms_error<<0.8", "finite number"},
  };
  for (const auto& c : cases) {
    const std::string message = parse_error(c.text);
    EXPECT_NE(message.find(c.says), std::string::npos) << "'" << c.text << "' -> " << message;
    EXPECT_NE(message.find(std::string("check '") + c.text + "'"), std::string::npos) << message;
  }
}

TEST(CheckParsing, RefusesUnknownNamesAndLinksNotInTheScenario) {
  std::string m = parse_error("rms<0.8");
  EXPECT_NE(m.find("unknown name 'rms'"), std::string::npos) << m;
  EXPECT_NE(m.find("rms_error"), std::string::npos) << m;  // lists the names there are
  EXPECT_NE(m.find("link.ID.{samples, delivered, dropped, observed_loss, observed_arrival_rate_since_change, "
                   "observed_arrival_rate_window, observed_window_samples, late, fused}"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("1, 2, 3"), std::string::npos) << m;
  EXPECT_NE(parse_error("RMS_ERROR<0.8").find("unknown name"), std::string::npos);  // names are case-sensitive
  EXPECT_NE(parse_error("link.2.loss<0.3").find("unknown name 'link.2.loss'"), std::string::npos);
  EXPECT_NE(parse_error("link.2<0.3").find("unknown name"), std::string::npos);
  EXPECT_NE(parse_error("link.observed_loss<0.3").find("unknown name"), std::string::npos);

  m = parse_error("link.7.observed_loss<0.3");
  EXPECT_NE(m.find("link 7 is not in the scenario (its links: 1, 2, 3)"), std::string::npos) << m;
  m = parse_error("link.02.observed_loss<0.3");  // ids are written as the scenario writes them
  EXPECT_NE(m.find("link 02 is not in the scenario"), std::string::npos) << m;
  m = parse_error("link.1.late>0", {});
  EXPECT_NE(m.find("link 1 is not in the scenario (its links: none)"), std::string::npos) << m;
}

// ---------------------------------------------------------------- summary math

TEST(RunSummary, SmallRunByHand) {
  // Sensors 1 and 3 (not contiguous), n = 2.
  RunSummaryBuilder b(scenario_with({1, 3}));
  // k = 0..3 have truth and estimate; truth of 2 arrives after its estimate; k = 4 has no
  // truth, k = 5 no estimate.
  b.add_truth(truth(0, {1.0, 1.0}));
  b.add_estimate(estimate(0, {4.0, 5.0}, 1.0, {1, 3}, {}, "ok", 2.0));  // error (3, 4): 25
  b.add_truth(truth(1, {0.0, 0.0}));
  b.add_estimate(estimate(1, {0.0, -1.0}, 2.0, {1}, {3}, "ok", 1.0));  // error 1
  b.add_estimate(estimate(2, {2.0, 2.0}, 3.0, {}, {}, "ok", -1.0));    // no sample fused: no latency
  b.add_truth(truth(2, {1.0, 3.0}));                                    // error (1, -1): 2
  b.add_truth(truth(3, {0.5, 0.5}));
  b.add_estimate(estimate(3, {0.5, 0.5}, 4.0, {3}, {1, 3, 9}, "diverging", 4.0));  // error 0; 9 is no link
  b.add_estimate(estimate(4, {7.0, 7.0}, 5.0, {1, 3}, {}, "diverging", 3.0));
  b.add_truth(truth(5, {1.0, 1.0}));
  // Link 1: two reports, then the channel restarted (totals start again); link 3 never reported.
  b.add_link_status(status(1, 10, 7, 3));
  b.add_link_status(status(1, 20, 14, 6));
  b.add_link_status(status(1, 4, 3, 1));
  b.add_link_status(status(8, 100, 100, 0));  // not in the scenario: ignored

  const RunSummary& s = b.summary();
  EXPECT_EQ(value_of(s, "periods"), 5.0);
  EXPECT_DOUBLE_EQ(value_of(s, "rms_error"), std::sqrt((25.0 + 1.0 + 2.0 + 0.0) / 4.0));
  EXPECT_DOUBLE_EQ(value_of(s, "mean_trace_P"), (1.0 + 2.0 + 3.0 + 4.0 + 5.0) / 5.0);
  EXPECT_DOUBLE_EQ(value_of(s, "mean_trace_P_pred"), (3.0 + 5.0 + 7.0 + 9.0 + 11.0) / 5.0);
  EXPECT_DOUBLE_EQ(value_of(s, "fused_fraction"), (2.0 + 1.0 + 0.0 + 1.0 + 2.0) / (5.0 * 2.0));
  EXPECT_EQ(value_of(s, "periods_diverging"), 2.0);
  // Latencies 2, 1, 4, 3 ms: p50 is the 2nd smallest (ceil(0.5 × 4) = 2), p99 the 4th.
  EXPECT_NEAR(value_of(s, "pipeline_latency_p50_ms"), 2.0, 1e-9);
  EXPECT_NEAR(value_of(s, "pipeline_latency_p99_ms"), 4.0, 1e-9);
  // Link 1: 20 + 4 samples, 14 + 3 delivered, 6 + 1 dropped.
  EXPECT_EQ(value_of(s, "link.1.samples"), 24.0);
  EXPECT_EQ(value_of(s, "link.1.delivered"), 17.0);
  EXPECT_EQ(value_of(s, "link.1.dropped"), 7.0);
  EXPECT_DOUBLE_EQ(value_of(s, "link.1.observed_loss"), 7.0 / 24.0);
  EXPECT_EQ(value_of(s, "link.1.fused"), 3.0);  // k = 0, 1, 4
  EXPECT_EQ(value_of(s, "link.3.fused"), 3.0);  // k = 0, 3, 4
  EXPECT_EQ(value_of(s, "link.1.late"), 1.0);
  EXPECT_EQ(value_of(s, "link.3.late"), 2.0);
  EXPECT_EQ(s.late, 4u);  // sensor 9's late sample counts in the total, in no link
  // Link 3 never reported: its counts and the late fraction (whose denominator would miss
  // link 3's deliveries) are not measured.
  for (const char* name : {"link.3.samples", "link.3.delivered", "link.3.dropped", "link.3.observed_loss", "late_fraction"}) {
    const Measured m = measure(s, name);
    EXPECT_FALSE(m.measured()) << name;
    EXPECT_TRUE(std::isnan(m.value)) << name;
    EXPECT_EQ(m.missing, "the channel never reported link 3") << name;
  }
  b.add_link_status(status(3, 30, 27, 3));
  EXPECT_DOUBLE_EQ(value_of(b.summary(), "late_fraction"), 4.0 / (17.0 + 27.0));
  EXPECT_THROW(measure(s, "link.9.samples"), std::invalid_argument);
  EXPECT_THROW(measure(s, "nonsense"), std::invalid_argument);
}

TEST(RunSummary, NothingToMeasureIsNotAValue) {
  RunSummaryBuilder b(scenario_with({1, 2}));
  const RunSummary& empty = b.summary();
  EXPECT_EQ(value_of(empty, "periods"), 0.0);  // a count of nothing is 0, measured
  for (const char* name : {"rms_error", "mean_trace_P", "mean_trace_P_pred", "late_fraction", "fused_fraction", "periods_diverging",
                           "pipeline_latency_p50_ms", "pipeline_latency_p99_ms", "link.1.late", "link.1.fused",
                           "link.2.samples", "link.2.observed_loss"}) {
    const Measured m = measure(empty, name);
    EXPECT_FALSE(m.measured()) << name;
    EXPECT_FALSE(m.missing.empty()) << name;
  }
  EXPECT_EQ(measure(empty, "rms_error").missing, "no period with both truth and estimate");
  EXPECT_EQ(measure(empty, "periods_diverging").missing, "no estimate received");

  // Estimates without truth, nothing fused, a link that carried nothing.
  b.add_estimate(estimate(0, {0.0, 0.0}, 1.0, {}, {}, "ok", -1.0));
  b.add_link_status(status(1, 0, 0, 0));
  b.add_link_status(status(2, 0, 0, 0));
  const RunSummary& s = b.summary();
  EXPECT_EQ(measure(s, "rms_error").missing, "no period with both truth and estimate");
  EXPECT_EQ(measure(s, "pipeline_latency_p50_ms").missing, "no period with a fused sample");
  EXPECT_EQ(measure(s, "link.1.observed_loss").missing, "link 1 carried no sample");
  EXPECT_EQ(measure(s, "late_fraction").missing, "the channel delivered no sample");
  EXPECT_EQ(value_of(s, "link.1.samples"), 0.0);
  EXPECT_EQ(value_of(s, "fused_fraction"), 0.0);
  EXPECT_EQ(value_of(s, "periods_diverging"), 0.0);
}

TEST(RunSummary, TruthOfAnotherSizeIsNotScored) {
  RunSummaryBuilder b(scenario_with({1}));
  b.add_truth(truth(0, {1.0}));
  b.add_estimate(estimate(0, {1.0, 2.0}, 1.0, {1}, {}, "ok", 1.0));
  EXPECT_FALSE(measure(b.summary(), "rms_error").measured());
  EXPECT_EQ(value_of(b.summary(), "periods"), 1.0);
}

TEST(RunSummary, AgreesWithAStraightforwardComputationOnARandomRun) {
  // 3000 periods of random records in a shuffled order of arrival (truth before or after
  // its estimate), some truths and estimates missing; expected values recomputed here from
  // the full lists, the plain way.
  const std::vector<int> ids{2, 5, 7};
  std::mt19937_64 rng(20240611);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform;
  struct Period {
    std::vector<double> x, xhat;
    bool has_truth, has_estimate;
    double trace;
    std::vector<int> fused, late;
    bool diverging;
    double latency_ms;  // < 0: nothing fused
  };
  std::vector<Period> periods(3000);
  for (auto& p : periods) {
    p.x = {normal(rng), normal(rng)};
    p.xhat = {p.x[0] + 0.3 * normal(rng), p.x[1] + 0.3 * normal(rng)};
    p.has_truth = uniform(rng) > 0.02;
    p.has_estimate = uniform(rng) > 0.02;
    p.trace = 0.5 + uniform(rng);
    for (int id : ids) {
      if (uniform(rng) < 0.7) p.fused.push_back(id);
      if (uniform(rng) < 0.05) p.late.push_back(id);
    }
    p.diverging = uniform(rng) < 0.1;
    // Whole nanoseconds: the stamps the estimate carries.
    p.latency_ms = p.fused.empty() ? -1.0 : std::round((0.2 + 5.0 * uniform(rng) * uniform(rng)) * 1e6) * 1e-6;
  }
  RunSummaryBuilder b(scenario_with(ids));
  // Records arrive in order of k, each truth up to 3 periods before or after its estimate.
  std::vector<std::pair<double, std::function<void()>>> arrivals;
  for (std::size_t k = 0; k < periods.size(); ++k) {
    const auto& p = periods[k];
    const auto kk = static_cast<std::int64_t>(k);
    if (p.has_truth) arrivals.emplace_back(kk + 3.0 * uniform(rng), [&b, kk, &p] { b.add_truth(truth(kk, p.x)); });
    if (p.has_estimate)
      arrivals.emplace_back(kk + 3.0 * uniform(rng), [&b, kk, &p] {
        b.add_estimate(estimate(kk, p.xhat, p.trace, p.fused, p.late, p.diverging ? "diverging" : "ok", p.latency_ms));
      });
  }
  std::stable_sort(arrivals.begin(), arrivals.end(), [](const auto& a, const auto& c) { return a.first < c.first; });
  for (auto& [when, add] : arrivals) add();
  b.add_link_status(status(2, 3000, 2100, 900));
  b.add_link_status(status(5, 3000, 2000, 1000));
  b.add_link_status(status(7, 2999, 2500, 499));

  double sq = 0.0, trace = 0.0;
  std::size_t scored = 0, estimated = 0, fused = 0, late = 0, diverging = 0;
  std::map<int, std::size_t> fused_by_id, late_by_id;
  std::vector<double> latencies;
  for (const auto& p : periods) {
    if (!p.has_estimate) continue;
    ++estimated;
    trace += p.trace;
    fused += p.fused.size();
    late += p.late.size();
    diverging += p.diverging;
    for (int id : p.fused) ++fused_by_id[id];
    for (int id : p.late) ++late_by_id[id];
    if (p.latency_ms >= 0.0) latencies.push_back(p.latency_ms);
    if (p.has_truth) {
      sq += (p.x[0] - p.xhat[0]) * (p.x[0] - p.xhat[0]) + (p.x[1] - p.xhat[1]) * (p.x[1] - p.xhat[1]);
      ++scored;
    }
  }
  // The percentile by its definition: the smallest value with at least p % at or below it.
  auto percentile = [&](double p) {
    double best = std::numeric_limits<double>::infinity();
    for (double v : latencies) {
      const auto at_or_below = std::count_if(latencies.begin(), latencies.end(), [v](double w) { return w <= v; });
      if (100.0 * static_cast<double>(at_or_below) >= p * static_cast<double>(latencies.size())) best = std::min(best, v);
    }
    return best;
  };

  const RunSummary& s = b.summary();
  EXPECT_EQ(value_of(s, "periods"), static_cast<double>(estimated));
  EXPECT_NEAR(value_of(s, "rms_error"), std::sqrt(sq / static_cast<double>(scored)), 1e-12);
  EXPECT_NEAR(value_of(s, "mean_trace_P"), trace / static_cast<double>(estimated), 1e-12);
  EXPECT_DOUBLE_EQ(value_of(s, "fused_fraction"), static_cast<double>(fused) / (3.0 * static_cast<double>(estimated)));
  EXPECT_DOUBLE_EQ(value_of(s, "late_fraction"), static_cast<double>(late) / (2100.0 + 2000.0 + 2500.0));
  EXPECT_EQ(value_of(s, "periods_diverging"), static_cast<double>(diverging));
  EXPECT_NEAR(value_of(s, "pipeline_latency_p50_ms"), percentile(50.0), 1e-9);
  EXPECT_NEAR(value_of(s, "pipeline_latency_p99_ms"), percentile(99.0), 1e-9);
  for (int id : ids) {
    const std::string link = "link." + std::to_string(id) + ".";
    EXPECT_EQ(value_of(s, link + "fused"), static_cast<double>(fused_by_id[id])) << id;
    EXPECT_EQ(value_of(s, link + "late"), static_cast<double>(late_by_id[id])) << id;
  }
  EXPECT_DOUBLE_EQ(value_of(s, "link.7.observed_loss"), 499.0 / 2999.0);
  EXPECT_GT(scored, 2800u);
  EXPECT_LT(scored, estimated);
}

TEST(RunSummary, NearestRankPercentile) {
  EXPECT_TRUE(std::isnan(nearest_rank_percentile({}, 50.0)));
  EXPECT_EQ(nearest_rank_percentile({5.0}, 50.0), 5.0);
  EXPECT_EQ(nearest_rank_percentile({5.0}, 99.0), 5.0);
  EXPECT_EQ(nearest_rank_percentile({4.0, 1.0, 3.0, 2.0}, 50.0), 2.0);
  EXPECT_EQ(nearest_rank_percentile({4.0, 1.0, 3.0, 2.0}, 99.0), 4.0);
  EXPECT_EQ(nearest_rank_percentile({4.0, 1.0, 3.0}, 50.0), 3.0);  // ceil(1.5) = 2nd smallest
  std::vector<double> hundred, thousand;
  for (int i = 100; i >= 1; --i) hundred.push_back(i);
  for (int i = 1; i <= 1000; ++i) thousand.push_back(i);
  EXPECT_EQ(nearest_rank_percentile(hundred, 50.0), 50.0);
  EXPECT_EQ(nearest_rank_percentile(hundred, 99.0), 99.0);  // exactly 99 %, not the 100th
  EXPECT_EQ(nearest_rank_percentile(hundred, 100.0), 100.0);
  EXPECT_EQ(nearest_rank_percentile(thousand, 99.0), 990.0);
  EXPECT_EQ(nearest_rank_percentile(thousand, 50.0), 500.0);
}

// ---------------------------------------------------------------- evaluation

RunSummary measured_run() {
  RunSummaryBuilder b(scenario_with({1, 2}));
  b.add_truth(truth(0, {1.0, 0.0}));
  b.add_estimate(estimate(0, {0.5, 0.0}, 2.0, {1, 2}, {}, "ok", 1.5));  // rms_error 0.5
  b.add_link_status(status(1, 10, 7, 3));                              // observed loss 0.3
  return b.summary();
}

TEST(CheckEvaluation, ComparesTheMeasuredValueAtTheBoundary) {
  const RunSummary s = measured_run();
  const std::vector<int> ids{1, 2};
  const std::vector<std::pair<std::string, bool>> cases{
      {"rms_error<0.8", true},   {"rms_error<0.5", false}, {"rms_error<=0.5", true}, {"rms_error>0.5", false},
      {"rms_error>=0.5", true},  {"rms_error>0.1", true},  {"periods>=1", true},     {"periods>1", false},
      {"link.1.observed_loss<0.35", true}, {"link.1.observed_loss<0.05", false}, {"link.1.delivered>=7", true},
      {"periods_diverging<1", true}, {"fused_fraction>=1", true},
  };
  for (const auto& [text, passes] : cases) {
    const auto results = evaluate_checks({parse_check(text, ids)}, s);
    ASSERT_EQ(results.size(), 1u);
    EXPECT_EQ(results[0].passed, passes) << text << " (value " << results[0].measured.value << ")";
    EXPECT_EQ(results[0].verdict(), passes ? "PASS" : "FAIL") << text;
  }
}

TEST(CheckEvaluation, AValueThatWasNotMeasuredFailsWhateverTheComparison) {
  const RunSummary s = measured_run();  // link 2 never reported
  const std::vector<int> ids{1, 2};
  for (const char* text : {"link.2.observed_loss<1", "link.2.observed_loss>-1", "link.2.samples>=0", "late_fraction<=1",
                           "late_fraction>=0"}) {
    const auto r = evaluate_checks({parse_check(text, ids)}, s).at(0);
    EXPECT_FALSE(r.passed) << text;
    EXPECT_EQ(r.verdict(), "FAIL (not measured: the channel never reported link 2)") << text;
  }
  const RunSummary nothing = RunSummaryBuilder(scenario_with({1, 2})).summary();
  for (const char* text : {"periods_diverging<1", "rms_error<1e9", "mean_trace_P>=0", "link.1.late<=0", "fused_fraction>=0"}) {
    const auto r = evaluate_checks({parse_check(text, ids)}, nothing).at(0);
    EXPECT_FALSE(r.passed) << text;
    EXPECT_NE(r.verdict().find("FAIL (not measured: "), std::string::npos) << r.verdict();
  }
  // The count of periods is a measurement even at zero.
  EXPECT_TRUE(evaluate_checks({parse_check("periods<1", ids)}, nothing).at(0).passed);
  EXPECT_FALSE(evaluate_checks({parse_check("periods>0", ids)}, nothing).at(0).passed);
}

TEST(CheckEvaluation, TableShowsCheckValueAndVerdict) {
  const RunSummary s = measured_run();
  const std::vector<int> ids{1, 2};
  const auto results = evaluate_checks(
      {parse_check("rms_error < 0.8", ids), parse_check("link.1.observed_loss<0.05", ids),
       parse_check("link.2.observed_loss<0.5", ids), parse_check("periods>=1", ids)},
      s);
  EXPECT_FALSE(all_passed(results));
  EXPECT_TRUE(all_passed({results[0], results[3]}));
  EXPECT_TRUE(all_passed({}));
  const std::string table = render_check_table(results);
  EXPECT_EQ(table,
            "check                      value  verdict\n"
            "rms_error < 0.8            0.5    PASS\n"
            "link.1.observed_loss<0.05  0.3    FAIL\n"
            "link.2.observed_loss<0.5   n/a    FAIL (not measured: the channel never reported link 2)\n"
            "periods>=1                 1      PASS\n"
            "4 checks: 2 passed, 2 failed\n");
}

TEST(SummaryJson, EveryNameIsAPathWithItsValueOrNull) {
  const RunSummary s = measured_run();
  const std::vector<int> ids{1, 2};
  const auto results = evaluate_checks({parse_check("rms_error<0.8", ids), parse_check("link.2.late<1", ids)}, s);
  const auto j = summary_json(s, results);
  for (const auto& name : summary_names(ids)) {
    // link.ID.NAME -> j["link"]["ID"]["NAME"]
    const nlohmann::ordered_json* node = &j;
    std::size_t from = 0;
    while (true) {
      const auto dot = name.find('.', from);
      const std::string key = name.substr(from, dot == std::string::npos ? std::string::npos : dot - from);
      ASSERT_TRUE(node->contains(key)) << name;
      node = &(*node)[key];
      if (dot == std::string::npos) break;
      from = dot + 1;
    }
    const Measured m = measure(s, name);
    if (!m.measured()) {
      EXPECT_TRUE(node->is_null()) << name;
    } else if (m.count) {
      EXPECT_TRUE(node->is_number_unsigned()) << name;
      EXPECT_EQ(node->get<std::uint64_t>(), static_cast<std::uint64_t>(m.value)) << name;
    } else {
      EXPECT_EQ(node->get<double>(), m.value) << name;
    }
  }
  EXPECT_EQ(j["rms_error"].get<double>(), 0.5);
  EXPECT_TRUE(j["link"]["2"]["samples"].is_null());
  ASSERT_EQ(j["checks"].size(), 2u);
  EXPECT_EQ(j["checks"][0]["check"], "rms_error<0.8");
  EXPECT_EQ(j["checks"][0]["name"], "rms_error");
  EXPECT_EQ(j["checks"][0]["operator"], "<");
  EXPECT_EQ(j["checks"][0]["threshold"].get<double>(), 0.8);
  EXPECT_EQ(j["checks"][0]["value"].get<double>(), 0.5);
  EXPECT_EQ(j["checks"][0]["verdict"], "PASS");
  EXPECT_FALSE(j["checks"][0].contains("reason"));
  EXPECT_EQ(j["checks"][1]["value"].get<std::uint64_t>(), 0u);  // no late sample of sensor 2
  EXPECT_EQ(j["checks"][1]["verdict"], "PASS");
  EXPECT_TRUE(j["passed"].get<bool>());
  const auto failing = summary_json(s, evaluate_checks({parse_check("link.2.dropped<1", ids)}, s));
  EXPECT_TRUE(failing["checks"][0]["value"].is_null());
  EXPECT_EQ(failing["checks"][0]["verdict"], "FAIL");
  EXPECT_EQ(failing["checks"][0]["reason"], "not measured: the channel never reported link 2");
  EXPECT_FALSE(failing["passed"].get<bool>());
  // The JSON library writes NaN as null too; no value is ever NaN in the file.
  EXPECT_EQ(nlohmann::ordered_json(kNaN).dump(), "null");
}

// late_policy fuse_within: revisions change only the final error, never the in-time numbers.
// Hand computation: truths x_0 = (1, 0), x_1 = (0, 2); in time x̂_0 = (0, 0), x̂_1 = (0, 0):
// errors 1 and 4, rms_error = sqrt(5/2). Finals: k = 0 revised twice to (1, 0) (error 0), k = 1
// once to (0, 1) (error 1), and a stale revision 1 of k = 0 after revision 2 is ignored:
// rms_error_final = sqrt(1/2).
TEST(RunSummary, RevisionsScoreTheFinalErrorOnly) {
  RunSummaryBuilder b(scenario_with({1}));
  b.add_truth(truth(0, {1.0, 0.0}));
  b.add_estimate(estimate(0, {0.0, 0.0}, 2.0, {1}, {}, "ok", 1.0));
  auto rev = [](std::uint64_t k, std::uint32_t revision, std::vector<double> x) {
    Estimate e = estimate(k, x, 1.0, {1}, {}, "ok", 1.0);
    e.revision = revision;
    return e;
  };
  b.add_estimate(rev(0, 1, {0.5, 0.0}));
  b.add_estimate(estimate(1, {0.0, 0.0}, 2.0, {}, {}, "ok", -1.0));
  b.add_estimate(rev(1, 1, {0.0, 1.0}));  // before its truth
  b.add_estimate(rev(0, 2, {1.0, 0.0}));
  b.add_estimate(rev(0, 1, {9.0, 9.0}));  // older than the revision kept
  b.add_truth(truth(1, {0.0, 2.0}));
  const RunSummary& s = b.summary();
  EXPECT_EQ(s.periods, 2u);
  EXPECT_EQ(s.revisions, 4u);
  EXPECT_DOUBLE_EQ(value_of(s, "rms_error"), std::sqrt(5.0 / 2.0));
  EXPECT_DOUBLE_EQ(value_of(s, "rms_error_final"), std::sqrt(1.0 / 2.0));
  EXPECT_DOUBLE_EQ(value_of(s, "mean_trace_P"), 2.0);  // in-time estimates only
  EXPECT_EQ(value_of(s, "link.1.fused"), 1.0);
}

TEST(RunSummary, WithoutRevisionsTheFinalErrorIsTheInTimeOne) {
  RunSummaryBuilder b(scenario_with({1}));
  b.add_estimate(estimate(0, {0.5, 0.0}, 2.0, {1}, {}, "ok", 1.0));
  b.add_truth(truth(0, {1.0, 1.0}));
  b.add_truth(truth(1, {0.0, 0.0}));
  b.add_estimate(estimate(1, {0.0, 3.0}, 2.0, {1}, {}, "ok", 1.0));
  EXPECT_DOUBLE_EQ(value_of(b.summary(), "rms_error_final"), value_of(b.summary(), "rms_error"));
  EXPECT_DOUBLE_EQ(value_of(b.summary(), "rms_error"), std::sqrt((0.25 + 1.0 + 9.0) / 2.0));
}


// ---- a relay's summary and checks (relay_summary.hpp) ------------------------------------

RelayTopicSummary relayed(const std::string& topic, const std::vector<bool>& dropped, std::size_t changed_at = 0) {
  RelayTopicSummary t;
  t.topic = topic;
  for (std::size_t i = 0; i < dropped.size(); ++i) {
    t.lifetime.record(dropped[i]);
    if (i >= changed_at) t.since_change.record(dropped[i]);
  }
  return t;
}

TEST(RelayChecks, NameATopicsLinkQuantity) {
  const std::vector<std::string> topics{"rt/chatter", "a.b"};
  const Check c = parse_relay_check("link.rt/chatter.observed_loss < 0.35", topics);
  EXPECT_EQ(c.name, "link.rt/chatter.observed_loss");
  EXPECT_EQ(c.op, CheckOp::less);
  EXPECT_EQ(c.threshold, 0.35);
  EXPECT_EQ(parse_relay_check("link.a.b.samples>=10", topics).name, "link.a.b.samples") << "a topic with a dot";
  for (const auto& q : relay_quantity_names()) EXPECT_NO_THROW(parse_relay_check("link.a.b." + q + ">0", topics));
  const auto error = [&](const std::string& text) {
    try {
      parse_relay_check(text, topics);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(error("link.rt/scan.samples>1").find("topic rt/scan is not relayed (the relay's topics: rt/chatter, a.b)"),
            std::string::npos);
  EXPECT_NE(error("link.rt/chatter.late>1").find("unknown name 'link.rt/chatter.late'; a relay's names are "
                                                 "link.TOPIC.{samples, delivered, dropped, refused, observed_loss, "
                                                 "mean_burst, observed_arrival_rate_since_change}"),
            std::string::npos);
  EXPECT_NE(error("rms_error<1").find("unknown name 'rms_error'"), std::string::npos);
  EXPECT_NE(error("link.rt/chatter.samples=1").find("e.g. 'link.rt/chatter.observed_loss<0.35'"), std::string::npos);
}

TEST(RelayChecks, MeasureEachTopicsCountsByHand) {
  // Drops at 1, 2, 4, 9: 10 samples, 4 dropped, bursts {1,2} {4} {9} → mean burst 4/3; the link
  // last set before sample 5: 5 samples since, 1 dropped.
  const std::vector<bool> d{false, true, true, false, true, false, false, false, false, true};
  auto t = relayed("rt/chatter", d, 5);
  t.refused = 2;
  const std::vector<RelayTopicSummary> topics{t, relayed("rt/none", {})};
  const auto at = [&](const std::string& name) { return measure_relay(topics, name); };
  EXPECT_EQ(at("link.rt/chatter.samples").value, 10.0);
  EXPECT_TRUE(at("link.rt/chatter.samples").count);
  EXPECT_EQ(at("link.rt/chatter.delivered").value, 6.0);
  EXPECT_EQ(at("link.rt/chatter.dropped").value, 4.0);
  EXPECT_EQ(at("link.rt/chatter.refused").value, 2.0);
  EXPECT_DOUBLE_EQ(at("link.rt/chatter.observed_loss").value, 0.4);
  EXPECT_DOUBLE_EQ(at("link.rt/chatter.mean_burst").value, 4.0 / 3.0);
  EXPECT_DOUBLE_EQ(at("link.rt/chatter.observed_arrival_rate_since_change").value, 0.8);
  EXPECT_EQ(at("link.rt/none.samples").value, 0.0);
  EXPECT_FALSE(at("link.rt/none.observed_loss").measured()) << "no sample: no loss";
  EXPECT_THROW(at("link.rt/other.samples"), std::invalid_argument);

  const std::vector<Check> checks{parse_relay_check("link.rt/chatter.observed_loss<0.45", {"rt/chatter", "rt/none"}),
                                  parse_relay_check("link.rt/chatter.observed_loss<0.35", {"rt/chatter", "rt/none"}),
                                  parse_relay_check("link.rt/none.observed_loss<=1", {"rt/chatter", "rt/none"})};
  const auto results = evaluate_checks(checks, at);
  ASSERT_EQ(results.size(), 3u);
  EXPECT_TRUE(results[0].passed);
  EXPECT_FALSE(results[1].passed);
  EXPECT_FALSE(results[2].passed);
  EXPECT_EQ(results[2].verdict(), "FAIL (not measured: rt/none relayed no sample)");
  EXPECT_FALSE(all_passed(results));

  const auto j = relay_summary_json(topics, results);
  EXPECT_EQ(j["link"]["rt/chatter"]["samples"], 10);
  EXPECT_EQ(j["link"]["rt/chatter"]["observed_loss"], 0.4);
  EXPECT_TRUE(j["link"]["rt/none"]["observed_loss"].is_null());
  ASSERT_EQ(j["checks"].size(), 3u);
  EXPECT_EQ(j["checks"][1]["verdict"], "FAIL");
  EXPECT_EQ(j["checks"][1]["value"], 0.4);
  EXPECT_EQ(j["passed"], false);
}

// A per-writer topic's writers' links (TOPIC@WRITER) may be checked; one no writer made is not
// measured, so its check fails saying so (the relay ends with exit 1, not an error).
TEST(RelayChecks, AWritersLinkIsCheckedAndAMissingOneFails) {
  const std::vector<std::string> topics{"rt/scan", "rt/odom"}, per_writer{"rt/scan"};
  EXPECT_EQ(parse_relay_check("link.rt/scan@robot1.dropped<5", topics, per_writer).name, "link.rt/scan@robot1.dropped");
  try {
    parse_relay_check("link.rt/odom@robot1.dropped<5", topics, per_writer);
    ADD_FAILURE() << "rt/odom has no writers' links";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("a writer's link of a per-writer topic: TOPIC@WRITER"), std::string::npos)
        << e.what();
  }
  const std::vector<RelayTopicSummary> seen{relayed("rt/scan@robot1", {false, true, false})};
  const auto at = [&](const std::string& name) { return measure_relay(seen, name); };
  const auto results = evaluate_checks({parse_relay_check("link.rt/scan@robot1.dropped<5", topics, per_writer),
                                        parse_relay_check("link.rt/scan@robot2.dropped<5", topics, per_writer)},
                                       at);
  ASSERT_EQ(results.size(), 2u);
  EXPECT_TRUE(results[0].passed);
  EXPECT_EQ(results[0].measured.value, 1.0);
  EXPECT_FALSE(results[1].passed);
  EXPECT_EQ(results[1].verdict(), "FAIL (not measured: no writer made the link rt/scan@robot2)");
}

}  // namespace
}  // namespace netkf::cli
