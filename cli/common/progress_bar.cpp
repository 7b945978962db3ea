#include "netkf/cli/common/progress_bar.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace netkf::cli {
namespace {

std::string duration_text(double seconds) {
  const auto s = static_cast<long long>(std::llround(std::max(0.0, seconds)));
  char buf[32];
  if (s >= 3600) {
    std::snprintf(buf, sizeof buf, "%lldh%02lldm", s / 3600, (s / 60) % 60);
  } else if (s >= 60) {
    std::snprintf(buf, sizeof buf, "%lldm%02llds", s / 60, s % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%llds", s);
  }
  return buf;
}

// Erase the line the cursor is on (carriage return, then ANSI "erase to end of line").
constexpr const char* kClearLine = "\r\033[K";

}  // namespace

bool progress_bar_wanted(bool stderr_is_terminal, bool json) { return stderr_is_terminal && !json; }

bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

std::string progress_line(const std::string& label, std::int64_t done, std::int64_t total, double elapsed_s,
                          int bar_width) {
  const double fraction = total > 0 ? std::clamp(static_cast<double>(done) / static_cast<double>(total), 0.0, 1.0) : 1.0;
  const int filled = static_cast<int>(fraction * bar_width);
  std::string line = label + " [" + std::string(static_cast<std::size_t>(filled), '#') +
                     std::string(static_cast<std::size_t>(bar_width - filled), '.') + "] ";
  char percent[8];
  std::snprintf(percent, sizeof percent, "%3d%%", static_cast<int>(fraction * 100.0));
  line += percent;
  // The time left at the rate so far: only once some work is done, and while some is left.
  if (done > 0 && done < total) line += "  " + duration_text(elapsed_s * (1.0 - fraction) / fraction) + " left";
  return line;
}

ProgressBar::ProgressBar(std::ostream& out, std::string label, bool enabled, Clock clock)
    : out_(out), label_(std::move(label)), enabled_(enabled), clock_(std::move(clock)), start_(clock_()) {}

ProgressBar::~ProgressBar() { clear(); }

void ProgressBar::update(std::int64_t done, std::int64_t total) {
  if (!enabled_) return;
  const std::lock_guard<std::mutex> lock(mutex_);
  const auto now = clock_();
  if (drawn_ && done < total && now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  drawn_ = true;
  out_ << kClearLine << progress_line(label_, done, total, std::chrono::duration<double>(now - start_).count())
       << std::flush;
}

void ProgressBar::clear() {
  if (!enabled_) return;
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!drawn_) return;
  out_ << kClearLine << std::flush;
  drawn_ = false;
}

ProgressCallback ProgressBar::callback() {
  if (!enabled_) return {};  // no callback: the core does not even count
  return [this](std::int64_t done, std::int64_t total) { update(done, total); };
}

}  // namespace netkf::cli
