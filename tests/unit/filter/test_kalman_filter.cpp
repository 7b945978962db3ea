// The intermittent multi-sensor Kalman filter against independent expectations:
// the four algebraic forms of the fused update agree on random systems; the
// NumPy reference vector (tests/data/fusion_vector.json); a textbook stacked
// Kalman filter written here; pure prediction; the algebraic Riccati equation;
// rejection of malformed samples; divergence without NaN/Inf.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_paths.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "netkf/filter/kalman_filter.hpp"
#include "netkf/support/random.hpp"

namespace {

using netkf::FilterModel;
using netkf::FilterState;
using netkf::IntermittentKalmanFilter;
using netkf::Matrix;
using netkf::ReceivedBlock;
using netkf::SampleRejection;
using netkf::SensorModel;
using netkf::SensorSample;
using netkf::Vector;
using ::testing::HasSubstr;

double max_abs_diff(const Matrix& a, const Matrix& b) { return (a - b).cwiseAbs().maxCoeff(); }

Matrix random_matrix(netkf::Rng& rng, Eigen::Index rows, Eigen::Index cols) {
  Matrix M(rows, cols);
  for (Eigen::Index i = 0; i < rows; ++i)
    for (Eigen::Index j = 0; j < cols; ++j) M(i, j) = rng.standard_normal();
  return M;
}
Vector random_vector(netkf::Rng& rng, Eigen::Index n) { return random_matrix(rng, n, 1); }
// Symmetric positive definite with eigenvalues bounded away from 0: G G' / k + c I.
Matrix random_spd(netkf::Rng& rng, Eigen::Index n, double floor = 0.1) {
  const Matrix G = random_matrix(rng, n, n);
  Matrix S = G * G.transpose() / static_cast<double>(n) + floor * Matrix::Identity(n, n);
  return 0.5 * (S + S.transpose());
}

struct RandomSystem {
  FilterModel model;
  Vector x;
  Matrix P;
  std::vector<Vector> y;
};
RandomSystem random_system(netkf::Rng& rng, int n, int sensors) {
  RandomSystem s;
  s.model.A = random_matrix(rng, n, n);
  s.model.Q = random_spd(rng, n);
  for (int i = 0; i < sensors; ++i) {
    const auto m = static_cast<Eigen::Index>(1 + rng.next_u64() % 3);
    s.model.sensors.push_back({10 + 3 * i, random_matrix(rng, m, n), random_spd(rng, m)});
    s.y.push_back(3.0 * random_vector(rng, m));
  }
  s.x = random_vector(rng, n);
  s.P = 2.0 * random_spd(rng, n);
  return s;
}

// ---- The fused update: four forms agree --------------------------------------------

TEST(FusedUpdate, AllFormsAgreeOnRandomSystems) {
  netkf::Rng rng(netkf::derive_seed(1, "test-fused-forms"));
  int compared = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + static_cast<int>(rng.next_u64() % 8);
    const int d = 1 + static_cast<int>(rng.next_u64() % 6);
    RandomSystem s = random_system(rng, n, d);
    // A random subset of sensors arrives.
    std::vector<SensorSample> samples;
    std::vector<ReceivedBlock> blocks;
    for (int i = 0; i < d; ++i) {
      if (rng.uniform() < 0.4) continue;
      const auto& sensor = s.model.sensors[static_cast<std::size_t>(i)];
      samples.push_back({sensor.id, s.y[static_cast<std::size_t>(i)]});
      blocks.push_back({&sensor.C, &sensor.R, &s.y[static_cast<std::size_t>(i)]});
    }
    const auto stacked = netkf::fused_update_stacked_inverse(s.x, s.P, blocks);
    const auto sequential = netkf::fused_update_sequential(s.x, s.P, blocks);
    const auto information = netkf::fused_update_information(s.x, s.P, blocks);
    IntermittentKalmanFilter filter(s.model, s.x, s.P);
    const auto result = filter.update(samples);
    ASSERT_EQ(result.fused_ids.size(), samples.size());
    ASSERT_TRUE(result.rejected.empty());
    for (const auto* form : {&sequential, &information}) {
      EXPECT_LT(max_abs_diff(form->x, stacked.x), 1e-10) << "trial " << trial;
      EXPECT_LT(max_abs_diff(form->P, stacked.P), 1e-10) << "trial " << trial;
    }
    EXPECT_LT(max_abs_diff(filter.x(), stacked.x), 1e-10) << "trial " << trial;
    EXPECT_LT(max_abs_diff(filter.P(), stacked.P), 1e-10) << "trial " << trial;
    EXPECT_EQ(filter.P(), filter.P().transpose());  // exactly symmetric
    compared += blocks.empty() ? 0 : 1;
  }
  EXPECT_GT(compared, 150);
}

