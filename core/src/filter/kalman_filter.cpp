// The intermittent multi-sensor Kalman filter (netkf/filter/kalman_filter.hpp).
//
// Model (multi-sensor paper Sec. 2; Liu-Goldsmith Sec. III):
//   x_{k+1} = A x_k + B u_k + w_k,   y_{i,k} = C_i x_k + v_{i,k},   R = blockdiag(R_i).
// The MMSE estimate given the arrivals (multi-sensor paper Thm 1, eqs. 8-9;
// Liu-Goldsmith eqs. 9-11) is the Kalman update with exactly the received rows of
// C and the matching block of R; with nothing received it is the open-loop
// prediction (Liu-Goldsmith eq. 6).
//
// Production update (IntermittentKalmanFilter::update), "factored information form":
//   Lambda = Σ_received C_i' R_i^-1 C_i,   b = Σ_received C_i' R_i^-1 (y_i - C_i x̂)
//   P = F F'                    (pivoted LDLT of the prior, D clamped at 0)
//   M = I + F' Lambda F = G G'  (Cholesky; eigenvalues of M are >= 1)
//   P+ = (F G^-T)(F G^-T)' = (P^-1 + Lambda)^-1,   x̂+ = x̂ + P+ b.
// Why this form:
//   * cost: O(n^3) once + O(n^2) per received sensor (adding its precomputed
//     Lambda_i), i.e. linear in the number of received sensors d with a smaller slope
//     than sequential Joseph updates (~6 n^2 m_i each), and no m x m stacked inverse;
//   * P+ = W W' is symmetric positive semidefinite by construction (a covariance
//     update cannot turn indefinite, unlike P - K S K'), M is never ill conditioned
//     from below, no matrix is inverted explicitly, R_i is factorised once;
//   * it needs no P^-1, so it works for a singular prior (perfectly known states)
//     and for a huge, saturated prior after a long outage.
// The textbook forms below (stacked inverse, sequential Joseph, plain information
// form) are kept as references; the tests check all four agree to 1e-10.
#include "netkf/filter/kalman_filter.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "netkf/model/scenario.hpp"

