// late_policy fuse_within (EstimatorCore): a late sample within D periods is fused by a re-run
// from its period, published as revised estimates. Independent expectation: a batch filter in
// plain covariance form written here (stacked Kalman gain, Joseph update), run over the
// samples that had arrived, never the production's factored information form.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <tuple>
#include <vector>

#include "netkf/nodes/estimator_core.hpp"

namespace {

using netkf::Matrix;
using netkf::Vector;
using netkf::nodes::EstimatorCore;
using netkf::nodes::PeriodEstimate;
using netkf::SampleRejection;

constexpr std::int64_t kMs = 1000000;

// n = 2 with an input, three sensors (one of them two-dimensional).
netkf::Scenario late_scenario(netkf::LatePolicy policy, int D) {
  netkf::Scenario s;
  s.name = "unit-late";
  s.period_ms = 10;
  s.plant.A = Matrix{{1.05, 0.1}, {0.0, 0.97}};
  s.plant.Q = Matrix{{0.2, 0.05}, {0.05, 0.1}};
  s.plant.B = Matrix{{0.0}, {0.1}};
  netkf::ControlSpec control;
  control.gain = Matrix{{0.5, 0.8}};
  s.plant.control = control;
  s.plant.x0 = Vector{{0.3, -0.2}};
  s.plant.P0 = Matrix{{1.0, 0.2}, {0.2, 0.5}};
  auto sensor = [&](int id, Matrix C, Matrix R) {
    netkf::SensorSpec sp;
    sp.id = id;
    sp.C = std::move(C);
    sp.R = std::move(R);
    s.sensors.push_back(sp);
  };
  sensor(1, Matrix{{1.0, 0.0}}, Matrix{{0.5}});
  sensor(2, Matrix{{0.0, 1.0}}, Matrix{{0.3}});
  sensor(3, Matrix{{1.0, 1.0}, {1.0, -1.0}}, Matrix{{1.0, 0.1}, {0.1, 2.0}});
  s.estimator.deadline_ms = 8;
  s.estimator.late_policy = policy;
  if (policy == netkf::LatePolicy::fuse_within) s.estimator.max_delay_periods = D;
  return s;
}

// One delivered sample: period, sensor, value, and how many periods after its own it arrives.
struct Arrival {
  std::uint64_t k;
  int sensor;
  Vector y;
  std::uint64_t delay_periods;
};

// The batch filter: x̂_{k|k} for every period, fusing exactly the arrivals `fused` says.
// Covariance form: S = C P C' + R, K = P C' S^-1, x+ = x + K (y - C x), Joseph P+.
std::vector<std::pair<Vector, Matrix>> batch_filter(const netkf::Scenario& sc, std::uint64_t periods,
                                                    const std::vector<Vector>& inputs,
                                                    const std::vector<Arrival>& arrivals,
                                                    const std::function<bool(const Arrival&)>& fused) {
  std::vector<std::pair<Vector, Matrix>> out;
  Vector x = sc.plant.x0;
  Matrix P = sc.plant.P0;
  const auto n = x.size();
  for (std::uint64_t k = 0; k < periods; ++k) {
    if (k > 0) {
      x = sc.plant.A * x + *sc.plant.B * inputs[k - 1];
      P = sc.plant.A * P * sc.plant.A.transpose() + sc.plant.Q;
    }
    std::map<int, const Arrival*> here;  // by sensor id
    for (const auto& a : arrivals)
      if (a.k == k && fused(a)) here[a.sensor] = &a;
    if (!here.empty()) {
      Eigen::Index m = 0;
      for (const auto& [id, a] : here) m += a->y.size();
      Matrix C = Matrix::Zero(m, n), R = Matrix::Zero(m, m);
      Vector y(m);
      Eigen::Index row = 0;
      for (const auto& [id, a] : here) {
        const netkf::SensorSpec& s = *sc.find_sensor(id);
        const auto mi = s.C.rows();
        C.middleRows(row, mi) = s.C;
        R.block(row, row, mi, mi) = s.R;
        y.segment(row, mi) = a->y;
        row += mi;
      }
      const Matrix S = C * P * C.transpose() + R;
      const Matrix K = P * C.transpose() * S.inverse();
      x = x + K * (y - C * x);
      const Matrix I_KC = Matrix::Identity(n, n) - K * C;
      P = I_KC * P * I_KC.transpose() + K * R * K.transpose();
    }
    out.emplace_back(x, P);
  }
  return out;
}

void expect_close(const Vector& a, const Vector& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (Eigen::Index i = 0; i < a.size(); ++i)
    EXPECT_NEAR(a(i), b(i), 1e-12 * std::max(1.0, std::abs(b(i)))) << what << " [" << i << "]";
}
void expect_close(const Matrix& a, const Matrix& b, const std::string& what) {
  ASSERT_EQ(a.rows(), b.rows()) << what;
  for (Eigen::Index i = 0; i < a.size(); ++i)
    EXPECT_NEAR(a.data()[i], b.data()[i], 1e-12 * std::max(1.0, std::abs(b.data()[i]))) << what << " [" << i << "]";
}

// A random run: each sample lost with probability 0.3, else delayed 0 periods (in time) with
// probability 0.5 or 1..D+2 periods. Period p: tick at 10p ms; samples of earlier periods
// arrive at 10p+1..3 ms, samples of p at 10p+4..7 ms (random order within each group), the
// deadline at 10p+8 ms. So a sample `d` periods late finds period k+d open (not complete).
struct ArrivalRun {
  std::uint64_t periods = 0;
  std::vector<Vector> inputs;      // u_k applied by the plant (acknowledged in tick k+1)
  std::vector<Arrival> arrivals;   // every delivered sample
};

ArrivalRun random_run(std::mt19937_64& rng, std::uint64_t periods, int max_delay) {
  ArrivalRun run;
  run.periods = periods;
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::uniform_int_distribution<int> late_by(1, max_delay);
  for (std::uint64_t k = 0; k < periods; ++k) {
    run.inputs.push_back(Vector::Constant(1, normal(rng)));
    for (int id = 1; id <= 3; ++id) {
      if (u01(rng) < 0.3) continue;
      Vector y(id == 3 ? 2 : 1);
      for (auto& v : y) v = 2.0 * normal(rng);
      const std::uint64_t d = u01(rng) < 0.5 ? 0 : static_cast<std::uint64_t>(late_by(rng));
      run.arrivals.push_back({k, id, y, d});
    }
  }
  return run;
}

// Feeds the run to the core (revise() called after a late sample with probability
// `revise_often`, else left to the next tick/deadline); returns everything it published.
std::vector<PeriodEstimate> drive(EstimatorCore& core, const ArrivalRun& run, std::mt19937_64& rng, double revise_often,
                                  bool shuffle_all = false) {
  std::vector<PeriodEstimate> out;
  auto take = [&out](std::vector<PeriodEstimate> v) { out.insert(out.end(), v.begin(), v.end()); };
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  for (std::uint64_t p = 0; p < run.periods; ++p) {
    const std::int64_t t0 = static_cast<std::int64_t>(p) * 10 * kMs;
    take(core.on_tick(p, p > 0 ? run.inputs[p - 1] : Vector(), t0));
    std::vector<const Arrival*> late, in_time;
    for (const auto& a : run.arrivals)
      if (a.k + a.delay_periods == p) (a.delay_periods > 0 ? late : in_time).push_back(&a);
    std::shuffle(late.begin(), late.end(), rng);
    std::shuffle(in_time.begin(), in_time.end(), rng);
    std::vector<const Arrival*> order = late;
    order.insert(order.end(), in_time.begin(), in_time.end());
    if (shuffle_all) std::shuffle(order.begin(), order.end(), rng);
    std::int64_t t = t0 + kMs;
    for (const Arrival* a : order) {
      take(core.on_sample(a->sensor, a->k, a->y, t, t));
      t += 1000;
      if (a->delay_periods > 0 && u01(rng) < revise_often) take(core.revise(t));
    }
    take(core.on_deadline(t0 + 8 * kMs));
  }
  return out;
}

TEST(LateFusion, ReRunEqualsBatchFilterOverTheArrivals) {
  for (int D = 1; D <= 8; ++D) {
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
      SCOPED_TRACE("D = " + std::to_string(D) + ", seed " + std::to_string(seed));
      std::mt19937_64 rng(1000 * D + seed);
      const std::uint64_t checked = 40;  // the last D+2 periods' samples may not all have arrived
      const ArrivalRun run = random_run(rng, checked + D + 3, D + 2);
      const netkf::Scenario sc = late_scenario(netkf::LatePolicy::fuse_within, D);
      EstimatorCore core(sc);
      const auto published = drive(core, run, rng, seed % 2 ? 0.5 : 0.0);

      // Final: every delivered sample at most D periods late. In time (revision 0) for k:
      // those that had arrived by k's deadline (p + d <= k) and were at most D late.
      const auto dD = static_cast<std::uint64_t>(D);
      const auto final_batch =
          batch_filter(sc, checked, run.inputs, run.arrivals, [&](const Arrival& a) { return a.delay_periods <= dD; });
      std::map<std::uint64_t, const PeriodEstimate*> first, last;
      std::map<std::uint64_t, std::uint32_t> revisions;
      for (const auto& e : published) {
        if (e.revision == 0) {
          EXPECT_FALSE(first.contains(e.k)) << "period " << e.k << " published twice in time";
          first[e.k] = &e;
        } else {
          EXPECT_EQ(e.revision, revisions[e.k] + 1) << "period " << e.k << ": revisions count up by one";
          revisions[e.k] = e.revision;
        }
        last[e.k] = &e;
      }
      for (std::uint64_t k = 0; k < checked; ++k) {
        ASSERT_TRUE(first.contains(k)) << "period " << k;
        const auto in_time_batch = batch_filter(sc, k + 1, run.inputs, run.arrivals, [&](const Arrival& a) {
          return a.delay_periods <= dD && a.k + a.delay_periods <= k;
        });
        expect_close(first[k]->x_hat, in_time_batch[k].first, "in-time x̂ of period " + std::to_string(k));
        expect_close(first[k]->P, in_time_batch[k].second, "in-time P of period " + std::to_string(k));
        expect_close(last[k]->x_hat, final_batch[k].first, "final x̂ of period " + std::to_string(k));
        expect_close(last[k]->P, final_batch[k].second, "final P of period " + std::to_string(k));
      }
      // Beyond D the sample is late as with drop: counted, never fused.
      std::uint64_t beyond = 0, within = 0;
      for (const auto& a : run.arrivals) {
        if (a.k + a.delay_periods >= run.periods) continue;  // never arrived in the run
        if (a.delay_periods > dD) ++beyond;
        else if (a.delay_periods > 0) ++within;
      }
      EXPECT_EQ(core.late_total(), beyond);
      EXPECT_EQ(core.late_fused_total(), within);
      EXPECT_EQ(core.rejected_total(), 0u);
    }
  }
}

