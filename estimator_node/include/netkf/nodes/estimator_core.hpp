#pragma once
// The estimator's period logic (docs/architecture.md, "estimator_node"), without DDS or clocks: the node
// passes every event with the current steady time in ns, so tests drive it with a fake clock.
//
// Period k opens when tick k arrives (deadline = arrival + deadline_ms). It is fused exactly
// once: as soon as every sensor's sample for k is in, or at the deadline, or when a later
// tick arrives first — whichever comes first. Samples for a fused period are late (counted,
// never fused); samples for a future period are buffered (bounded) until its tick.
// Fusion is the multi-sensor MMSE update with exactly the samples received (multi-sensor
// paper Thm 1, eqs. 8-9; Sinopoli eqs. 14-16 for one sensor); with nothing received the
// period still advances (open-loop prediction). Prediction to period k uses the input u_{k-1}
// the plant acknowledged in tick k. With control, u_k = -L x̂_{k|k} (LQG certainty equivalence).
//
// Late samples (estimator.late_policy, docs/scenario-format.md): with `drop` a sample for a
// fused period is counted late and never fused. With `fuse_within` and max_delay_periods D
// the core keeps the last D fused periods (their prior x̂_{j|j-1}, P_{j|j-1}, the samples
// fused and the input predicted with after them), D + 1 of them: the ring. A sample for period
// j is fusable until period j + D is fused, or until j + D's deadline when it was fused
// before it (all its samples in, or a later tick): then j's window is deadline + D periods
// after j's tick, whatever the other sensors do, as the theory assumes (the final estimate's
// arrival rate (1 − loss)·P(delay <= deadline + D·period), theory/report.hpp). A fusable
// sample is added to j's samples and the filter is re-run from j to
// now: every period from j on gets a revised estimate (revision 1, 2, ... of the same k), the
// MMSE estimate given every sample that has arrived (multi-sensor paper Thm 1 applied to the
// arrivals; Schenato 2008: with delays bounded by the buffer, the buffered re-run is optimal).
// The inputs are the ones applied, so a re-run never changes a control already sent. The
// re-run is done by revise(), and before anything else that fuses or predicts, so the next
// in-time estimate always starts from the revised history. A sample older than D is late.
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "netkf/filter/kalman_filter.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/records/estimate.hpp"

namespace netkf::nodes {

/// One fused period, ready to publish: the estimate and what only the estimator node needs.
struct PeriodEstimate : Estimate {
  std::optional<Vector> control;  // u_k = -L x̂_{k|k} to send to the plant (closed loop only)
  bool skipped_tick = false;      // tick k never arrived: open-loop period inferred from a later tick
};

class EstimatorCore {
 public:
  /// Throws std::invalid_argument when the scenario cannot be run (e.g. control without B).
  explicit EstimatorCore(const Scenario& scenario);

  /// Tick k arrived at `now_ns` with the input u_{k-1} the plant applied (empty: none / zero).
  /// Returns the periods fused because of it (a still-open earlier period, skipped periods,
  /// and period k itself if all its samples were already buffered), in order.
  std::vector<PeriodEstimate> on_tick(std::uint64_t k, const Vector& applied_input, std::int64_t now_ns);

  /// Continue after `last_published.k` (before any tick): ticks up to and including it are
  /// ignored (a transient-local tick history replays them), later ones predict from it; this
  /// life counts one restart more than the estimate it resumes from.
  /// Throws std::invalid_argument when the estimate does not fit the scenario.
  void resume(const Estimate& last_published);

  /// A delivered sample arrived. Returns period k's estimate if this completed its set.
  std::vector<PeriodEstimate> on_sample(int sensor_id, std::uint64_t k, const Vector& y, std::int64_t stamp_ns,
                                        std::int64_t now_ns);

  /// A sample that could not be decoded (e.g. NaN caught by the wire conversion).
  void count_rejection(SampleRejection reason);

  /// Fuse the open period if its deadline has passed.
  std::vector<PeriodEstimate> on_deadline(std::int64_t now_ns);

  /// late_policy fuse_within: re-run the filter (step() per period) from the earliest period that received a late
  /// sample since the last re-run, returning the revised estimates (oldest period first); empty
  /// when nothing is pending. Cost: at most D + 1 fused updates and predictions.
  std::vector<PeriodEstimate> revise(std::int64_t now_ns);
  /// Whether a late sample waits for revise().
  bool revision_pending() const { return rerun_from_.has_value(); }

  /// Deadline of the open period (for the node's timer); nullopt when none is open.
  std::optional<std::int64_t> pending_deadline_ns() const;
  std::optional<std::uint64_t> open_period() const;
  std::optional<std::uint64_t> last_fused_period() const { return last_fused_; }

  std::uint64_t late_total() const { return late_total_; }
  /// Samples that arrived after their period was fused and were fused into a revision.
  std::uint64_t late_fused_total() const { return late_fused_total_; }
  /// D: how many periods a sample stays fusable after its own (0 with late_policy drop).
  int max_delay_periods() const { return max_delay_periods_; }
  std::uint64_t rejected_total() const;
  std::uint64_t rejected(SampleRejection r) const { return rejected_[static_cast<int>(r)]; }
  std::size_t buffered_samples() const;
  const IntermittentKalmanFilter& filter() const { return filter_; }
  std::uint32_t restarts() const { return restarts_; }
  int sensor_count() const { return static_cast<int>(sensor_dims_.size()); }

