// EstimatorCore: period fusion semantics (docs/architecture.md, "estimator_node") driven by explicit
// calls and a fake clock. Expected numbers come from the scalar Kalman recursion written
// out here by hand (information form of the fused update, Sinopoli eqs. 14-16 /
// multi-sensor paper Thm 1), independent of core's implementation.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "netkf/nodes/estimator_core.hpp"
#include "netkf/records/checkpoint.hpp"

namespace {

using netkf::Matrix;
using netkf::Vector;
using netkf::nodes::EstimatorCore;
using netkf::SampleRejection;

constexpr std::int64_t kMs = 1000000;

Matrix m1(double v) { return Matrix::Constant(1, 1, v); }
Vector v1(double v) { return Vector::Constant(1, v); }

// Scalar plant A = 1.2, Q = 1, two sensors C = 1 with R = 0.5 and R = 1, prior N(0, 1).
netkf::Scenario scalar_scenario(int sensors = 2) {
  netkf::Scenario s;
  s.name = "unit-scalar";
  s.period_ms = 10;
  s.seed = 7;
  s.plant.A = m1(1.2);
  s.plant.Q = m1(1.0);
  s.plant.x0 = v1(0.0);
  s.plant.P0 = m1(1.0);
  const double R[] = {0.5, 1.0, 2.0};
  for (int i = 0; i < sensors; ++i) {
    netkf::SensorSpec sp;
    sp.id = i + 1;
    sp.C = m1(1.0);
    sp.R = m1(R[i]);
    s.sensors.push_back(sp);
  }
  s.estimator.deadline_ms = 8;
  return s;
}

// Fused scalar update in information form: P+ = (1/P + Σ 1/R_i)^-1, x+ = P+ (x/P + Σ y_i/R_i).
struct Scalar {
  double x, P;
};
Scalar fuse(Scalar prior, std::initializer_list<std::pair<double, double>> y_and_R) {
  double info = 1.0 / prior.P;
  double weighted = prior.x / prior.P;
  for (auto [y, R] : y_and_R) {
    info += 1.0 / R;
    weighted += y / R;
  }
  return {weighted / info, 1.0 / info};
}
Scalar predict(Scalar post, double A, double Q, double Bu = 0.0) { return {A * post.x + Bu, A * A * post.P + Q}; }

TEST(EstimatorLogic, CompleteSetFusesBeforeTheDeadline) {
  EstimatorCore core(scalar_scenario());
  EXPECT_TRUE(core.on_tick(0, Vector(), 0).empty());
  EXPECT_TRUE(core.on_sample(1, 0, v1(0.8), 0, 1 * kMs).empty());
  auto out = core.on_sample(2, 0, v1(1.4), 0, 2 * kMs);
  ASSERT_EQ(out.size(), 1u);
  const Scalar expect = fuse({0.0, 1.0}, {{0.8, 0.5}, {1.4, 1.0}});
  EXPECT_EQ(out[0].k, 0u);
  EXPECT_EQ(out[0].fused, (std::vector<int>{1, 2}));
  EXPECT_NEAR(out[0].x_hat(0), expect.x, 1e-12);
  EXPECT_NEAR(out[0].P(0, 0), expect.P, 1e-12);
  EXPECT_EQ(out[0].fused_at_ns, 2 * kMs);
  EXPECT_FALSE(core.pending_deadline_ns().has_value());
  // Nothing left to fuse at the deadline: fused exactly once.
  EXPECT_TRUE(core.on_deadline(100 * kMs).empty());
}

TEST(EstimatorLogic, DeadlineFusesWhatArrived) {
  EstimatorCore core(scalar_scenario());
  core.on_tick(0, Vector(), 10 * kMs);
  ASSERT_EQ(core.pending_deadline_ns().value(), 18 * kMs);  // tick receipt + deadline_ms
  core.on_sample(1, 0, v1(0.8), 0, 11 * kMs);
  EXPECT_TRUE(core.on_deadline(17 * kMs).empty());
  auto out = core.on_deadline(18 * kMs);
  ASSERT_EQ(out.size(), 1u);
  const Scalar expect = fuse({0.0, 1.0}, {{0.8, 0.5}});
  EXPECT_EQ(out[0].fused, std::vector<int>{1});
  EXPECT_NEAR(out[0].x_hat(0), expect.x, 1e-12);
  EXPECT_NEAR(out[0].P(0, 0), expect.P, 1e-12);
}

TEST(EstimatorLogic, LateSamplesAreCountedNotFused) {
  EstimatorCore core(scalar_scenario());
  core.on_tick(0, Vector(), 0);
  core.on_sample(1, 0, v1(0.8), 0, 1 * kMs);
  auto first = core.on_deadline(8 * kMs);
  ASSERT_EQ(first.size(), 1u);
  EXPECT_EQ(first[0].late, 0u);
  // Sensor 2's sample for period 0 arrives after period 0 was fused.
  EXPECT_TRUE(core.on_sample(2, 0, v1(1.4), 0, 9 * kMs).empty());
  EXPECT_EQ(core.late_total(), 1u);
  core.on_tick(1, Vector(), 10 * kMs);
  auto second = core.on_deadline(18 * kMs);
  ASSERT_EQ(second.size(), 1u);
  EXPECT_EQ(second[0].late, 1u);
  EXPECT_EQ(second[0].late_sensors, std::vector<int>{2});
  EXPECT_EQ(second[0].late_periods, std::vector<std::uint64_t>{0});  // published with period 1, but for 0
  EXPECT_EQ(second[0].late_total, 1u);
  EXPECT_TRUE(second[0].fused.empty());
  // The late sample did not enter period 1: pure open-loop prediction of period 0's posterior.
  const Scalar p0 = fuse({0.0, 1.0}, {{0.8, 0.5}});
  const Scalar p1 = predict(p0, 1.2, 1.0);
  EXPECT_NEAR(second[0].x_hat(0), p1.x, 1e-12);
  EXPECT_NEAR(second[0].P(0, 0), p1.P, 1e-12);
}

TEST(EstimatorLogic, LateSamplesNameTheirSensorsOncePerSample) {
  // Both ways a sample becomes late: buffered for a period before the first tick seen, and
  // arriving for a period already fused. `late` is the number of ids listed, per estimate.
  EstimatorCore core(scalar_scenario());
  EXPECT_TRUE(core.on_sample(2, 3, v1(1.0), 0, 0).empty());  // no tick yet: buffered
  core.on_tick(5, Vector(), 1 * kMs);                       // period 3 can never be fused now
  core.on_sample(1, 5, v1(0.8), 0, 2 * kMs);
  auto first = core.on_sample(2, 5, v1(0.9), 0, 3 * kMs);
  ASSERT_EQ(first.size(), 1u);
  EXPECT_EQ(first[0].late_sensors, std::vector<int>{2});
  EXPECT_EQ(first[0].late_periods, std::vector<std::uint64_t>{3});
  EXPECT_EQ(first[0].late, 1u);
  // Period 5 is fused: sensor 1 twice (a duplicate of a late sample is still late), then 2.
  core.on_sample(1, 5, v1(0.8), 0, 4 * kMs);
  core.on_sample(1, 4, v1(0.8), 0, 5 * kMs);
  core.on_sample(2, 5, v1(0.8), 0, 6 * kMs);
  core.on_tick(6, Vector(), 10 * kMs);
  auto second = core.on_deadline(18 * kMs);
  ASSERT_EQ(second.size(), 1u);
  EXPECT_EQ(second[0].late_sensors, (std::vector<int>{1, 1, 2}));
  EXPECT_EQ(second[0].late_periods, (std::vector<std::uint64_t>{5, 4, 5}));  // each its own period
  EXPECT_EQ(second[0].late, 3u);
  EXPECT_EQ(second[0].late_total, 4u);
  // Nothing late since: the next estimate lists nobody.
  core.on_tick(7, Vector(), 20 * kMs);
  auto third = core.on_deadline(28 * kMs);
  ASSERT_EQ(third.size(), 1u);
  EXPECT_TRUE(third[0].late_sensors.empty());
  EXPECT_TRUE(third[0].late_periods.empty());
  EXPECT_EQ(third[0].late, 0u);
}

TEST(EstimatorLogic, FutureSamplesWaitForTheirTick) {
  EstimatorCore core(scalar_scenario());
  core.on_tick(0, Vector(), 0);
  // Both samples of period 1 arrive while period 0 is still open.
  EXPECT_TRUE(core.on_sample(1, 1, v1(2.0), 0, 1 * kMs).empty());
  EXPECT_TRUE(core.on_sample(2, 1, v1(2.2), 0, 2 * kMs).empty());
  EXPECT_EQ(core.buffered_samples(), 2u);
  // Tick 1 closes period 0 (nothing arrived) and period 1 is complete on opening.
  auto out = core.on_tick(1, Vector(), 5 * kMs);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].k, 0u);
  EXPECT_TRUE(out[0].fused.empty());
  EXPECT_EQ(out[1].k, 1u);
  EXPECT_EQ(out[1].fused, (std::vector<int>{1, 2}));
  const Scalar expect = fuse(predict({0.0, 1.0}, 1.2, 1.0), {{2.0, 0.5}, {2.2, 1.0}});
  EXPECT_NEAR(out[1].x_hat(0), expect.x, 1e-12);
  EXPECT_NEAR(out[1].P(0, 0), expect.P, 1e-12);
  EXPECT_EQ(core.buffered_samples(), 0u);
}