TEST(LateFusion, DropPolicyFusesOnlyInTimeSamplesAndPublishesNoRevision) {
  std::mt19937_64 rng(77);
  const ArrivalRun run = random_run(rng, 40, 3);
  const netkf::Scenario sc = late_scenario(netkf::LatePolicy::drop, 0);
  EstimatorCore core(sc);
  const auto published = drive(core, run, rng, 0.5);
  const auto batch =
      batch_filter(sc, run.periods, run.inputs, run.arrivals, [](const Arrival& a) { return a.delay_periods == 0; });
  ASSERT_EQ(published.size(), run.periods);
  for (const auto& e : published) {
    EXPECT_EQ(e.revision, 0u);
    expect_close(e.x_hat, batch[e.k].first, "x̂ of period " + std::to_string(e.k));
  }
  std::uint64_t late = 0;
  for (const auto& a : run.arrivals) late += a.delay_periods > 0 && a.k + a.delay_periods < run.periods;
  EXPECT_EQ(core.late_total(), late);
  EXPECT_EQ(core.late_fused_total(), 0u);
}

TEST(LateFusion, ArrivalOrderWithinAPeriodDoesNotMatter) {
  // Delays at most D - 1 periods: every delivered sample is fused whatever the order, even
  // when a period completes (and is fused) before a late sample of the same period arrives.
  const int D = 3;
  std::mt19937_64 rng(5);
  const ArrivalRun run = random_run(rng, 30, D - 1);
  const netkf::Scenario sc = late_scenario(netkf::LatePolicy::fuse_within, D);
  std::map<std::uint64_t, PeriodEstimate> reference;
  for (int trial = 0; trial < 5; ++trial) {
    EstimatorCore core(sc);
    std::map<std::uint64_t, PeriodEstimate> last;
    for (auto& e : drive(core, run, rng, 0.3, /*shuffle_all=*/true)) last[e.k] = e;
    if (trial == 0) {
      reference = last;
      continue;
    }
    for (std::uint64_t k = 0; k + D < run.periods; ++k) {
      // The same sums in the same (sensor id) order: equal to the bit.
      EXPECT_EQ(last[k].x_hat, reference[k].x_hat) << "trial " << trial << ", period " << k;
      EXPECT_EQ(last[k].P, reference[k].P) << "trial " << trial << ", period " << k;
      EXPECT_EQ(last[k].fused, reference[k].fused) << "trial " << trial << ", period " << k;
    }
  }
}