namespace netkf {

FilterModel filter_model(const Scenario& s) {
  FilterModel m;
  m.A = s.plant.A;
  m.Q = s.plant.Q;
  m.B = s.plant.B;
  for (const auto& sensor : s.sensors) m.sensors.push_back(SensorModel{sensor.id, sensor.C, sensor.R});
  return m;
}

Vector prior_mean(const Scenario& s) {
  return s.plant.x0.size() == s.plant.A.rows() ? s.plant.x0 : Vector(Vector::Zero(s.plant.A.rows()));
}

Matrix prior_covariance(const Scenario& s) {
  const auto n = s.plant.A.rows();
  return s.plant.P0.rows() == n ? s.plant.P0 : Matrix(Matrix::Identity(n, n));
}

FilterOptions filter_options(const Scenario& s) {
  FilterOptions o;
  o.divergence_trace_bound = s.estimator.divergence_trace_bound;
  return o;
}

namespace {

std::string shape(const Matrix& M) { return std::to_string(M.rows()) + "x" + std::to_string(M.cols()); }

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument("FilterModel: " + message); }

// Relative symmetry tolerance (matrices computed as A P A' differ in the last bits).
bool nearly_symmetric(const Matrix& M) {
  const double scale = std::max(1.0, M.cwiseAbs().maxCoeff());
  return (M - M.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * scale;
}

Matrix symmetric_part(const Matrix& M) { return 0.5 * (M + M.transpose()); }

void check_psd(const std::string& name, const Matrix& M, std::size_t n) {
  if (static_cast<std::size_t>(M.rows()) != n || static_cast<std::size_t>(M.cols()) != n)
    fail(name + " must be " + std::to_string(n) + "x" + std::to_string(n) + ", got " + shape(M));
  if (!M.allFinite()) fail(name + " has non-finite entries");
  if (!nearly_symmetric(M)) fail(name + " is not symmetric");
  const double scale = std::max(1.0, M.cwiseAbs().maxCoeff());
  const Eigen::SelfAdjointEigenSolver<Matrix> es(symmetric_part(M), Eigen::EigenvaluesOnly);
  if (es.eigenvalues().minCoeff() < -1e-9 * scale) fail(name + " is not positive semidefinite");
}

// Copies the lower triangle's mirror average into both halves: exact symmetry.
void symmetrise(Matrix& P) {
  for (Eigen::Index j = 0; j < P.cols(); ++j)
    for (Eigen::Index i = j + 1; i < P.rows(); ++i) {
      const double v = 0.5 * (P(i, j) + P(j, i));
      P(i, j) = v;
      P(j, i) = v;
    }
}

void check_blocks(const Vector& x, const Matrix& P, std::span<const ReceivedBlock> blocks) {
  const Eigen::Index n = x.size();
  if (P.rows() != n || P.cols() != n) throw std::invalid_argument("fused update: P must be n x n");
  for (const auto& b : blocks) {
    if (b.C == nullptr || b.R == nullptr || b.y == nullptr) throw std::invalid_argument("fused update: null block");
    const Eigen::Index m = b.C->rows();
    if (b.C->cols() != n || b.R->rows() != m || b.R->cols() != m || b.y->size() != m)
      throw std::invalid_argument("fused update: block dimensions do not match");
  }
}

}  // namespace

const char* to_string(FilterState state) { return state == FilterState::ok ? "ok" : "diverging"; }

const char* to_string(SampleRejection reason) {
  switch (reason) {
    case SampleRejection::unknown_sensor: return "unknown_sensor";
    case SampleRejection::wrong_size: return "wrong_size";
    case SampleRejection::non_finite: return "non_finite";
    case SampleRejection::duplicate: return "duplicate";
    case SampleRejection::buffer_full: return "buffer_full";
    case SampleRejection::stale_tick: return "stale_tick";
    case SampleRejection::count_: break;
  }
  return "invalid";
}

std::uint64_t RejectionCounts::total() const {
  std::uint64_t sum = 0;
  for (const auto c : by_reason) sum += c;
  return sum;
}

// ---- IntermittentKalmanFilter -------------------------------------------------------

IntermittentKalmanFilter::IntermittentKalmanFilter(FilterModel model, Vector x0, Matrix P0, FilterOptions options)
    : model_(std::move(model)), options_(options), x_(std::move(x0)), P_(std::move(P0)) {
  const Matrix& A = model_.A;
  if (A.rows() == 0 || A.rows() != A.cols()) fail("A must be square and non-empty, got " + shape(A));
  if (!A.allFinite()) fail("A has non-finite entries");
  const auto n = static_cast<std::size_t>(A.rows());
  check_psd("Q", model_.Q, n);
  model_.Q = symmetric_part(model_.Q);
  if (model_.B) {
    if (static_cast<std::size_t>(model_.B->rows()) != n || model_.B->cols() == 0)
      fail("B must have " + std::to_string(n) + " rows and at least one column, got " + shape(*model_.B));
    if (!model_.B->allFinite()) fail("B has non-finite entries");
  }
  if (static_cast<std::size_t>(x_.size()) != n)
    fail("x0 must have " + std::to_string(n) + " entries, got " + std::to_string(x_.size()));
  if (!x_.allFinite()) fail("x0 has non-finite entries");
  check_psd("P0", P_, n);
  P_ = symmetric_part(P_);
  if (!(options_.divergence_trace_bound > 0.0) || !std::isfinite(options_.divergence_trace_bound))
    fail("divergence_trace_bound must be positive and finite");
  if (!(options_.covariance_ceiling > 0.0) || !std::isfinite(options_.covariance_ceiling) ||
      options_.covariance_ceiling > 1e300)
    fail("covariance_ceiling must be positive and at most 1e300");

  terms_.reserve(model_.sensors.size());
  for (auto& sensor : model_.sensors) {
    const std::string name = "sensor " + std::to_string(sensor.id);
    const Matrix& C = sensor.C;
    if (C.rows() == 0 || static_cast<std::size_t>(C.cols()) != n)
      fail(name + ": C must be m x " + std::to_string(n) + " with m >= 1, got " + shape(C));
    if (!C.allFinite()) fail(name + ": C has non-finite entries");
    const Eigen::Index m = C.rows();
    if (sensor.R.rows() != m || sensor.R.cols() != m)
      fail(name + ": R must be " + std::to_string(m) + "x" + std::to_string(m) + " to match C, got " + shape(sensor.R));
    if (!sensor.R.allFinite()) fail(name + ": R has non-finite entries");
    if (!nearly_symmetric(sensor.R)) fail(name + ": R is not symmetric");
    sensor.R = symmetric_part(sensor.R);
    const Eigen::LLT<Matrix> llt(sensor.R);
    if (llt.info() != Eigen::Success || llt.matrixL().toDenseMatrix().diagonal().minCoeff() <= 0.0)
      fail(name + ": R is not positive definite");
    // R = L L':  G = L^-1 C,  Lambda_i = G'G = C' R^-1 C (PSD by construction),
    // H_i = C' R^-1 = G' L^-1 = (L^-T G)'.
    const Matrix G = llt.matrixL().solve(C);
    SensorTerms t;
    t.Lambda = G.transpose() * G;
    t.H = llt.matrixU().solve(G).transpose();
    terms_.push_back(std::move(t));
  }
  id_index_.reserve(model_.sensors.size());
  for (std::size_t i = 0; i < model_.sensors.size(); ++i)
    id_index_.emplace_back(model_.sensors[i].id, static_cast<int>(i));
  std::sort(id_index_.begin(), id_index_.end());
  for (std::size_t i = 1; i < id_index_.size(); ++i)
    if (id_index_[i].first == id_index_[i - 1].first) fail("duplicate sensor id " + std::to_string(id_index_[i].first));

  const auto dim = static_cast<Eigen::Index>(n);
  accepted_.reserve(model_.sensors.size());
  taken_.assign(model_.sensors.size(), -1);
  lambda_sum_.resize(dim, dim);
  info_vector_.resize(dim);
  work_x_.resize(dim);
  factor_.resize(dim, dim);
  work_a_.resize(dim, dim);
  work_b_.resize(dim, dim);
  // Size the factorisations' storage now (first update then does not allocate).
  // Not via LDLT(size) + assignment: that copies an uninitialised status field.
  ldlt_.compute(Matrix::Identity(dim, dim));
  llt_.compute(Matrix::Identity(dim, dim));
  saturate();
  refresh_state();
}

int IntermittentKalmanFilter::sensor_index(int id) const {
  const auto it = std::lower_bound(id_index_.begin(), id_index_.end(), std::pair<int, int>(id, -1));
  return it != id_index_.end() && it->first == id ? it->second : -1;
}

std::optional<SampleRejection> IntermittentKalmanFilter::check(int sensor_id, const Vector& y) const {
  return check_at(sensor_index(sensor_id), y);
}

std::optional<SampleRejection> IntermittentKalmanFilter::check_at(int s, const Vector& y) const {
  if (s < 0) return SampleRejection::unknown_sensor;
  if (y.size() != model_.sensors[static_cast<std::size_t>(s)].C.rows()) return SampleRejection::wrong_size;
  if (!y.allFinite()) return SampleRejection::non_finite;
  return std::nullopt;
}

FusedUpdateResult IntermittentKalmanFilter::update(std::span<const SensorSample> received) {
  FusedUpdateResult result;
  accept(received, result);
  if (!accepted_.empty()) fuse_accepted(received, result);
  saturate();
  refresh_state();
  return result;
}

void IntermittentKalmanFilter::accept(std::span<const SensorSample> received, FusedUpdateResult& result) {
  accepted_.clear();
  // Validate every sample before touching the state, so a bad sample cannot change
  // it. Checks in order: unknown id, wrong size, non-finite values; a further sample
  // of a sensor that already has a valid one in this call is a duplicate (the first
  // valid sample is fused).
  for (std::size_t k = 0; k < received.size(); ++k) {
    const SensorSample& sample = received[k];
    const int s = sensor_index(sample.sensor_id);
    std::optional<SampleRejection> reason = check_at(s, sample.y);
    if (!reason && taken_[static_cast<std::size_t>(s)] >= 0) reason = SampleRejection::duplicate;
    if (reason) {
      ++rejections_.by_reason[static_cast<int>(*reason)];
      result.rejected.emplace_back(sample.sensor_id, *reason);
      continue;
    }
    taken_[static_cast<std::size_t>(s)] = static_cast<int>(k);
    accepted_.push_back(s);
  }
  // Fuse in sensor-id order: the result does not depend on arrival order.
  std::sort(accepted_.begin(), accepted_.end(), [this](int a, int b) {
    return model_.sensors[static_cast<std::size_t>(a)].id < model_.sensors[static_cast<std::size_t>(b)].id;
  });
}

void IntermittentKalmanFilter::fuse_accepted(std::span<const SensorSample> received, FusedUpdateResult& result) {
  result.fused_ids.reserve(accepted_.size());
  // Information terms of the received sensors: Lambda = Σ C_i'R_i^-1 C_i,
  // h = Σ C_i'R_i^-1 y_i   (the received rows of the stacked update).
  lambda_sum_.setZero();
  info_vector_.setZero();
  for (const int s : accepted_) {
    const auto si = static_cast<std::size_t>(s);
    const SensorModel& sensor = model_.sensors[si];
    const Vector& y = received[static_cast<std::size_t>(taken_[si])].y;
    lambda_sum_ += terms_[si].Lambda;
    info_vector_.noalias() += terms_[si].H * y;
    result.fused_ids.push_back(sensor.id);
    taken_[si] = -1;
  }

  // P = F F' with F = Pi' L D^1/2 (pivoted LDLT; tiny negative pivots of a
  // semidefinite P are rounding and are clamped to 0).
  ldlt_.compute(P_);
  factor_.setIdentity();
  factor_.triangularView<Eigen::StrictlyLower>() = ldlt_.matrixLDLT().triangularView<Eigen::StrictlyLower>();
  const auto& D = ldlt_.vectorD();
  for (Eigen::Index j = 0; j < factor_.cols(); ++j) factor_.col(j) *= std::sqrt(std::max(D(j), 0.0));
  work_a_ = ldlt_.transpositionsP().transpose() * factor_;
  factor_.swap(work_a_);

  // When P is positive definite, z = F^-1 x̂ = D^-1/2 L^-1 Pi x̂ exists; it is
  // needed by the information form of the mean below.
  work_x_ = ldlt_.transpositionsP() * x_;
  ldlt_.matrixL().solveInPlace(work_x_);
  bool prior_invertible = true;
  for (Eigen::Index j = 0; j < work_x_.size(); ++j) {
    prior_invertible = prior_invertible && D(j) > 0.0;
    work_x_(j) = prior_invertible ? work_x_(j) / std::sqrt(D(j)) : 0.0;
  }
  prior_invertible = prior_invertible && work_x_.allFinite();

  // M = I + F' Lambda F = G G';  W' = G^-1 F';  P+ = W W'.
  work_a_.noalias() = lambda_sum_ * factor_;
  work_b_.noalias() = factor_.transpose() * work_a_;
  work_b_.diagonal().array() += 1.0;
  llt_.compute(work_b_);
  work_a_ = factor_.transpose();
  llt_.matrixL().solveInPlace(work_a_);
  P_.noalias() = work_a_.transpose() * work_a_;
  symmetrise(P_);
  if (prior_invertible) {
    // Information form of the mean: x̂+ = P+ (P^-1 x̂ + h) = W G^-1 (z + F' h).
    // Unlike the innovation form x̂ + P+ Σ C_i'R_i^-1 (y_i - C_i x̂) it does not
    // subtract nearly equal numbers when the prior is huge (after a long outage,
    // P ~ x̂^2 ~ ceiling): y then still counts.
    work_x_.noalias() += factor_.transpose() * info_vector_;
    llt_.matrixL().solveInPlace(work_x_);
    x_.noalias() = work_a_.transpose() * work_x_;
  } else {
    // Singular prior (some states known exactly): innovation form
    // x̂+ = x̂ + P+ b,  b = Σ C_i'R_i^-1 (y_i - C_i x̂) = h - Lambda x̂  (K = P+ C' R^-1).
    info_vector_.noalias() -= lambda_sum_ * x_;
    x_.noalias() += P_ * info_vector_;
  }
}

void IntermittentKalmanFilter::predict(const Vector* input) { predict_with(input, nullptr); }

void IntermittentKalmanFilter::predict_with(const Vector* input, const Matrix* input_covariance) {
  const bool use_input = model_.B.has_value() && input != nullptr;
  if (use_input) {
    if (input->size() != model_.B->cols())
      throw std::invalid_argument("predict: input has " + std::to_string(input->size()) + " entries, B has " +
                                  std::to_string(model_.B->cols()) + " columns");
    if (!input->allFinite()) throw std::invalid_argument("predict: input has non-finite entries");
  }
  const Matrix& A = model_.A;
  // x̂_{k+1|k} = A x̂_{k|k} + B u_k
  work_x_.noalias() = A * x_;
  if (use_input) work_x_.noalias() += *model_.B * *input;
  if (!work_x_.allFinite()) {
    // Overflow: keep the direction of A x̂ at the ceiling's magnitude (see saturate()).
    const double s = x_.cwiseAbs().maxCoeff();
    work_x_.noalias() = A * (x_ / s);
    const double m = work_x_.cwiseAbs().maxCoeff();
    if (m > 0.0) work_x_ *= options_.covariance_ceiling / m;
  }
  x_.swap(work_x_);

  // P_{k+1|k} = A P_{k|k} A' + Q
  work_b_ = P_;
  work_a_.noalias() = A * P_;
  P_.noalias() = work_a_ * A.transpose();
  P_ += model_.Q;
  if (use_input && input_covariance != nullptr) P_ += *model_.B * *input_covariance * model_.B->transpose();
  if (!P_.allFinite()) {
    // Overflow of A P A': recompute it from a scaled P and put it at the ceiling.
    work_b_ /= work_b_.cwiseAbs().maxCoeff();
    work_a_.noalias() = A * work_b_;
    P_.noalias() = work_a_ * A.transpose();
    P_ *= options_.covariance_ceiling / P_.cwiseAbs().maxCoeff();
  }
  symmetrise(P_);
  saturate();
  refresh_state();
}

void IntermittentKalmanFilter::predict(const Vector& input, const Matrix& input_covariance) {
  if (model_.B && (input_covariance.rows() != model_.B->cols() || input_covariance.cols() != model_.B->cols()))
    throw std::invalid_argument("predict: the input covariance must be " + std::to_string(model_.B->cols()) + " x " +
                                std::to_string(model_.B->cols()));
  if (!input_covariance.allFinite()) throw std::invalid_argument("predict: input covariance has non-finite entries");
  predict_with(&input, &input_covariance);
}

void IntermittentKalmanFilter::restore(const Vector& x, const Matrix& P) {
  const Eigen::Index n = x_.size();
  if (x.size() != n || P.rows() != n || P.cols() != n)
    throw std::invalid_argument("restore: expected a state of " + std::to_string(n) + " entries and a " +
                                std::to_string(n) + " x " + std::to_string(n) + " covariance");
  if (!x.allFinite() || !P.allFinite()) throw std::invalid_argument("restore: non-finite state or covariance");
  x_ = x;
  P_ = P;
  refresh_state();
}

void IntermittentKalmanFilter::saturate() {
  // Below the critical arrival rate E[P] is unbounded and P grows geometrically
  // (like α^2k) until it overflows. We keep it finite instead: every variance P_ii
  // above the ceiling is brought down to it by the congruence P <- D P D with
  // D = diag(min(1, sqrt(ceiling / P_ii))). That keeps P symmetric positive
  // semidefinite, keeps the correlations, leaves the components that are still
  // bounded untouched, and bounds every entry (|P_ij| <= sqrt(P_ii P_jj)).
  // The estimate is clamped to +-ceiling entrywise. The numbers then only mean
  // "unknown"; state() reports `diverging` (Tr P far above the trace bound).
  const double ceiling = options_.covariance_ceiling;
  const Eigen::Index n = P_.rows();
  bool scaled = false;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double d = P_(i, i) > ceiling ? std::sqrt(ceiling / P_(i, i)) : 1.0;
    work_x_(i) = d;
    scaled = scaled || d < 1.0;
  }
  if (scaled) {
    P_ = work_x_.asDiagonal() * P_ * work_x_.asDiagonal();
    symmetrise(P_);
    for (Eigen::Index i = 0; i < n; ++i)
      if (work_x_(i) < 1.0) P_(i, i) = ceiling;  // exactly, not ceiling*(1 +- eps)
  }
  x_ = x_.cwiseMax(-ceiling).cwiseMin(ceiling);
}