TEST(FusedUpdate, SingularPriorAgreesWithStackedForm) {
  // Some directions of the state known exactly (rank-deficient P): the information
  // form does not exist, the production update must still match the stacked one.
  netkf::Rng rng(netkf::derive_seed(1, "test-singular-prior"));
  for (int trial = 0; trial < 50; ++trial) {
    const int n = 2 + trial % 5;
    RandomSystem s = random_system(rng, n, 3);
    if (trial % 2 == 0) {
      const Matrix G = random_matrix(rng, n, n - 1);  // rank n-1, zero pivot only up to rounding
      s.P = G * G.transpose();
      s.P = 0.5 * (s.P + s.P.transpose()).eval();
    } else {
      const auto k = static_cast<Eigen::Index>(trial % n);  // state k known exactly: exact zero pivot
      s.P.row(k).setZero();
      s.P.col(k).setZero();
    }
    std::vector<SensorSample> samples;
    std::vector<ReceivedBlock> blocks;
    for (std::size_t i = 0; i < 3; ++i) {
      samples.push_back({s.model.sensors[i].id, s.y[i]});
      blocks.push_back({&s.model.sensors[i].C, &s.model.sensors[i].R, &s.y[i]});
    }
    const auto stacked = netkf::fused_update_stacked_inverse(s.x, s.P, blocks);
    IntermittentKalmanFilter filter(s.model, s.x, s.P);
    filter.update(samples);
    EXPECT_LT(max_abs_diff(filter.x(), stacked.x), 1e-10) << "trial " << trial;
    EXPECT_LT(max_abs_diff(filter.P(), stacked.P), 1e-10) << "trial " << trial;
    // Directions with zero prior variance stay exactly known (up to rounding).
    const Eigen::SelfAdjointEigenSolver<Matrix> es(filter.P());
    EXPECT_GT(es.eigenvalues().minCoeff(), -1e-12);
  }
}

TEST(FusedUpdate, ArrivalOrderDoesNotMatter) {
  netkf::Rng rng(netkf::derive_seed(1, "test-order"));
  RandomSystem s = random_system(rng, 5, 4);
  std::vector<SensorSample> forward;
  for (std::size_t i = 0; i < 4; ++i) forward.push_back({s.model.sensors[i].id, s.y[i]});
  std::vector<SensorSample> backward(forward.rbegin(), forward.rend());
  IntermittentKalmanFilter a(s.model, s.x, s.P);
  IntermittentKalmanFilter b(s.model, s.x, s.P);
  const auto ra = a.update(forward);
  const auto rb = b.update(backward);
  EXPECT_EQ(ra.fused_ids, (std::vector<int>{10, 13, 16, 19}));
  EXPECT_EQ(ra.fused_ids, rb.fused_ids);
  EXPECT_EQ(a.x(), b.x());
  EXPECT_EQ(a.P(), b.P());
}

// ---- The NumPy reference vector ---------------------------------------------------