TEST(LateFusion, SampleOlderThanDIsLateAndDuplicatesAreRejected) {
  const netkf::Scenario sc = late_scenario(netkf::LatePolicy::fuse_within, 2);
  EstimatorCore core(sc);
  const Vector y1 = Vector::Constant(1, 0.4);
  for (std::uint64_t p = 0; p < 4; ++p) {
    core.on_tick(p, Vector::Zero(1), static_cast<std::int64_t>(p) * 10 * kMs);
    core.on_deadline(static_cast<std::int64_t>(p) * 10 * kMs + 8 * kMs);
  }
  // Periods 0..3 fused, next is 4: periods 2 and 3 are within D = 2, period 1 is not.
  EXPECT_TRUE(core.on_sample(1, 1, y1, 0, 40 * kMs).empty());
  EXPECT_EQ(core.late_total(), 1u);
  EXPECT_FALSE(core.revision_pending());
  EXPECT_TRUE(core.on_sample(1, 2, y1, 0, 40 * kMs).empty());
  EXPECT_EQ(core.late_fused_total(), 1u);
  EXPECT_TRUE(core.revision_pending());
  core.on_sample(1, 2, y1, 0, 40 * kMs);  // the same sensor again for period 2
  EXPECT_EQ(core.rejected(SampleRejection::duplicate), 1u);
  const auto revised = core.revise(41 * kMs);
  ASSERT_EQ(revised.size(), 2u);  // periods 2 and 3
  EXPECT_EQ(revised[0].k, 2u);
  EXPECT_EQ(revised[0].revision, 1u);
  EXPECT_EQ(revised[0].fused, std::vector<int>{1});
  EXPECT_EQ(revised[1].k, 3u);
  EXPECT_TRUE(revised[1].fused.empty());
  EXPECT_FALSE(revised[0].control.has_value());  // a revision never sends a control input
  EXPECT_TRUE(core.revise(42 * kMs).empty());
}

