#pragma once
// The intermittent multi-sensor Kalman filter (MMSE recursion): predict, then a
// fused update with exactly the sensors whose samples arrived.
// Multi-sensor paper Thm 1 (eqs. 8-9); Liu-Goldsmith eqs. 9-11; Sinopoli eqs. 14-16.
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>
#include <utility>

#include "netkf/support/types.hpp"

namespace netkf {

struct SensorModel {
  int id = 0;
  Matrix C;  // C_i
  Matrix R;  // R_i
};

/// One sensor's sample for the period being fused.
struct SensorSample {
  int sensor_id = 0;
  Vector y;
};

enum class FilterState { ok, diverging };
const char* to_string(FilterState state);

/// Why a sample was not fused: the one list of reasons of the filter and the estimator (the
/// filter judges the first four; the estimator's period logic adds the last two).
enum class SampleRejection : int {
  unknown_sensor = 0,
  wrong_size,
  non_finite,
  duplicate,    // same sensor twice in one fused update (or one period)
  buffer_full,  // a sample for a period too far ahead to be buffered
  stale_tick,   // a tick for a period already opened (duplicate or reordered)
  count_
};
const char* to_string(SampleRejection reason);

struct RejectionCounts {
  std::array<std::uint64_t, static_cast<int>(SampleRejection::count_)> by_reason{};
  std::uint64_t total() const;
  std::uint64_t operator[](SampleRejection r) const { return by_reason[static_cast<int>(r)]; }
};

/// Result of one fused update.
struct FusedUpdateResult {
  std::vector<int> fused_ids;              // sensors whose samples were used (sorted)
  std::vector<std::pair<int, SampleRejection>> rejected;
};

struct FilterOptions {
  /// Tr P above this marks the filter `diverging` (arrival rate below critical).
  double divergence_trace_bound = 1e6;
  /// P is clamped (scaled) so its entries never exceed this; keeps everything finite.
  double covariance_ceiling = 1e150;
};

/// Validated system model the filter runs on.
struct FilterModel {
  Matrix A;                     // n x n
  Matrix Q;                     // n x n
  std::optional<Matrix> B;      // n x p (closed loop)
  std::vector<SensorModel> sensors;
};

struct Scenario;
/// The filter of a scenario as the estimator runs it: the plant's A, Q, B and each sensor's C, R.
FilterModel filter_model(const Scenario& scenario);
/// The scenario's prior x̂_{0|-1}: plant.x0, zeros when not given.
Vector prior_mean(const Scenario& scenario);
/// The scenario's prior P_{0|-1}: plant.P0, the identity when not given.
Matrix prior_covariance(const Scenario& scenario);
/// The estimator's options: the scenario's divergence bound.
FilterOptions filter_options(const Scenario& scenario);

class IntermittentKalmanFilter {
 public:
  /// x0 / P0: the prior for the first period, x̂_{0|-1}, P_{0|-1}.
  IntermittentKalmanFilter(FilterModel model, Vector x0, Matrix P0, FilterOptions options = {});

  /// Fused measurement update for the current period with the samples that arrived
  /// (any subset; empty = no update). Invalid samples are rejected and counted, never fused.
  /// After the call, x()/P() are the filtered x̂_{k|k}, P_{k|k}.
  FusedUpdateResult update(std::span<const SensorSample> received);
  /// Why a sample of `sensor_id` could not be fused on its own (unknown sensor, wrong size,
  /// non-finite); nullopt when it can. The one check update() and the estimator's arrival use.
  std::optional<SampleRejection> check(int sensor_id, const Vector& y) const;

  /// Time update to the next period: x̂_{k+1|k} = A x̂_{k|k} + B u_k, P_{k+1|k} = A P A' + Q.
  /// `input` must have B's column count (ignored when the model has no B).
  void predict(const Vector* input = nullptr);
  /// The same when the input applied is not known, only its mean `input` and covariance
  /// `input_covariance` (an unacknowledged actuation link): P_{k+1|k} = A P A' + Q + B Σ_u B'
  /// (Schenato et al. 2007, Sec. VI: Σ_u = ν̄(1 − ν̄) u u' for a zeroing actuator).
  void predict(const Vector& input, const Matrix& input_covariance);

