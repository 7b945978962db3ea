#pragma once
// The CSV recordings of a live run (docs/architecture.md, "Recordings: netkf launch FILE --record OUT.csv").
// Rows are formatted on the caller's (main) thread from records queued by the DDS
// callbacks, so no file I/O ever blocks a DDS thread.
#include <cstdint>
#include <map>
#include <ostream>
#include <set>
#include <string>
#include <vector>

#include "live_records.hpp"

namespace netkf::cli {

/// Doubles with 17 significant digits: a reader gets back the exact double.
std::string format_double(double value);

/// `k,t,x0..x{n-1},xhat0..xhat{n-1},trace_P,fused,late,state,late_samples`, one row per period,
/// written when both the truth and the estimate of k are known.
class PeriodCsvRecorder {
 public:
  explicit PeriodCsvRecorder(int state_dim);
  static std::string header(int state_dim);

  void add_truth(const TruthRecord& truth);
  void add_estimate(const Estimate& estimate);
  /// Append the completed rows (in order of k) to `out` and forget them.
  std::size_t flush(std::ostream& out);

  std::uint64_t rows_written() const { return rows_written_; }
  /// Records whose vectors had the wrong size (counted, not written).
  std::uint64_t rejected() const { return rejected_; }

 private:
  void try_complete(std::int64_t k);
  int n_;
  std::map<std::int64_t, TruthRecord> truth_;
  std::map<std::int64_t, Estimate> estimates_;
  std::map<std::int64_t, std::string> ready_;
  std::uint64_t rows_written_ = 0;
  std::uint64_t rejected_ = 0;
};

/// Every delivered measurement with whether the estimator fused it:
/// `k,sensor_id,stamp,fused,y0..y{m-1}` (m = the largest measurement size; shorter
/// samples leave trailing cells empty). Written when the estimate of k is known, so a
/// test can replay the run through the core filter offline.
class SampleCsvRecorder {
 public:
  explicit SampleCsvRecorder(int max_measurement_dim);
  static std::string header(int max_measurement_dim);

  void add_delivered(const DeliveredRecord& sample);
  void add_estimate(const Estimate& estimate);
  std::size_t flush(std::ostream& out);

 private:
  int m_;
  std::map<std::int64_t, std::vector<DeliveredRecord>> pending_;
  std::map<std::int64_t, std::set<int>> fused_;  // k -> fused ids, once the estimate is known
  std::vector<std::string> ready_;
};

}  // namespace netkf::cli
