#pragma once
// A progress bar for long commands (simulate, analyze --region): one line on stderr,
// redrawn in place, with the percentage and an estimate of the time left; drawn only on a
// terminal (a log file or a pipe gets nothing) and cleared when the work is done, so
// stdout (--json, tables) stays clean.
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <ostream>
#include <string>

#include "netkf/support/progress.hpp"

namespace netkf::cli {

/// Whether a command shows a progress bar: stderr is a terminal and the output is not --json.
bool progress_bar_wanted(bool stderr_is_terminal, bool json);
/// isatty(stderr).
bool stderr_is_terminal();

/// The bar's line: "LABEL [#####.....]  42%  1m05s left" (no time left before any unit is
/// done, or when done). `elapsed_s`: since the work started.
std::string progress_line(const std::string& label, std::int64_t done, std::int64_t total, double elapsed_s,
                          int bar_width = 30);

class ProgressBar {
 public:
  using Clock = std::function<std::chrono::steady_clock::time_point()>;
  /// enabled false: draws nothing at all.
  ProgressBar(std::ostream& out, std::string label, bool enabled, Clock clock = std::chrono::steady_clock::now);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  /// Redraws at most ten times a second, and always when done == total. Thread-safe.
  void update(std::int64_t done, std::int64_t total);
  /// Clears the line (once; also done by the destructor).
  void clear();
  /// A callback for the core's computations (netkf/support/progress.hpp) that updates this bar.
  ProgressCallback callback();

 private:
  std::ostream& out_;
  std::string label_;
  bool enabled_;
  Clock clock_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_{};
  bool drawn_ = false;
  std::mutex mutex_;
};

}  // namespace netkf::cli