  /// Continue from a filtered x̂_{k|k}, P_{k|k} published earlier (an estimator restarted from
  /// its last estimate). Throws std::invalid_argument on a wrong size or a non-finite entry.
  void restore(const Vector& x, const Matrix& P);

  const Vector& x() const { return x_; }
  const Matrix& P() const { return P_; }
  double trace_P() const { return P_.trace(); }
  FilterState state() const { return state_; }
  const RejectionCounts& rejections() const { return rejections_; }
  const FilterModel& model() const { return model_; }
  int state_dim() const { return static_cast<int>(x_.size()); }

 private:
  void refresh_state();
  void saturate();  // keeps P and x finite (FilterOptions::covariance_ceiling)
  /// Looks up a sensor's index in model_.sensors; -1 when unknown.
  int sensor_index(int id) const;
  // check() for the sensor at index s of the model (-1: unknown), so update() looks it up once.
  std::optional<SampleRejection> check_at(int s, const Vector& y) const;
  /// update()'s first half: the valid samples' sensor indices into accepted_ (in id order) and
  /// taken_; the rest counted and listed in `result`. Leaves x_ and P_ alone.
  void accept(std::span<const SensorSample> received, FusedUpdateResult& result);
  /// update()'s second half: the fused update of x_, P_ with the accepted samples.
  void fuse_accepted(std::span<const SensorSample> received, FusedUpdateResult& result);

  // Per-sensor information terms precomputed at construction (R_i factorised once):
  // H_i = C_i' R_i^-1 (n x m_i) and Lambda_i = C_i' R_i^-1 C_i (n x n, PSD by construction).
  struct SensorTerms {
    Matrix H;
    Matrix Lambda;
  };

  void predict_with(const Vector* input, const Matrix* input_covariance);

  FilterModel model_;
  FilterOptions options_;
  Vector x_;
  Matrix P_;
  FilterState state_ = FilterState::ok;
  RejectionCounts rejections_;
  std::vector<SensorTerms> terms_;             // parallel to model_.sensors
  std::vector<std::pair<int, int>> id_index_;  // (sensor id, index), sorted by id

  // Workspace sized at construction so that update()/predict() do not allocate
  // matrices at 100 Hz (only the small result vectors are allocated).
  std::vector<int> accepted_;     // indices of samples accepted in this update
  std::vector<int> taken_;        // sensor index -> sample index in this update, or -1
  Matrix lambda_sum_;             // Σ Lambda_i over the received sensors
  Vector info_vector_;            // h = Σ H_i y_i
  Vector work_x_;
  Matrix factor_;                 // F with P = F F'
  Matrix work_a_;
  Matrix work_b_;
  Eigen::LDLT<Matrix> ldlt_;
  Eigen::LLT<Matrix> llt_;
};

// ---- Reference forms of the fused update (for tests and benchmarks) ----
// All take the prior (x, P) and the received sensors' (C_i, R_i, y_i) and return the posterior.
struct FusedPosterior {
  Vector x;
  Matrix P;
};
struct ReceivedBlock {
  const Matrix* C;
  const Matrix* R;
  const Vector* y;
};

/// Stacked form with an explicit inverse of the stacked innovation covariance (naive, O(m^3)).
FusedPosterior fused_update_stacked_inverse(const Vector& x, const Matrix& P, std::span<const ReceivedBlock> blocks);
/// Sequential per-sensor Joseph-form updates (block-diagonal R): O(d).
FusedPosterior fused_update_sequential(const Vector& x, const Matrix& P, std::span<const ReceivedBlock> blocks);
/// Information form: P^-1 + Σ C_i' R_i^-1 C_i.
FusedPosterior fused_update_information(const Vector& x, const Matrix& P, std::span<const ReceivedBlock> blocks);

}  // namespace netkf
