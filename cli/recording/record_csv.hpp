#pragma once
// The CSV recordings of a live run (docs/architecture.md, "Recordings: netkf launch FILE --record OUT.csv").
// Rows are formatted on the caller's (main) thread from records queued by the DDS
// callbacks, so no file I/O ever blocks a DDS thread.
#include <cstdint>
#include <map>
#include <optional>
#include <ostream>
#include <set>
#include <string>
#include <vector>

#include "netkf/records/delivered.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/truth.hpp"

namespace netkf::cli {

/// Doubles with 17 significant digits: a reader gets back the exact double.
std::string format_double(double value);

/// `k,t,x0..x{n-1},xhat0..xhat{n-1},trace_P,fused,late,state,late_samples`, one row per period
/// the plant ran, in order of k. With late_policy fuse_within (max_delay_periods D > 0) the row
/// keeps the first (in-time, revision 0) estimate in those columns and appends the final one:
/// `...,late_samples,revisions,xhat_final0..xhat_final{n-1},trace_P_final,fused_final`. A closed
/// loop (input_dim m > 0) appends `u0..u{m-1}`: the input u_{k-1} the plant applied to produce
/// x_k (zeros at k = 0; where no input arrived in time zero, or with on_loss hold the previous
/// one); with an actuation link (plant.control.link) then `nu`: 1 when u_{k-1} reached the plant
/// in time (ν_{k-1}), 0 when it was lost or late (1 at k = 0: nothing was due).
/// A row waits until the truth and the estimate of k are known (D > 0: until k is final, i.e.
/// the in-time estimate of k + D + 1 has arrived, after which k is not revised). A period whose
/// estimate never comes (the estimator was stopped, or the run ended first) still gets its
/// truth: a row with the estimate's cells empty and state `none`, written as soon as an estimate
/// of a later period has arrived (the estimator publishes its periods in order, a restarted one
/// too, so k's will not come: e.g. lost at a hot standby's takeover), else once the truth is
/// kGiveUpPeriods periods old or the run ends (finish_pending()). A period without truth (the
/// recorder joined late) is left out.
class PeriodCsvRecorder {
 public:
  /// How many periods a row waits for its estimate before it is written without one: longer
  /// than an estimator restart or stall, after which the missed periods' estimates do come.
  static constexpr std::int64_t kGiveUpPeriods = 2000;

  explicit PeriodCsvRecorder(int state_dim, int max_delay_periods = 0, int input_dim = 0, bool actuation_link = false);
  static std::string header(int state_dim, int max_delay_periods = 0, int input_dim = 0, bool actuation_link = false);

  void add_truth(const Truth& truth);
  void add_estimate(const Estimate& estimate);
  /// Append the completed rows (in order of k) to `out` and forget them.
  std::size_t flush(std::ostream& out);
  /// The run ended: every period still waiting is written (with its last estimate, or none).
  void finish_pending();

  std::uint64_t rows_written() const { return rows_written_; }
  /// Records whose vectors had the wrong size (counted, not written).
  std::uint64_t rejected() const { return rejected_; }
  /// Rows written without an estimate (state `none`).
  std::uint64_t rows_without_estimate() const { return rows_without_estimate_; }

 private:
  void emit(bool finishing);  // the rows that can be written now, in order of k
  void write_row(std::int64_t k, const Truth& truth, const Estimate* estimate);
  int n_;
  int max_delay_periods_;
  int m_;
  bool actuation_link_;
  std::map<std::int64_t, Truth> truth_;
  std::map<std::int64_t, Estimate> estimates_;  // the first (in-time) estimate of k
  std::map<std::int64_t, Estimate> finals_;     // D > 0: the newest revision of k
  std::optional<std::int64_t> newest_truth_;
  std::optional<std::int64_t> newest_in_time_;  // the newest period with an in-time estimate
  std::optional<std::int64_t> last_written_;    // rows are written in order: older records come too late
  std::map<std::int64_t, std::string> ready_;
  std::uint64_t rows_written_ = 0;
  std::uint64_t rejected_ = 0;
  std::uint64_t rows_without_estimate_ = 0;
};

/// Every delivered measurement with whether the estimator fused it:
/// `k,sensor_id,stamp,fused,y0..y{m-1}` (m = the largest measurement size; shorter
/// samples leave trailing cells empty). Written when the estimate of k is known, so a
/// test can replay the run through the core filter offline.
/// With fuse_within (D > 0): `k,sensor_id,stamp,fused,fused_in_time,y0..`, `fused` meaning
/// fused in k's final estimate; a row waits until k is final (as the period rows do).
class SampleCsvRecorder {
 public:
  explicit SampleCsvRecorder(int max_measurement_dim, int max_delay_periods = 0);
  static std::string header(int max_measurement_dim, int max_delay_periods = 0);

  void add_delivered(const DeliveredMeasurement& sample);
  void add_estimate(const Estimate& estimate);
  std::size_t flush(std::ostream& out);
  /// The run ended: write the samples still waiting for their period to be final.
  void finish_pending();

 private:
  void write_row(const DeliveredMeasurement& sample, bool fused, bool fused_in_time);
  void write_final(std::int64_t k);
  int m_;
  int max_delay_periods_;
  std::map<std::int64_t, std::set<int>> fused_in_time_;  // D > 0: k -> ids of the in-time estimate
  std::map<std::int64_t, std::vector<DeliveredMeasurement>> pending_;
  std::map<std::int64_t, std::set<int>> fused_;  // k -> fused ids, once the estimate is known
  std::vector<std::string> ready_;
};

}  // namespace netkf::cli