TEST(EstimatorLogic, FarFutureSamplesAreBoundedAndRejected) {
  EstimatorCore core(scalar_scenario());
  core.on_tick(0, Vector(), 0);
  core.on_sample(1, EstimatorCore::kMaxFuturePeriods + 5, v1(1.0), 0, 1);
  EXPECT_EQ(core.rejected(SampleRejection::buffer_full), 1u);
  EXPECT_EQ(core.buffered_samples(), 0u);
}

TEST(EstimatorLogic, InvalidSamplesAreRejectedAndCounted) {
  EstimatorCore core(scalar_scenario());
  core.on_tick(0, Vector(), 0);
  core.on_sample(9, 0, v1(1.0), 0, 1);                                      // unknown sensor
  core.on_sample(1, 0, Vector::Zero(2), 0, 1);                              // wrong size
  core.on_sample(1, 0, v1(std::numeric_limits<double>::quiet_NaN()), 0, 1);  // NaN
  core.on_sample(1, 0, v1(0.8), 0, 1);
  core.on_sample(1, 0, v1(5.0), 0, 1);  // duplicate: the first one stays
  EXPECT_EQ(core.rejected(SampleRejection::unknown_sensor), 1u);
  EXPECT_EQ(core.rejected(SampleRejection::wrong_size), 1u);
  EXPECT_EQ(core.rejected(SampleRejection::non_finite), 1u);
  EXPECT_EQ(core.rejected(SampleRejection::duplicate), 1u);
  auto out = core.on_deadline(8 * kMs);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].rejected_total, 4u);
  const Scalar expect = fuse({0.0, 1.0}, {{0.8, 0.5}});
  EXPECT_NEAR(out[0].x_hat(0), expect.x, 1e-12);
  EXPECT_TRUE(out[0].x_hat.allFinite());
}

