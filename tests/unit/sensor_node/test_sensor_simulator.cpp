// SensorSimulator: y = C x + v with v ~ N(0, R), one sample per period, bad truth refused.
#include <gtest/gtest.h>

#include <stdexcept>

#include "netkf/nodes/sensor_simulator.hpp"

namespace {

using netkf::Matrix;
using netkf::Vector;
using netkf::nodes::SensorSimulator;

netkf::Scenario sensor_scenario() {
  netkf::Scenario s;
  s.name = "unit-sensor";
  s.seed = 3;
  s.plant.A = Matrix::Identity(2, 2);
  s.plant.Q = Matrix::Identity(2, 2);
  netkf::SensorSpec a;
  a.id = 4;
  a.C = Matrix{{1.0, 2.0}, {0.0, 1.0}};
  a.R = Matrix{{0.5, 0.1}, {0.1, 0.2}};
  s.sensors.push_back(a);
  netkf::SensorSpec b = a;
  b.id = 5;
  s.sensors.push_back(b);
  return s;
}

TEST(SensorLogic, MeanIsCxAndNoiseCovarianceIsR) {
  const auto sc = sensor_scenario();
  SensorSimulator sensor(sc, 4);
  const Vector x{{0.7, -1.3}};
  const Vector cx = sc.sensors[0].C * x;
  const int n = 40000;
  Vector mean = Vector::Zero(2);
  Matrix cov = Matrix::Zero(2, 2);
  for (int k = 0; k < n; ++k) {
    auto y = sensor.measure(static_cast<std::uint64_t>(k), x);
    ASSERT_TRUE(y.has_value());
    const Vector v = *y - cx;
    mean += v;
    cov += v * v.transpose();
  }
  mean /= n;
  cov /= n;
  EXPECT_NEAR(mean(0), 0.0, 0.02);
  EXPECT_NEAR(mean(1), 0.0, 0.02);
  EXPECT_NEAR(cov(0, 0), 0.5, 0.02);
  EXPECT_NEAR(cov(1, 1), 0.2, 0.01);
  EXPECT_NEAR(cov(0, 1), 0.1, 0.01);
}

TEST(SensorLogic, SensorsHaveIndependentSeededStreams) {
  const auto sc = sensor_scenario();
  SensorSimulator a(sc, 4), a2(sc, 4), b(sc, 5);
  const Vector x = Vector::Zero(2);
  for (std::uint64_t k = 0; k < 10; ++k) {
    const Vector ya = *a.measure(k, x);
    EXPECT_EQ(ya, *a2.measure(k, x));
    EXPECT_NE(ya, *b.measure(k, x));
  }
}

TEST(SensorLogic, RefusesBadTruthAndRepeatedPeriods) {
  SensorSimulator sensor(sensor_scenario(), 4);
  std::string why;
  EXPECT_FALSE(sensor.measure(0, Vector::Zero(3), &why).has_value());
  EXPECT_NE(why.find("expected 2"), std::string::npos);
  EXPECT_FALSE(sensor.measure(0, Vector{{std::nan(""), 0.0}}, &why).has_value());
  EXPECT_TRUE(sensor.measure(0, Vector::Zero(2)).has_value());
  EXPECT_FALSE(sensor.measure(0, Vector::Zero(2), &why).has_value());  // duplicate truth for period 0
  EXPECT_TRUE(sensor.measure(1, Vector::Zero(2)).has_value());
  EXPECT_EQ(sensor.measured(), 2u);
  EXPECT_EQ(sensor.skipped(), 3u);
}

TEST(SensorLogic, UnknownSensorIdIsAClearError) {
  try {
    SensorSimulator s(sensor_scenario(), 9);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no sensor with id 9"), std::string::npos);
  }
}

}  // namespace