void IntermittentKalmanFilter::refresh_state() {
  state_ = P_.trace() > options_.divergence_trace_bound ? FilterState::diverging : FilterState::ok;
}

// ---- Reference forms ----------------------------------------------------------------

FusedPosterior fused_update_stacked_inverse(const Vector& x, const Matrix& P, std::span<const ReceivedBlock> blocks) {
  // The textbook stacked update (multi-sensor paper Thm 1 with the received rows):
  // K = P C' (C P C' + R)^-1 with an explicit inverse, P+ = (I - K C) P. O(m^3), m = Σ m_i.
  check_blocks(x, P, blocks);
  Eigen::Index m = 0;
  for (const auto& b : blocks) m += b.C->rows();
  if (m == 0) return {x, P};
  const Eigen::Index n = x.size();
  Matrix C(m, n);
  Matrix R = Matrix::Zero(m, m);
  Vector y(m);
  Eigen::Index row = 0;
  for (const auto& b : blocks) {
    const Eigen::Index mi = b.C->rows();
    C.middleRows(row, mi) = *b.C;
    R.block(row, row, mi, mi) = *b.R;
    y.segment(row, mi) = *b.y;
    row += mi;
  }
  const Matrix S = C * P * C.transpose() + R;
  const Matrix K = P * C.transpose() * S.inverse();
  FusedPosterior post;
  post.x = x + K * (y - C * x);
  post.P = (Matrix::Identity(n, n) - K * C) * P;
  symmetrise(post.P);
  return post;
}