TEST(EstimatorLogic, PeriodWithNothingDeliveredAdvancesOpenLoop) {
  EstimatorCore core(scalar_scenario());
  Scalar s{0.0, 1.0};
  for (std::uint64_t k = 0; k < 5; ++k) {
    const std::int64_t t0 = static_cast<std::int64_t>(k) * 10 * kMs;
    core.on_tick(k, Vector(), t0);
    auto out = core.on_deadline(t0 + 8 * kMs);
    ASSERT_EQ(out.size(), 1u);
    if (k > 0) s = predict(s, 1.2, 1.0);
    EXPECT_EQ(out[0].k, k);
    EXPECT_TRUE(out[0].fused.empty());
    EXPECT_NEAR(out[0].P(0, 0), s.P, 1e-9 * s.P);
  }
}

TEST(EstimatorLogic, LostTicksStillGiveEveryPeriodAnEstimate) {
  EstimatorCore core(scalar_scenario());
  core.on_tick(0, Vector(), 0);
  core.on_sample(1, 0, v1(0.8), 0, 1);
  core.on_sample(2, 0, v1(1.4), 0, 2);
  // Tick 1 is lost; sensor 1's sample for period 1 arrived and is fused with the inferred period.
  core.on_sample(1, 1, v1(1.1), 0, 12 * kMs);
  auto out = core.on_tick(2, Vector(), 20 * kMs);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].k, 1u);
  EXPECT_TRUE(out[0].skipped_tick);
  EXPECT_EQ(out[0].fused, std::vector<int>{1});
  const Scalar p0 = fuse({0.0, 1.0}, {{0.8, 0.5}, {1.4, 1.0}});
  const Scalar p1 = fuse(predict(p0, 1.2, 1.0), {{1.1, 0.5}});
  EXPECT_NEAR(out[0].x_hat(0), p1.x, 1e-12);
  EXPECT_NEAR(out[0].P(0, 0), p1.P, 1e-12);
  EXPECT_EQ(core.open_period().value(), 2u);
}

