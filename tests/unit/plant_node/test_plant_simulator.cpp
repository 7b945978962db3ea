// PlantSimulator and GaussianSampler: the plant recursion x_{k+1} = A x_k + B u_k + w_k
// checked against the noise-free closed form A^k x0 (+ inputs), the bound that ends an
// uncontrolled run, input acknowledgement, and the noise covariance by sample statistics.
#include <gtest/gtest.h>

#include <cmath>

#include "netkf/nodes/plant_simulator.hpp"
#include "netkf/support/gaussian.hpp"

namespace {

using netkf::Matrix;
using netkf::Vector;
using netkf::nodes::PlantSimulator;

netkf::Scenario plant_scenario(bool noise) {
  netkf::Scenario s;
  s.name = "unit-plant";
  s.period_ms = 10;
  s.seed = 99;
  s.plant.A = Matrix{{1.1, 0.1}, {0.0, 0.95}};
  s.plant.Q = noise ? Matrix(Matrix::Identity(2, 2)) : Matrix(Matrix::Zero(2, 2));
  s.plant.x0 = Vector{{1.0, -0.5}};
  s.plant.P0 = noise ? Matrix(Matrix::Identity(2, 2)) : Matrix(Matrix::Zero(2, 2));
  return s;
}

TEST(PlantLogic, NoiseFreeRunFollowsAToTheK) {
  netkf::Scenario sc = plant_scenario(false);
  PlantSimulator plant(sc);
  Vector expect = sc.plant.x0;
  for (std::uint64_t k = 0; k < 50; ++k) {
    auto s = plant.step();
    EXPECT_EQ(s.k, k);
    EXPECT_DOUBLE_EQ(s.t, 0.01 * static_cast<double>(k));
    EXPECT_LT((s.x - expect).norm(), 1e-12 * (1 + expect.norm()));
    EXPECT_EQ(s.applied_input.size(), 0);
    expect = sc.plant.A * expect;
  }
}

TEST(PlantLogic, HoldOnLossAppliesThePreviousInput) {
  // plant.control.on_loss hold: a missing u_{k-1} is replaced by the input applied at the
  // previous step (zero before any arrived); the step still says the input was missing (ν = 0).
  netkf::Scenario sc = plant_scenario(false);
  sc.plant.B = Matrix{{0.0}, {1.0}};
  netkf::ControlSpec control;
  control.gain = Matrix{{0.1, 0.2}};
  control.on_loss = netkf::OnLoss::hold;
  sc.plant.control = control;
  PlantSimulator plant(sc);
  auto s0 = plant.step();
  auto s1 = plant.step();  // no input for period 0 yet: the held input is zero
  EXPECT_TRUE(s1.input_missing);
  EXPECT_EQ(s1.applied_input, Vector::Zero(1));
  EXPECT_LT((s1.x - sc.plant.A * s0.x).norm(), 1e-12);
  ASSERT_TRUE(plant.set_input(1, Vector{{0.7}}));
  auto s2 = plant.step();
  EXPECT_FALSE(s2.input_missing);
  EXPECT_EQ(s2.applied_input, Vector{{0.7}});
  for (int i = 0; i < 3; ++i) {  // lost three times: 0.7 each time
    const Vector before = plant.state();
    auto s = plant.step();
    EXPECT_TRUE(s.input_missing);
    EXPECT_EQ(s.applied_input, Vector{{0.7}});
    EXPECT_LT((s.x - (sc.plant.A * before + *sc.plant.B * 0.7)).norm(), 1e-12);
  }
  ASSERT_TRUE(plant.set_input(5, Vector{{-0.2}}));
  EXPECT_EQ(plant.step().applied_input, Vector{{-0.2}});
  EXPECT_EQ(plant.step().applied_input, Vector{{-0.2}});  // and that one is held next
  EXPECT_EQ(plant.missing_inputs(), 5u);
}

TEST(PlantLogic, AppliesAcknowledgesAndZeroesMissingInputs) {
  netkf::Scenario sc = plant_scenario(false);
  sc.plant.B = Matrix{{0.0}, {1.0}};
  PlantSimulator plant(sc);
  auto s0 = plant.step();
  EXPECT_EQ(s0.applied_input, Vector::Zero(1));
  ASSERT_TRUE(plant.set_input(0, Vector{{0.3}}));
  auto s1 = plant.step();
  EXPECT_LT((s1.x - (sc.plant.A * s0.x + *sc.plant.B * 0.3)).norm(), 1e-12);
  EXPECT_EQ(s1.applied_input, Vector{{0.3}});
  EXPECT_FALSE(s1.input_missing);
  // No input for period 1: zero is applied and reported.
  auto s2 = plant.step();
  EXPECT_TRUE(s2.input_missing);
  EXPECT_EQ(s2.applied_input, Vector::Zero(1));
  EXPECT_LT((s2.x - sc.plant.A * s1.x).norm(), 1e-12);
  EXPECT_EQ(plant.missing_inputs(), 1u);
  // Stale, wrong-size and non-finite inputs are refused.
  std::string why;
  EXPECT_FALSE(plant.set_input(0, Vector{{1.0}}, &why));
  EXPECT_NE(why.find("stale"), std::string::npos);
  EXPECT_FALSE(plant.set_input(5, Vector::Zero(2), &why));
  EXPECT_FALSE(plant.set_input(5, Vector{{std::nan("")}}, &why));
}

TEST(PlantLogic, UnstableUncontrolledRunHitsTheBound) {
  netkf::Scenario sc = plant_scenario(false);
  sc.plant.A = Matrix{{2.0, 0.0}, {0.0, 0.5}};
  sc.plant.state_bound = 100.0;
  PlantSimulator plant(sc);
  std::uint64_t ended_at = 0;
  for (int i = 0; i < 20; ++i) {
    auto s = plant.step();
    if (s.bound_exceeded) {
      ended_at = s.k;
      break;
    }
  }
  EXPECT_EQ(ended_at, 7u);  // 2^7 = 128 > 100 >= 2^6
}

TEST(PlantLogic, ProcessNoiseHasCovarianceQ) {
  netkf::Scenario sc = plant_scenario(true);
  sc.plant.A = Matrix::Zero(2, 2);  // x_{k+1} = w_k
  sc.plant.Q = Matrix{{4.0, 1.0}, {1.0, 2.0}};
  PlantSimulator plant(sc);
  plant.step();
  const int n = 40000;
  Matrix acc = Matrix::Zero(2, 2);
  Vector mean = Vector::Zero(2);
  for (int i = 0; i < n; ++i) {
    const Vector w = plant.step().x;
    acc += w * w.transpose();
    mean += w;
  }
  acc /= n;
  mean /= n;
  // Standard error of a sample (co)variance entry ~ sqrt((Q_ii Q_jj + Q_ij^2)/n) <= 0.03 here.
  EXPECT_NEAR(acc(0, 0), 4.0, 0.12);
  EXPECT_NEAR(acc(1, 1), 2.0, 0.06);
  EXPECT_NEAR(acc(0, 1), 1.0, 0.07);
  EXPECT_NEAR(mean(0), 0.0, 0.05);
}

TEST(PlantLogic, SameSeedSameRunDifferentSeedDifferentRun) {
  netkf::Scenario sc = plant_scenario(true);
  PlantSimulator a(sc), b(sc);
  sc.seed += 1;
  PlantSimulator c(sc);
  for (int i = 0; i < 20; ++i) {
    const auto sa = a.step(), sb = b.step(), scc = c.step();
    EXPECT_EQ(sa.x, sb.x);
    EXPECT_NE(sa.x, scc.x);
  }
}

TEST(PlantLogic, SingularCovarianceSamplesOnlyItsRange) {
  netkf::GaussianSampler g(Matrix{{1.0, 1.0}, {1.0, 1.0}}, 5);
  for (int i = 0; i < 100; ++i) {
    const Vector d = g.draw();
    EXPECT_NEAR(d(0), d(1), 1e-12);  // covariance of rank one along (1, 1)
  }
}

}  // namespace