// A period fused before its deadline (all its samples in) does not shorten the window of the
// period D before it: that window ends at its deadline, D periods after the period's own.
TEST(LateFusion, EarlyFusionKeepsTheWindowOpenUntilTheDeadline) {
  const netkf::Scenario sc = late_scenario(netkf::LatePolicy::fuse_within, 1);
  EstimatorCore core(sc);
  const Vector y1 = Vector::Constant(1, 0.4), y2 = Vector::Constant(2, 0.1);
  core.on_tick(0, Vector::Zero(1), 0);
  core.on_deadline(8 * kMs);  // period 0 fused with nothing
  core.on_tick(1, Vector::Zero(1), 10 * kMs);
  core.on_sample(1, 1, y1, 0, 11 * kMs);
  core.on_sample(2, 1, y1, 0, 11 * kMs);
  ASSERT_EQ(core.on_sample(3, 1, y2, 0, 11 * kMs).size(), 1u);  // period 1 complete: fused at 11 ms
  EXPECT_EQ(core.last_fused_period(), 1u);
  core.on_sample(1, 0, y1, 0, 17 * kMs);  // before period 1's deadline (18 ms): fused into 0
  EXPECT_EQ(core.late_fused_total(), 1u);
  EXPECT_EQ(core.late_total(), 0u);
  core.on_sample(2, 0, y1, 0, 18 * kMs);  // at the deadline: late
  EXPECT_EQ(core.late_fused_total(), 1u);
  EXPECT_EQ(core.late_total(), 1u);
  const auto revised = core.revise(19 * kMs);
  ASSERT_EQ(revised.size(), 2u);
  EXPECT_EQ(revised[0].fused, std::vector<int>{1});
  EXPECT_EQ(revised[1].fused, (std::vector<int>{1, 2, 3}));
}

}  // namespace