TEST(EstimatorLogic, StaleOrDuplicateTicksAreIgnored) {
  EstimatorCore core(scalar_scenario());
  core.on_tick(0, Vector(), 0);
  EXPECT_TRUE(core.on_tick(0, Vector(), 1).empty());
  core.on_deadline(8 * kMs);
  EXPECT_TRUE(core.on_tick(0, Vector(), 9 * kMs).empty());
  EXPECT_EQ(core.rejected(SampleRejection::stale_tick), 2u);
}

TEST(EstimatorLogic, KilledSensorLeavesDeadlineFusionRunning) {
  // Sensor 2 dies after period 9: every later period is fused at the deadline with sensor 1
  // alone, and P follows the one-sensor Riccati recursion (written out here).
  EstimatorCore core(scalar_scenario());
  Scalar s{0.0, 1.0};
  for (std::uint64_t k = 0; k < 200; ++k) {
    const std::int64_t t0 = static_cast<std::int64_t>(k) * 10 * kMs;
    core.on_tick(k, Vector(), t0);
    if (k > 0) s = predict(s, 1.2, 1.0);
    core.on_sample(1, k, v1(0.5), 0, t0 + 1 * kMs);
    std::vector<netkf::nodes::PeriodEstimate> out;
    if (k < 10) {
      out = core.on_sample(2, k, v1(0.5), 0, t0 + 2 * kMs);
      s = fuse(s, {{0.5, 0.5}, {0.5, 1.0}});
    } else {
      out = core.on_deadline(t0 + 8 * kMs);
      s = fuse(s, {{0.5, 0.5}});
    }
    ASSERT_EQ(out.size(), 1u) << "period " << k;
    EXPECT_EQ(out[0].fused.size(), k < 10 ? 2u : 1u);
    EXPECT_NEAR(out[0].P(0, 0), s.P, 1e-9);
    EXPECT_NEAR(out[0].x_hat(0), s.x, 1e-9);
  }
}

TEST(EstimatorLogic, ClosedLoopSendsMinusLxAndPredictsWithTheAcknowledgedInput) {
  netkf::Scenario sc = scalar_scenario();
  sc.plant.B = m1(1.0);
  netkf::ControlSpec control;
  control.gain = m1(0.9);
  sc.plant.control = control;
  EstimatorCore core(sc);
  core.on_tick(0, v1(0.0), 0);
  core.on_sample(1, 0, v1(0.8), 0, 1);
  auto out = core.on_sample(2, 0, v1(1.4), 0, 2);
  ASSERT_EQ(out.size(), 1u);
  ASSERT_TRUE(out[0].control.has_value());
  const Scalar p0 = fuse({0.0, 1.0}, {{0.8, 0.5}, {1.4, 1.0}});
  EXPECT_NEAR((*out[0].control)(0), -0.9 * p0.x, 1e-12);
  // The plant acknowledges it applied u_0 = 0.25 (not what we sent): predict with that.
  core.on_tick(1, v1(0.25), 10 * kMs);
  auto out1 = core.on_deadline(18 * kMs);
  ASSERT_EQ(out1.size(), 1u);
  const Scalar p1 = predict(p0, 1.2, 1.0, 0.25);
  EXPECT_NEAR(out1[0].x_hat(0), p1.x, 1e-12);
  EXPECT_NEAR((*out1[0].control)(0), -0.9 * p1.x, 1e-12);
}