FusedPosterior fused_update_sequential(const Vector& x, const Matrix& P, std::span<const ReceivedBlock> blocks) {
  // With block-diagonal R the sensors are conditionally independent given x, so
  // fusing them one after the other gives the stacked posterior. Each step is a
  // Joseph-form update P+ = (I - K C) P (I - K C)' + K R K' with K from a Cholesky
  // solve of the m_i x m_i innovation covariance.
  check_blocks(x, P, blocks);
  const Eigen::Index n = x.size();
  FusedPosterior post{x, P};
  for (const auto& b : blocks) {
    const Matrix& C = *b.C;
    const Matrix PCt = post.P * C.transpose();
    const Matrix S = C * PCt + *b.R;
    const Eigen::LLT<Matrix> llt(S);
    const Matrix K = llt.solve(PCt.transpose()).transpose();  // K = P C' S^-1
    post.x += K * (*b.y - C * post.x);
    const Matrix IKC = Matrix::Identity(n, n) - K * C;
    post.P = IKC * post.P * IKC.transpose() + K * *b.R * K.transpose();
    symmetrise(post.P);
  }
  return post;
}

FusedPosterior fused_update_information(const Vector& x, const Matrix& P, std::span<const ReceivedBlock> blocks) {
  // Information form: P+^-1 = P^-1 + Σ C_i' R_i^-1 C_i,
  // x̂+ = x̂ + P+ Σ C_i' R_i^-1 (y_i - C_i x̂). Needs P positive definite.
  check_blocks(x, P, blocks);
  if (blocks.empty()) return {x, P};
  const Eigen::Index n = x.size();
  const Eigen::LLT<Matrix> prior(P);
  if (prior.info() != Eigen::Success) throw std::invalid_argument("fused_update_information: P is not positive definite");
  Matrix J = prior.solve(Matrix::Identity(n, n));
  Vector b = Vector::Zero(n);
  for (const auto& blk : blocks) {
    const Eigen::LLT<Matrix> r(*blk.R);
    J += blk.C->transpose() * r.solve(*blk.C);
    b += blk.C->transpose() * r.solve(*blk.y - *blk.C * x);
  }
  symmetrise(J);
  const Eigen::LLT<Matrix> info(J);
  FusedPosterior post;
  post.P = info.solve(Matrix::Identity(n, n));
  symmetrise(post.P);
  post.x = x + post.P * b;
  return post;
}

}  // namespace netkf
