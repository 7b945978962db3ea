#pragma once
// The one check of every time-like number a command reads (durations, timeouts, intervals:
// on the command line through command_options.hpp's seconds_in(), in a sweep.yaml): finite
// and in its range. NaN fails every comparison, so each bound is written to refuse it.
#include <cmath>
#include <string>

#include "netkf/cli/common/text.hpp"

namespace netkf::cli {

/// The longest a run may be asked to last (--duration of launch, record, sweep): 10^7 s,
/// about 116 days; a longer one is a typo (1e300) and would overflow a count of periods.
inline constexpr double kMaxDurationSeconds = 1e7;

/// Empty when `s` is a number of seconds in [min, max] (in (min, max] with `above_min`), else
/// "must be a number of seconds in [min, max]".
inline std::string seconds_problem(double s, double min, double max, bool above_min = false) {
  if (std::isfinite(s) && (above_min ? s > min : s >= min) && s <= max) return {};
  return "must be a number of seconds in " + std::string(above_min ? "(" : "[") + number_text(min) + ", " +
         number_text(max) + "]";
}

}  // namespace netkf::cli
