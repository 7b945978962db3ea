#pragma once
// Progress of a long computation (Monte Carlo runs, the stability region's grid), for a
// caller that shows it (the CLI's progress bar on a terminal). The core prints nothing.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>

namespace netkf {

/// Called with the units of work done and their total: `done` never decreases from one call
/// to the next and the last call has done == total. Calls never overlap, though they may
/// come from different worker threads.
using ProgressCallback = std::function<void(std::int64_t done, std::int64_t total)>;

/// Counts work done by any number of threads and reports it to a ProgressCallback at a
/// bounded rate: (0, total) at once, then at most once per `min_interval`, and always
/// (total, total) when the last unit is added. Without a callback it does nothing.
class ProgressReporter {
 public:
  ProgressReporter(ProgressCallback callback, std::int64_t total,
                   std::chrono::steady_clock::duration min_interval = std::chrono::milliseconds(100));
  ProgressReporter(const ProgressReporter&) = delete;
  ProgressReporter& operator=(const ProgressReporter&) = delete;

  /// `units` more are done. Thread-safe; an atomic add when no report is due.
  void add(std::int64_t units);

 private:
  void report();

  ProgressCallback callback_;
  std::int64_t total_;
  std::int64_t interval_ns_;
  std::atomic<std::int64_t> done_{0};
  std::atomic<std::int64_t> next_report_ns_{0};  // steady clock: no report before this
  std::mutex mutex_;                             // serialises the callback
  std::int64_t reported_ = -1;                   // guarded by mutex_
};

}  // namespace netkf
