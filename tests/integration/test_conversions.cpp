// Wire <-> core conversions (dds/src/conversions.cpp): untrusted wire data is validated —
// wrong sizes and non-finite numbers are errors, never a crash or a NaN in the math — and
// valid data converts without loss. No participant is created here.
#include <gtest/gtest.h>

#include <limits>

#include "netkf/dds/conversions.hpp"

namespace {

namespace dds = netkf::dds;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Conversions, VectorsAndRowMajorMatrices) {
  const netkf::Matrix m{{1.0, 2.0, 3.0}, {4.0, 5.0, 6.0}};
  const auto w = dds::to_wire_row_major(m);
  EXPECT_EQ(w, (std::vector<double>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(dds::to_matrix(w, 2, 3, "m"), m);
  EXPECT_THROW(dds::to_matrix(w, 3, 3, "m"), dds::ConversionError);
  EXPECT_THROW(dds::to_vector({1.0, kNaN}, 2, "v"), dds::ConversionError);
  EXPECT_THROW(dds::to_vector({1.0, kInf}, -1, "v"), dds::ConversionError);
  EXPECT_THROW(dds::to_vector({1.0}, 2, "v"), dds::ConversionError);
  EXPECT_EQ(dds::to_vector({1.5, -2.5}, 2, "v"), (netkf::Vector{{1.5, -2.5}}));
}

TEST(Conversions, MeasurementValidation) {
  auto m = dds::make_measurement(2, 5, 10, netkf::Vector{{0.25}});
  const auto s = dds::to_sensor_sample(m, 1);
  EXPECT_EQ(s.sensor_id, 2);
  EXPECT_EQ(s.y, netkf::Vector{{0.25}});
  m.y({kNaN});
  try {
    dds::to_sensor_sample(m);
    FAIL() << "NaN accepted";
  } catch (const dds::ConversionError& e) {
    EXPECT_NE(std::string(e.what()).find("non-finite"), std::string::npos);
  }
  m.y({1.0, 2.0});
  EXPECT_THROW(dds::to_sensor_sample(m, 1), dds::ConversionError);
}

TEST(Conversions, TickAndControlInputs) {
  EXPECT_EQ(dds::tick_applied_input(dds::make_tick(1, 0.01, netkf::Vector(), false), 1).size(), 0);
  EXPECT_EQ(dds::tick_applied_input(dds::make_tick(1, 0.01, netkf::Vector{{0.5}}, false), 1), netkf::Vector{{0.5}});
  EXPECT_THROW(dds::tick_applied_input(dds::make_tick(1, 0.01, netkf::Vector{{0.5, 1.0}}, false), 1),
               dds::ConversionError);
  auto c = dds::make_control_input(3, netkf::Vector{{1.0}});
  c.u({kInf});
  EXPECT_THROW(dds::control_input_u(c, 1), dds::ConversionError);
  EXPECT_THROW(dds::truth_state(dds::make_truth(0, 0.0, netkf::Vector{{1.0}}, netkf::Vector()), 2),
               dds::ConversionError);
}

TEST(Conversions, EstimateRefusesNonFiniteAndBadShapes) {
  dds::EstimateRecord r;
  r.x_hat = netkf::Vector{{1.0, 2.0}};
  r.P = netkf::Matrix::Identity(2, 2);
  EXPECT_DOUBLE_EQ(dds::to_wire(r).trace_P(), 2.0);
  r.P(0, 1) = kNaN;
  EXPECT_THROW(dds::to_wire(r), dds::ConversionError);
  r.P = netkf::Matrix::Identity(3, 3);
  EXPECT_THROW(dds::to_wire(r), dds::ConversionError);
  r.P = netkf::Matrix::Identity(2, 2);
  r.x_hat(0) = kInf;
  EXPECT_THROW(dds::to_wire(r), dds::ConversionError);
  r.x_hat(0) = 1.0;
  auto w = dds::to_wire(r);
  w.state("exploded");
  EXPECT_THROW(dds::from_wire(w), dds::ConversionError);
  w.state("ok");
  w.P({1.0, 0.0, 0.0});
  EXPECT_THROW(dds::from_wire(w), dds::ConversionError);
}

TEST(Conversions, EstimateLateCountIsItsListOfSensors) {
  dds::EstimateRecord r;
  r.x_hat = netkf::Vector{{1.0}};
  r.P = netkf::Matrix::Identity(1, 1);
  r.late = 2;
  r.late_sensors = {2};  // one id for two late samples: inconsistent
  EXPECT_THROW(dds::to_wire(r), dds::ConversionError);
  r.late_sensors = {2, 2};  // the same sensor late twice
  auto w = dds::to_wire(r);
  EXPECT_EQ(w.late(), 2u);
  EXPECT_EQ(w.late_sensors(), (std::vector<int32_t>{2, 2}));
  EXPECT_EQ(dds::from_wire(w).late_sensors, (std::vector<int>{2, 2}));
  w.late(3);  // a sender whose count disagrees with its list
  EXPECT_THROW(dds::from_wire(w), dds::ConversionError);
}

TEST(Conversions, LinkRequestsAreValidatedWithTheParameterNamed) {
  auto c = dds::make_link_control(1, 2, netkf::GilbertElliottLink{0.1, 0.2, 0.0, 1.0});
  EXPECT_EQ(dds::to_link_model(c), netkf::LinkModel(netkf::GilbertElliottLink{0.1, 0.2, 0.0, 1.0}));
  c.r(-0.5);
  try {
    dds::to_link_model(c);
    FAIL() << "r = -0.5 accepted";
  } catch (const dds::ConversionError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("r must be a probability", 0), 0u) << e.what();
  }
  c.r(kNaN);
  EXPECT_THROW(dds::to_link_model(c), dds::ConversionError);
  c.model("bernouli");
  EXPECT_THROW(dds::to_link_model(c), dds::ConversionError);
  netkf::wire::LinkStatus s;
  dds::set_link_model(s, netkf::BernoulliLink{0.25});
  EXPECT_EQ(s.model(), "bernoulli");
  EXPECT_DOUBLE_EQ(s.stationary_loss(), 0.25);
  EXPECT_EQ(dds::link_model_of(s), netkf::LinkModel(netkf::BernoulliLink{0.25}));
}

}  // namespace
