#include "netkf/support/progress.hpp"

#include <algorithm>

namespace netkf {
namespace {

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

ProgressReporter::ProgressReporter(ProgressCallback callback, std::int64_t total,
                                   std::chrono::steady_clock::duration min_interval)
    : callback_(std::move(callback)),
      total_(std::max<std::int64_t>(total, 0)),
      interval_ns_(std::chrono::duration_cast<std::chrono::nanoseconds>(min_interval).count()) {
  if (!callback_) return;
  next_report_ns_.store(now_ns() + interval_ns_);
  report();
}

void ProgressReporter::add(std::int64_t units) {
  if (!callback_) return;
  const std::int64_t done = done_.fetch_add(units, std::memory_order_relaxed) + units;
  if (done >= total_) {
    report();  // the final count is always reported
    return;
  }
  const std::int64_t now = now_ns();
  std::int64_t due = next_report_ns_.load(std::memory_order_relaxed);
  if (now < due) return;
  // One thread takes the due report; the others carry on without waiting.
  if (!next_report_ns_.compare_exchange_strong(due, now + interval_ns_)) return;
  report();
}

void ProgressReporter::report() {
  const std::lock_guard<std::mutex> lock(mutex_);
  // Read under the lock: a report that lost the race to a later count skips, so counts
  // never go backwards.
  const std::int64_t done = std::min(done_.load(std::memory_order_relaxed), total_);
  if (done <= reported_) return;
  reported_ = done;
  callback_(done, total_);
}

}  // namespace netkf