Matrix matrix_from_json(const nlohmann::json& j) {
  Matrix M(static_cast<Eigen::Index>(j.size()), static_cast<Eigen::Index>(j.at(0).size()));
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    for (Eigen::Index k = 0; k < M.cols(); ++k) M(i, k) = j.at(static_cast<std::size_t>(i)).at(static_cast<std::size_t>(k)).get<double>();
  return M;
}
Vector vector_from_json(const nlohmann::json& j) {
  Vector v(static_cast<Eigen::Index>(j.size()));
  for (Eigen::Index i = 0; i < v.size(); ++i) v(i) = j.at(static_cast<std::size_t>(i)).get<double>();
  return v;
}

TEST(FusedUpdate, MatchesReferenceVector) {
  std::ifstream in(netkf::test::test_data_dir() / "fusion_vector.json");
  ASSERT_TRUE(in) << "tests/data/fusion_vector.json missing";
  const auto doc = nlohmann::json::parse(in);
  const auto& tv = doc.at("test_vector");
  FilterModel model;
  model.A = matrix_from_json(tv.at("A"));
  model.Q = matrix_from_json(tv.at("Q"));
  for (std::size_t i = 0; i < tv.at("C").size(); ++i)
    model.sensors.push_back({static_cast<int>(i), matrix_from_json(tv.at("C")[i]), matrix_from_json(tv.at("R")[i])});
  const Vector x_prior = vector_from_json(tv.at("x_prior"));
  const Matrix P_prior = matrix_from_json(tv.at("P_prior"));
  std::vector<Vector> y;
  for (const auto& yi : tv.at("y")) y.push_back(vector_from_json(yi));

  auto run = [&](const std::vector<int>& received) {
    IntermittentKalmanFilter filter(model, x_prior, P_prior);
    std::vector<SensorSample> samples;
    for (const int i : received) samples.push_back({i, y[static_cast<std::size_t>(i)]});
    const auto result = filter.update(samples);
    EXPECT_EQ(result.fused_ids, received);
    return filter;
  };

  // Every subset of the three sensors (including none: the prior is returned).
  ASSERT_EQ(doc.at("all_received_sets").size(), 8u);
  for (const auto& set : doc.at("all_received_sets")) {
    const auto received = set.at("received").get<std::vector<int>>();
    const auto filter = run(received);
    EXPECT_LT(max_abs_diff(filter.x(), vector_from_json(set.at("x_post"))), 1e-10) << set.at("received").dump();
    EXPECT_LT(max_abs_diff(filter.P(), matrix_from_json(set.at("P_post"))), 1e-10) << set.at("received").dump();
  }

  // The main vector, then one prediction step.
  auto filter = run(tv.at("received").get<std::vector<int>>());
  EXPECT_LT(max_abs_diff(filter.x(), vector_from_json(tv.at("x_post"))), 1e-10);
  EXPECT_LT(max_abs_diff(filter.P(), matrix_from_json(tv.at("P_post"))), 1e-10);
  filter.predict();
  EXPECT_LT(max_abs_diff(filter.x(), vector_from_json(tv.at("x_pred_next=A x_post"))), 1e-10);
  EXPECT_LT(max_abs_diff(filter.P(), matrix_from_json(tv.at("P_pred_next=A P_post A^T + Q"))), 1e-10);
}

// ---- Special cases: all arrive, none arrive, Riccati -----------------------------

// A textbook Kalman filter (stacked C and R, standard form with an explicit inverse),
// written independently of the library as the expectation for λ = 1.
struct TextbookKalman {
  Matrix A, Q, C, R;
  Vector x;
  Matrix P;
  void update(const Vector& y) {
    const Matrix S = C * P * C.transpose() + R;
    const Matrix K = P * C.transpose() * S.inverse();
    x = x + K * (y - C * x);
    P = P - K * S * K.transpose();
  }
  void predict() {
    x = A * x;
    P = A * P * A.transpose() + Q;
  }
};

