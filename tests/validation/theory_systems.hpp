#pragma once
// The papers' example systems, written out once for the validation tests.
#include <initializer_list>
#include <vector>

#include "netkf/model/scenario.hpp"

namespace netkf::testing {

inline Matrix mat(std::initializer_list<std::initializer_list<double>> rows) {
  Matrix m(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(rows.begin()->size()));
  Eigen::Index i = 0;
  for (const auto& r : rows) {
    Eigen::Index j = 0;
    for (double v : r) m(i, j++) = v;
    ++i;
  }
  return m;
}

inline SensorSpec sensor(int id, Matrix C, Matrix R, LinkModel link = BernoulliLink{0.0}) {
  SensorSpec s;
  s.id = id;
  s.C = std::move(C);
  s.R = std::move(R);
  s.link = link;
  return s;
}

inline Scenario system(Matrix A, Matrix Q, std::vector<SensorSpec> sensors) {
  Scenario s;
  s.name = "test";
  s.seed = 7;
  s.plant.A = std::move(A);
  s.plant.Q = std::move(Q);
  const auto n = s.plant.A.rows();
  s.plant.x0 = Vector::Zero(n);
  s.plant.P0 = Matrix::Identity(n, n);
  s.sensors = std::move(sensors);
  return s;
}

// Sinopoli Sec. IV: scalar A = -1.25, C = 1, Q = 1, R = 2.5.
inline Scenario sinopoli_scalar(double arrival_rate) {
  return system(mat({{-1.25}}), mat({{1.0}}), {sensor(1, mat({{1.0}}), mat({{2.5}}), BernoulliLink{1.0 - arrival_rate})});
}

// Sinopoli Sec. IV: single unstable eigenvalue (Fig. 3).
inline Scenario sinopoli_mimo(double arrival_rate) {
  return system(mat({{1.25, 1, 0}, {0, 0.9, 7}, {0, 0, 0.6}}), 20.0 * Matrix::Identity(3, 3),
                {sensor(1, mat({{1, 0, 2}}), mat({{2.5}}), BernoulliLink{1.0 - arrival_rate})});
}

// Sinopoli Sec. IV general example (Fig. 4).
inline Scenario sinopoli_general(double arrival_rate) {
  return system(mat({{1.25, 0}, {1, 1.1}}), 20.0 * Matrix::Identity(2, 2),
                {sensor(1, mat({{1, 1}}), mat({{2.5}}), BernoulliLink{1.0 - arrival_rate})});
}

// Liu-Goldsmith Sec. VI-B: A = diag(2.5, 1.5), C1 = [1 0], C2 = [0 1].
inline Scenario liu_goldsmith_diagonal(double l1, double l2) {
  return system(mat({{2.5, 0}, {0, 1.5}}), 20.0 * Matrix::Identity(2, 2),
                {sensor(1, mat({{1, 0}}), mat({{2.5}}), BernoulliLink{1.0 - l1}),
                 sensor(2, mat({{0, 1}}), mat({{2.5}}), BernoulliLink{1.0 - l2})});
}

// Liu-Goldsmith Fig. 5: A = [[1.25,0],[1,1.1]], C1 = [1 0], C2 = [1 1].
inline Scenario liu_goldsmith_fig5(double l1, double l2) {
  return system(mat({{1.25, 0}, {1, 1.1}}), 20.0 * Matrix::Identity(2, 2),
                {sensor(1, mat({{1, 0}}), mat({{2.5}}), BernoulliLink{1.0 - l1}),
                 sensor(2, mat({{1, 1}}), mat({{2.5}}), BernoulliLink{1.0 - l2})});
}

// Liu-Goldsmith case 1: C1 = I2, C2 = [[1,0],[1,1]] (both invertible), R = 2.5 I.
inline Scenario liu_goldsmith_case1(double l1, double l2) {
  return system(mat({{1.25, 0}, {1, 1.1}}), 20.0 * Matrix::Identity(2, 2),
                {sensor(1, Matrix::Identity(2, 2), 2.5 * Matrix::Identity(2, 2), BernoulliLink{1.0 - l1}),
                 sensor(2, mat({{1, 0}, {1, 1}}), 2.5 * Matrix::Identity(2, 2), BernoulliLink{1.0 - l2})});
}

}  // namespace netkf::testing
