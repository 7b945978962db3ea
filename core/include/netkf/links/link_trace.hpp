#pragma once
// A measured link as a per-sample arrival trace (docs/scenario-format.md, "Link traces"):
// CSV with the header `k,delivered` and an optional third column `delay_ms`, one row per
// sample in order, `#` comment lines and blank lines allowed:
//
//     # measured 2024-05-01, office Wi-Fi
//     k,delivered,delay_ms
//     0,1,4.2
//     1,0,
//     2,1,3.9
//
// k counts the samples: the first row's k is any non-negative integer, each next row's k is
// one more (a gap would be samples of unknown fate). delivered is 0 or 1. delay_ms, when the
// column is there, is the delivered sample's delay in ms (finite, 0 .. 60000, as a link's
// delay); on a lost row it may be empty and is ignored. A trace is read whole, once: it is
// bounded by max_trace_samples rows and max_trace_line characters per line.
#include "netkf/links/link.hpp"

#include <cstddef>
#include <cstdint>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace netkf {

/// Rows a trace may have (10^7 samples: at a 10 ms period, more than a day of one link;
/// about 90 MB in memory with a delay column). A longer file is refused, not truncated.
inline constexpr std::size_t max_trace_samples = 10'000'000;
/// Characters a trace line may have (a real row is a few dozen).
inline constexpr std::size_t max_trace_line = 4096;

/// A malformed trace: what() is "FILE:LINE:COL: what is wrong" (LINE and COL from 1).
class TraceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct LinkTrace {
  std::uint64_t first_k = 0;           // k of the first row
  std::vector<std::uint8_t> delivered;  // 1 delivered, 0 lost, one per sample
  bool has_delay = false;               // the file has a delay_ms column
  std::vector<double> delay_ms;         // with has_delay: one per sample, NaN on lost rows
  std::size_t size() const { return delivered.size(); }
  std::size_t delivered_count() const;
};

/// Parse a trace; `name` is the FILE of error messages. Throws TraceError, also for a
/// trace longer than `max_samples` rows.
LinkTrace read_link_trace(std::istream& in, const std::string& name, std::size_t max_samples = max_trace_samples);
/// Write a trace in the format read_link_trace() reads (`# comment` lines first, when given;
/// delays with 17 significant digits): read_link_trace(write_link_trace(t)) == t.
void write_link_trace(std::ostream& out, const LinkTrace& trace, const std::string& comment = "");
/// Read a trace file. Throws TraceError (also when the file cannot be opened).
LinkTrace read_link_trace_file(const std::string& path);

/// The fate of one sample on a trace link.
struct TraceSample {
  bool delivered = false;
  double delay_ms = 0.0;  // the row's delay_ms (NaN when the trace has no delay column or the row is lost)
};
/// The trace's row for the sample `periods_since_start` periods after the trace link took
/// effect (row offset + n; loop or drop past the end, as TraceLink says).
TraceSample trace_sample(const TraceLink& trace, std::uint64_t periods_since_start);

}  // namespace netkf