TEST(IntermittentFilter, AllArrivalsEqualPlainKalmanFilter) {
  netkf::Rng rng(netkf::derive_seed(3, "test-plain-kf"));
  for (int trial = 0; trial < 10; ++trial) {
    const int n = 2 + trial % 4;
    RandomSystem s = random_system(rng, n, 3);
    s.model.A /= 1.5 * std::sqrt(static_cast<double>(n));  // keep the run well scaled
    TextbookKalman kf{s.model.A, s.model.Q, Matrix(), Matrix(), s.x, s.P};
    Eigen::Index m = 0;
    for (const auto& sensor : s.model.sensors) m += sensor.C.rows();
    kf.C.resize(m, n);
    kf.R = Matrix::Zero(m, m);
    Eigen::Index row = 0;
    for (const auto& sensor : s.model.sensors) {
      kf.C.middleRows(row, sensor.C.rows()) = sensor.C;
      kf.R.block(row, row, sensor.C.rows(), sensor.C.rows()) = sensor.R;
      row += sensor.C.rows();
    }
    IntermittentKalmanFilter filter(s.model, s.x, s.P);
    for (int k = 0; k < 50; ++k) {
      std::vector<SensorSample> samples;
      Vector y(m);
      row = 0;
      for (const auto& sensor : s.model.sensors) {
        const Vector yi = random_vector(rng, sensor.C.rows());
        samples.push_back({sensor.id, yi});
        y.segment(row, yi.size()) = yi;
        row += yi.size();
      }
      filter.update(samples);
      kf.update(y);
      ASSERT_LT(max_abs_diff(filter.x(), kf.x), 1e-9) << "trial " << trial << " k " << k;
      ASSERT_LT(max_abs_diff(filter.P(), kf.P), 1e-9) << "trial " << trial << " k " << k;
      filter.predict();
      kf.predict();
    }
  }
}

TEST(IntermittentFilter, NoArrivalsIsPurePrediction) {
  netkf::Rng rng(netkf::derive_seed(4, "test-open-loop"));
  RandomSystem s = random_system(rng, 4, 2);
  s.model.A /= 3.0;
  IntermittentKalmanFilter filter(s.model, s.x, s.P);
  Vector x = s.x;
  Matrix P = s.P;
  for (int k = 0; k < 20; ++k) {
    const auto result = filter.update({});  // Liu-Goldsmith eq. 6: x̂_{k|k} = x̂_{k|k-1}
    EXPECT_TRUE(result.fused_ids.empty());
    ASSERT_EQ(filter.x(), x);
    ASSERT_LT(max_abs_diff(filter.P(), P), 1e-14 * std::max(1.0, P.cwiseAbs().maxCoeff()));
    filter.predict();
    x = s.model.A * x;
    P = s.model.A * P * s.model.A.transpose() + s.model.Q;
    ASSERT_LT(max_abs_diff(filter.x(), x), 1e-12);
    ASSERT_LT(max_abs_diff(filter.P(), P), 1e-12);
  }
}

TEST(IntermittentFilter, SteadyStateSolvesRiccatiEquation) {
  // λ = 1: the prediction covariance converges to the stabilising solution of
  // P = A P A' - A P C'(C P C' + R)^-1 C P A' + Q (Sinopoli eq. 17 with λ = 1).
  FilterModel model;
  model.A = (Matrix(2, 2) << 1.25, 1.0, 0.0, 0.9).finished();  // unstable, detectable
  model.Q = (Matrix(2, 2) << 1.0, 0.2, 0.2, 0.5).finished();
  model.sensors.push_back({1, (Matrix(1, 2) << 1.0, 0.0).finished(), Matrix::Constant(1, 1, 2.5)});
  model.sensors.push_back({2, (Matrix(1, 2) << 0.5, 1.0).finished(), Matrix::Constant(1, 1, 1.0)});
  IntermittentKalmanFilter filter(model, Vector::Zero(2), Matrix::Identity(2, 2));
  const std::vector<SensorSample> samples = {{1, Vector::Zero(1)}, {2, Vector::Zero(1)}};
  for (int k = 0; k < 500; ++k) {
    filter.update(samples);
    filter.predict();
  }
  const Matrix& P = filter.P();  // P_{k+1|k}
  const Matrix C = (Matrix(2, 2) << 1.0, 0.0, 0.5, 1.0).finished();
  const Matrix R = (Matrix(2, 2) << 2.5, 0.0, 0.0, 1.0).finished();
  const Matrix& A = model.A;
  const Matrix riccati = A * P * A.transpose() -
                         A * P * C.transpose() * (C * P * C.transpose() + R).inverse() * C * P * A.transpose() +
                         model.Q;
  EXPECT_LT(max_abs_diff(riccati, P), 1e-9);
  EXPECT_GT(P.trace(), 1.0);  // not trivially small
  EXPECT_EQ(filter.state(), FilterState::ok);
}

