#pragma once
// A rate limit for repeated warnings (a rogue or broken sender can produce one bad sample
// per period): at most `burst` messages per `window`; the others are counted, and the next
// message allowed says how many were left out. Pure logic: the caller logs, and callers on
// several threads hold their own lock.
#include <chrono>
#include <cstdint>
#include <optional>

namespace netkf {

class LogThrottle {
 public:
  using Clock = std::chrono::steady_clock;
  explicit LogThrottle(int burst = 5, Clock::duration window = std::chrono::seconds(10))
      : burst_(burst), window_(window) {}

  /// nullopt: leave this one out (it is counted). Otherwise log it, with the number of
  /// messages left out since the last one logged (0: none).
  std::optional<std::uint64_t> allow(Clock::time_point now = Clock::now()) {
    if (now - window_start_ >= window_) {
      window_start_ = now;
      in_window_ = 0;
    }
    if (in_window_ >= burst_) {
      ++suppressed_;
      return std::nullopt;
    }
    ++in_window_;
    const std::uint64_t left_out = suppressed_;
    suppressed_ = 0;
    return left_out;
  }

 private:
  int burst_;
  Clock::duration window_;
  Clock::time_point window_start_{};
  int in_window_ = 0;
  std::uint64_t suppressed_ = 0;
};

}  // namespace netkf