TEST(EstimatorLogic, UnacknowledgedInputsArePredictedWithTheirExpectation) {
  // UDP-like actuation link (plant.control.acknowledged false), inputs arriving with ν̄ = 0.7:
  // the tick's applied input is not used. Zero on loss (Schenato et al. 2007, Sec. VI):
  // x̂_{1|0} = a x̂_0 + ν̄ b u_0, P_{1|0} = a² P_0 + q + ν̄(1 − ν̄) b² u_0². Hold: the applied
  // input's mean m_k = ν̄ u_k + (1 − ν̄) m_{k−1} and second moment s_k = ν̄ u_k² + (1 − ν̄) s_{k−1},
  // the spread s_k − m_k² added as process noise.
  for (netkf::OnLoss on_loss : {netkf::OnLoss::zero, netkf::OnLoss::hold}) {
    netkf::Scenario sc = scalar_scenario();
    sc.plant.B = m1(1.0);
    netkf::ControlSpec control;
    control.gain = m1(0.9);
    control.link = netkf::LinkSpec(netkf::BernoulliLink{0.3});
    control.acknowledged = false;
    control.on_loss = on_loss;
    sc.plant.control = control;
    EstimatorCore core(sc);
    const double nu = 0.7;
    core.on_tick(0, v1(0.0), 0);
    core.on_sample(1, 0, v1(0.8), 0, 1);
    auto out0 = core.on_sample(2, 0, v1(1.4), 0, 2);
    ASSERT_EQ(out0.size(), 1u);
    const Scalar p0 = fuse({0.0, 1.0}, {{0.8, 0.5}, {1.4, 1.0}});
    const double u0 = -0.9 * p0.x;
    EXPECT_NEAR((*out0[0].control)(0), u0, 1e-12);
    core.on_tick(1, v1(123.0), 10 * kMs);  // what the tick says is not used
    auto out1 = core.on_deadline(18 * kMs);
    ASSERT_EQ(out1.size(), 1u);
    double m = nu * u0, second = nu * u0 * u0;  // m_{-1} = s_{-1} = 0 for both
    EXPECT_NEAR(out1[0].x_hat(0), 1.2 * p0.x + m, 1e-12) << netkf::to_string(on_loss);
    EXPECT_NEAR(out1[0].P(0, 0), 1.44 * p0.P + 1.0 + (second - m * m), 1e-12) << netkf::to_string(on_loss);
    // One more period: here the two actuators differ.
    const Scalar p1{out1[0].x_hat(0), out1[0].P(0, 0)};
    const double u1 = -0.9 * p1.x;
    core.on_tick(2, v1(-55.0), 20 * kMs);
    auto out2 = core.on_deadline(28 * kMs);
    ASSERT_EQ(out2.size(), 1u);
    const bool hold = on_loss == netkf::OnLoss::hold;
    m = nu * u1 + (1.0 - nu) * (hold ? m : 0.0);
    second = nu * u1 * u1 + (1.0 - nu) * (hold ? second : 0.0);
    EXPECT_NEAR(out2[0].x_hat(0), 1.2 * p1.x + m, 1e-12) << netkf::to_string(on_loss);
    EXPECT_NEAR(out2[0].P(0, 0), 1.44 * p1.P + 1.0 + (second - m * m), 1e-12) << netkf::to_string(on_loss);
  }
}

TEST(EstimatorLogic, BelowCriticalRateReportsDivergingAndStaysFinite) {
  netkf::Scenario sc = scalar_scenario(1);
  sc.plant.A = m1(2.0);
  sc.estimator.divergence_trace_bound = 1e6;
  EstimatorCore core(sc);
  bool diverging = false;
  for (std::uint64_t k = 0; k < 2000; ++k) {  // nothing ever arrives: P grows like 4^k
    const std::int64_t t0 = static_cast<std::int64_t>(k) * 10 * kMs;
    core.on_tick(k, Vector(), t0);
    auto out = core.on_deadline(t0 + 8 * kMs);
    ASSERT_EQ(out.size(), 1u);
    ASSERT_TRUE(out[0].x_hat.allFinite());
    ASSERT_TRUE(out[0].P.allFinite()) << "period " << k;
    diverging = out[0].state == netkf::FilterState::diverging;
  }
  EXPECT_TRUE(diverging);
}

}  // namespace