TEST(IntermittentFilter, PredictWithInput) {
  FilterModel model;
  model.A = (Matrix(2, 2) << 1.0, 0.1, 0.0, 1.0).finished();
  model.Q = Matrix::Identity(2, 2) * 0.01;
  model.B = (Matrix(2, 1) << 0.005, 0.1).finished();
  model.sensors.push_back({1, (Matrix(1, 2) << 1.0, 0.0).finished(), Matrix::Constant(1, 1, 1.0)});
  IntermittentKalmanFilter filter(model, Vector::Ones(2), Matrix::Identity(2, 2));
  const Vector u = Vector::Constant(1, 2.0);
  filter.predict(&u);
  EXPECT_LT(max_abs_diff(filter.x(), (Vector(2) << 1.1 + 0.01, 1.0 + 0.2).finished()), 1e-15);
  filter.predict();  // no input: pure A x
  EXPECT_LT(max_abs_diff(filter.x(), (Vector(2) << 1.11 + 0.12, 1.2).finished()), 1e-15);
  const Vector wrong = Vector::Ones(2);
  const Vector before = filter.x();
  EXPECT_THROW(filter.predict(&wrong), std::invalid_argument);
  const Vector nan_input = Vector::Constant(1, std::nan(""));
  EXPECT_THROW(filter.predict(&nan_input), std::invalid_argument);
  EXPECT_EQ(filter.x(), before);
}

// ---- Bad input ------------------------------------------------------------------------