  /// Future periods buffered at most (samples for k > open + this are rejected: buffer_full).
  static constexpr std::uint64_t kMaxFuturePeriods = 64;

 private:
  struct OpenPeriod {
    std::uint64_t k = 0;
    double t = 0.0;
    std::int64_t deadline_ns = 0;
    std::map<int, SensorSample> samples;
    std::int64_t last_stamp_ns = 0;
  };
  struct Buffered {
    SensorSample sample;
    std::int64_t stamp_ns = 0;
  };
  /// A fused period the re-run may start from (late_policy fuse_within).
  struct FusedPeriod {
    std::uint64_t k = 0;
    double t = 0.0;
    Vector x_prior;  // x̂_{k|k-1}
    Matrix P_prior;  // P_{k|k-1}
    std::map<int, SensorSample> samples;  // every sample fused for k (in time and late)
    std::optional<Vector> input_after;     // the input predicted with from k to k+1 (once k+1 opened; empty: none)
    std::optional<Matrix> input_covariance_after;  // unacknowledged inputs: the applied input's spread
    std::int64_t last_stamp_ns = 0;
    std::int64_t deadline_ns = 0;  // k's deadline (k - D's window closes at it, or when k is fused if later)
    std::uint32_t revision = 0;
  };

  /// One period's fused update, the same for the in-time fusion and a re-run: the filter's
  /// prior (x̂_{k|k-1}, P_{k|k-1}) updated with `samples` (multi-sensor paper Thm 1, eqs. 8-9),
  /// the estimate of k made of it. What else a published estimate carries is the caller's.
  PeriodEstimate step(std::uint64_t k, double t, const std::map<int, SensorSample>& samples,
                      std::int64_t last_stamp_ns, std::int64_t now_ns);
  /// The open period fused in time: step(), then the late samples since the previous estimate,
  /// the control, and the period kept for a re-run.
  PeriodEstimate fuse(std::int64_t now_ns);
  /// revise() first (the revisions go to `out`), so what follows starts from the revised history.
  void flush_revisions(std::vector<PeriodEstimate>& out, std::int64_t now_ns);
  /// A sample for the fused period k: kept for a re-run (true) when fuse_within and k is in the ring.
  bool keep_late(int sensor_id, std::uint64_t k, const Vector& y, std::int64_t stamp_ns, std::int64_t now_ns);
  void remember(const PeriodEstimate& e, Vector x_prior, Matrix P_prior);
  void open(std::uint64_t k, std::int64_t now_ns);
  /// From the last fused period to the next: with the input the plant applied (acknowledged:
  /// `applied_input`, empty meaning zero), or with its expectation (unacknowledged); the input
  /// used is kept with the last fused period, so a re-run predicts with the same.
  void predict_next(const Vector& applied_input);
  /// The input predicted with after the last fused period (for a re-run).
  void keep_input_after(std::optional<Vector> input, std::optional<Matrix> input_covariance);
  /// Acknowledged inputs: the one applied (an absent input means the plant applied zero).
  Vector predict_with(const Vector& applied_input);
  /// Unacknowledged inputs: the input the plant applied is not known, only that u_{k-1} arrived
  /// with probability ν̄; predict with its mean and spread (returned).
  std::pair<Vector, Matrix> predict_with_expected_input();
  bool complete() const;
  void reject(SampleRejection r) { ++rejected_[static_cast<int>(r)]; }
  void count_late(int sensor_id, std::uint64_t k);

  IntermittentKalmanFilter filter_;
  std::map<int, int> sensor_dims_;   // id -> m_i
  std::optional<Matrix> gain_;       // L
  int input_dim_ = 0;
  double period_s_;
  std::int64_t deadline_ns_;
  std::optional<OpenPeriod> open_;
  std::optional<std::uint64_t> last_fused_;
  std::optional<Vector> last_control_;  // u sent for the last fused period (assumed applied if its tick is lost)
  // The actuation link (plant.control.link): acknowledged (TCP-like) inputs are predicted with as
  // the tick reports them; unacknowledged (UDP-like) ones with their expectation under ν̄.
  bool acknowledged_ = true;
  OnLoss on_loss_ = OnLoss::zero;
  double input_arrival_rate_ = 1.0;  // ν̄
  Vector applied_mean_;              // hold: E[u^a_{k-1}], the applied input's mean
  Matrix applied_second_moment_;     // hold: E[u^a_{k-1} u^a_{k-1}']
  std::map<std::uint64_t, std::map<int, Buffered>> future_;
  std::uint64_t late_total_ = 0;
  std::vector<int> late_since_publish_;  // sensor id of each late sample since the previous estimate
  std::vector<std::uint64_t> late_periods_since_publish_;  // ... and the period it was for
  std::uint64_t rejected_[static_cast<int>(SampleRejection::count_)] = {};
  std::uint64_t rejected_before_restart_ = 0;  // the previous lives' total (from the checkpoint)
  std::optional<std::uint64_t> resumed_after_;  // ticks up to this period are history: ignored
  std::uint32_t restarts_ = 0;
  int max_delay_periods_ = 0;               // D (0: late_policy drop)
  std::deque<FusedPeriod> history_;         // the last D + 1 fused periods, oldest first
  std::optional<std::uint64_t> rerun_from_;  // earliest period with a late sample not yet re-run
  std::uint64_t late_fused_total_ = 0;
};

}  // namespace netkf::nodes