namespace {

/// The last estimate a previous life published (what a restarted estimator resumes from).
netkf::Estimate last_published(std::uint64_t k, double t, Vector x_hat, Matrix P, std::uint32_t restarts,
                               std::uint64_t late_total, std::uint64_t rejected_total) {
  netkf::Estimate e;
  e.k = k;
  e.t = t;
  e.x_hat = std::move(x_hat);
  e.P = std::move(P);
  e.restarts = restarts;
  e.late_total = late_total;
  e.rejected_total = rejected_total;
  return e;
}

// A restart: the estimator resumes after period 4 from x̂ = 0.7, P = 0.3 (its last estimate),
// ignores the replayed ticks up to 4, predicts 5 with the input acknowledged in tick 5 and
// fuses the periods it missed with nothing; the counters continue.
TEST(EstimatorLogic, ResumeContinuesFromTheCheckpointWithTheAcknowledgedInputs) {
  netkf::Scenario sc = scalar_scenario();
  sc.plant.B = m1(1.0);
  netkf::ControlSpec control;
  control.gain = m1(0.9);
  sc.plant.control = control;
  EstimatorCore core(sc);
  core.resume(last_published(4, 0.04, v1(0.7), m1(0.3), 1, 11, 5));  // its first life published restart 1
  EXPECT_EQ(core.rejected_total(), 5u);
  EXPECT_EQ(core.late_total(), 11u);
  // The tick history replays periods already fused: ignored, not counted as stale.
  for (std::uint64_t k = 2; k <= 4; ++k) EXPECT_TRUE(core.on_tick(k, v1(9.0), 0).empty());
  EXPECT_EQ(core.rejected(SampleRejection::stale_tick), 0u);
  EXPECT_TRUE(core.on_tick(5, v1(0.25), 0).empty());
  auto out = core.on_tick(6, v1(-0.5), 1 * kMs);  // closes 5 with nothing
  ASSERT_EQ(out.size(), 1u);
  const Scalar p5 = predict({0.7, 0.3}, 1.2, 1.0, 0.25);
  EXPECT_EQ(out[0].k, 5u);
  EXPECT_TRUE(out[0].fused.empty());
  EXPECT_NEAR(out[0].x_hat(0), p5.x, 1e-12);
  EXPECT_NEAR(out[0].P(0, 0), p5.P, 1e-12);
  EXPECT_EQ(out[0].restarts, 2u);  // one more than the estimate it resumed from
  EXPECT_EQ(out[0].late_total, 11u);
  EXPECT_EQ(out[0].rejected_total, 5u);
  core.on_sample(1, 6, v1(0.8), 0, 2 * kMs);
  auto out6 = core.on_sample(2, 6, v1(1.4), 0, 3 * kMs);
  ASSERT_EQ(out6.size(), 1u);
  const Scalar p6 = fuse(predict(p5, 1.2, 1.0, -0.5), {{0.8, 0.5}, {1.4, 1.0}});
  EXPECT_NEAR(out6[0].x_hat(0), p6.x, 1e-12);
  EXPECT_NEAR(out6[0].P(0, 0), p6.P, 1e-12);
  EXPECT_NEAR((*out6[0].control)(0), -0.9 * p6.x, 1e-12);
}

TEST(EstimatorLogic, ResumeRefusesACheckpointThatDoesNotFit) {
  EstimatorCore core(scalar_scenario());
  EXPECT_THROW(core.resume(last_published(4, 0.04, Vector::Zero(2), Matrix::Identity(2, 2), 0, 0, 0)), std::invalid_argument);
  EXPECT_THROW(core.resume(last_published(4, 0.04, v1(std::nan("")), m1(1.0), 0, 0, 0)), std::invalid_argument);
  EstimatorCore started(scalar_scenario());
  started.on_tick(0, Vector(), 0);
  EXPECT_THROW(started.resume(last_published(4, 0.04, v1(0.0), m1(1.0), 0, 0, 0)), std::invalid_argument);
}

TEST(EstimatorLogic, CheckpointFileRoundTripsBitIdentical) {
  const netkf::Estimate c = last_published(123456789012ull, 1234.5678, Vector{{0.1, -1.0 / 3.0}},
                                           Matrix{{2.0 / 3.0, 1e-300}, {1e-300, 5.0e7 / 7.0}}, 3, 42, 7);
  const std::string path = ::testing::TempDir() + "netkf-checkpoint.json";
  netkf::write_checkpoint(path, c);
  const auto back = netkf::read_checkpoint(path);
  EXPECT_EQ(back.k, c.k);
  EXPECT_EQ(back.t, c.t);
  EXPECT_EQ(back.x_hat, c.x_hat);  // exactly: a restart must not perturb the estimate
  EXPECT_EQ(back.P, c.P);
  EXPECT_EQ(back.restarts, 3u);
  EXPECT_EQ(back.late_total, 42u);
  EXPECT_EQ(back.rejected_total, 7u);
  {
    std::ofstream bad(path);
    bad << R"({"k": 1, "t": 0, "x_hat": [1, 2], "P": [1, 0, 0], "restarts": 1, "late_total": 0, "rejected_total": 0})";
  }
  EXPECT_THROW(netkf::read_checkpoint(path), std::runtime_error);
  EXPECT_THROW(netkf::read_checkpoint(path + ".missing"), std::runtime_error);
}

}  // namespace