TEST(IntermittentFilter, MalformedSamplesRejectedCountedStateUntouched) {
  netkf::Rng rng(netkf::derive_seed(5, "test-reject"));
  RandomSystem s = random_system(rng, 3, 3);  // ids 10, 13, 16
  const auto& sensors = s.model.sensors;
  IntermittentKalmanFilter filter(s.model, s.x, s.P);
  IntermittentKalmanFilter expected(s.model, s.x, s.P);

  const Vector bad_size = Vector::Ones(sensors[1].C.rows() + 1);
  Vector with_nan = s.y[2];
  with_nan(0) = std::nan("");
  Vector with_inf = s.y[2];
  with_inf(with_inf.size() - 1) = std::numeric_limits<double>::infinity();
  const std::vector<SensorSample> samples = {
      {10, s.y[0]},      // good
      {99, s.y[0]},      // unknown sensor
      {13, bad_size},    // wrong size
      {16, with_nan},    // non-finite
      {16, with_inf},    // non-finite
      {10, s.y[0]},      // duplicate of a fused sensor
  };
  const auto result = filter.update(samples);
  EXPECT_EQ(result.fused_ids, std::vector<int>{10});
  ASSERT_EQ(result.rejected.size(), 5u);
  EXPECT_EQ(result.rejected[0], std::make_pair(99, SampleRejection::unknown_sensor));
  EXPECT_EQ(result.rejected[1], std::make_pair(13, SampleRejection::wrong_size));
  EXPECT_EQ(result.rejected[2], std::make_pair(16, SampleRejection::non_finite));
  EXPECT_EQ(result.rejected[3], std::make_pair(16, SampleRejection::non_finite));
  EXPECT_EQ(result.rejected[4], std::make_pair(10, SampleRejection::duplicate));
  EXPECT_EQ(filter.rejections()[SampleRejection::unknown_sensor], 1u);
  EXPECT_EQ(filter.rejections()[SampleRejection::wrong_size], 1u);
  EXPECT_EQ(filter.rejections()[SampleRejection::non_finite], 2u);
  EXPECT_EQ(filter.rejections()[SampleRejection::duplicate], 1u);
  EXPECT_EQ(filter.rejections().total(), 5u);

  // The same as fusing only the good sample.
  const std::vector<SensorSample> good = {{10, s.y[0]}};
  expected.update(good);
  EXPECT_EQ(filter.x(), expected.x());
  EXPECT_EQ(filter.P(), expected.P());
  EXPECT_TRUE(filter.x().allFinite());

  // Only bad samples: the state does not change at all.
  const Vector x_before = filter.x();
  const Matrix P_before = filter.P();
  const std::vector<SensorSample> only_bad = {{16, with_nan}, {42, s.y[1]}};
  const auto r2 = filter.update(only_bad);
  EXPECT_TRUE(r2.fused_ids.empty());
  EXPECT_EQ(r2.rejected.size(), 2u);
  EXPECT_EQ(filter.x(), x_before);
  EXPECT_EQ(filter.P(), P_before);
  EXPECT_EQ(filter.rejections().total(), 7u);
  EXPECT_STREQ(netkf::to_string(SampleRejection::non_finite), "non_finite");
}

TEST(IntermittentFilter, InvalidModelThrowsNamingTheProblem) {
  FilterModel good;
  good.A = Matrix::Identity(2, 2);
  good.Q = Matrix::Identity(2, 2);
  good.sensors.push_back({1, Matrix::Ones(1, 2), Matrix::Constant(1, 1, 1.0)});
  EXPECT_NO_THROW(IntermittentKalmanFilter(good, Vector::Zero(2), Matrix::Identity(2, 2)));

  auto expect_error = [&](FilterModel m, Vector x0, Matrix P0, const std::string& what) {
    try {
      IntermittentKalmanFilter f(std::move(m), std::move(x0), std::move(P0));
      ADD_FAILURE() << "expected std::invalid_argument mentioning " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr(what));
    }
  };
  FilterModel m = good;
  m.A = Matrix::Identity(2, 3);
  expect_error(m, Vector::Zero(2), Matrix::Identity(2, 2), "A must be square");
  m = good;
  m.Q = Matrix::Identity(3, 3);
  expect_error(m, Vector::Zero(2), Matrix::Identity(2, 2), "Q must be 2x2");
  m = good;
  m.sensors[0].C = Matrix::Ones(1, 3);
  expect_error(m, Vector::Zero(2), Matrix::Identity(2, 2), "sensor 1: C");
  m = good;
  m.sensors[0].R = Matrix::Constant(1, 1, 0.0);
  expect_error(m, Vector::Zero(2), Matrix::Identity(2, 2), "sensor 1: R is not positive definite");
  m = good;
  m.sensors[0].R = Matrix::Constant(1, 1, -1.0);
  expect_error(m, Vector::Zero(2), Matrix::Identity(2, 2), "R is not positive definite");
  m = good;
  m.sensors[0].R = Matrix::Identity(2, 2);
  expect_error(m, Vector::Zero(2), Matrix::Identity(2, 2), "R must be 1x1");
  m = good;
  m.sensors.push_back(m.sensors[0]);
  expect_error(m, Vector::Zero(2), Matrix::Identity(2, 2), "duplicate sensor id 1");
  m = good;
  m.B = Matrix::Ones(3, 1);
  expect_error(m, Vector::Zero(2), Matrix::Identity(2, 2), "B must have 2 rows");
  expect_error(good, Vector::Zero(3), Matrix::Identity(2, 2), "x0 must have 2 entries");
  expect_error(good, Vector::Zero(2), -Matrix::Identity(2, 2), "P0 is not positive semidefinite");
  m = good;
  m.A(0, 1) = std::nan("");
  expect_error(m, Vector::Zero(2), Matrix::Identity(2, 2), "A has non-finite");
}

// ---- Divergence ------------------------------------------------------------------------

TEST(IntermittentFilter, DivergesWithoutNaNAndRecovers) {
  FilterModel model;
  model.A = Matrix::Constant(1, 1, 2.0);
  model.Q = Matrix::Constant(1, 1, 1.0);
  model.sensors.push_back({1, Matrix::Constant(1, 1, 1.0), Matrix::Constant(1, 1, 2.0)});
  IntermittentKalmanFilter filter(model, Vector::Constant(1, 1.0), Matrix::Constant(1, 1, 1.0));
  EXPECT_EQ(filter.state(), FilterState::ok);
  for (int k = 0; k < 5000; ++k) {
    filter.update({});
    filter.predict();
    ASSERT_TRUE(filter.x().allFinite()) << k;
    ASSERT_TRUE(filter.P().allFinite()) << k;
    ASSERT_LE(filter.P()(0, 0), 1e150) << k;
  }
  EXPECT_EQ(filter.state(), FilterState::diverging);
  EXPECT_GT(filter.trace_P(), 1e6);
  // Samples arrive again: the update is finite and the variance is about R again.
  const std::vector<SensorSample> sample = {{1, Vector::Constant(1, 3.0)}};
  filter.update(sample);
  EXPECT_TRUE(filter.x().allFinite());
  // The saturated prior is x̂ = P = 1e150 (ceiling): posterior variance
  // (1/P + 1/R)^-1 = R (to 1e-150) and mean (R x̂ + P y)/(P + R) = 2 + 3 = 5: the
  // sample is not lost to cancellation against the huge prior.
  EXPECT_NEAR(filter.P()(0, 0), 2.0, 1e-9);
  EXPECT_NEAR(filter.x()(0), 5.0, 1e-9);
  EXPECT_EQ(filter.state(), FilterState::ok);
}

TEST(IntermittentFilter, SaturationKeepsBoundedComponents) {
  // One unstable, unobserved component and one stable, observed one: after the
  // unstable variance hits the ceiling, the other component is still filtered.
  FilterModel model;
  model.A = (Matrix(2, 2) << 3.0, 0.0, 0.0, 0.5).finished();
  model.Q = Matrix::Identity(2, 2);
  model.sensors.push_back({7, (Matrix(1, 2) << 0.0, 1.0).finished(), Matrix::Constant(1, 1, 1.0)});
  netkf::FilterOptions options;
  options.divergence_trace_bound = 1e3;
  options.covariance_ceiling = 1e20;
  IntermittentKalmanFilter filter(model, Vector::Zero(2), Matrix::Identity(2, 2), options);
  const std::vector<SensorSample> sample = {{7, Vector::Constant(1, 0.5)}};
  for (int k = 0; k < 200; ++k) {
    filter.update(sample);
    filter.predict();
    ASSERT_TRUE(filter.P().allFinite());
  }
  EXPECT_EQ(filter.state(), FilterState::diverging);
  EXPECT_LE(filter.P()(0, 0), 1e20);
  EXPECT_GT(filter.P()(0, 0), 1e19);
  // Scalar steady state of the observed component: p = 0.25 p/(p + 1) + 1.
  const double p = (0.25 + std::sqrt(0.25 * 0.25 + 4.0)) / 2.0 - 0.0;  // root of p^2 - 0.25 p - 1 = 0
  EXPECT_NEAR(filter.P()(1, 1), p, 1e-9);
}

}  // namespace
