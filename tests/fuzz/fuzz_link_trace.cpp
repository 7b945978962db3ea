// Fuzzes the link trace reader (core/src/links/link_trace.cpp) on arbitrary text: it must return a
// trace or throw TraceError ("FILE:LINE:COL: ..."), never crash, hang or throw anything
// else. An accepted trace must be well formed (a delay per row when the column is there, no
// delay on a lost row, every delay finite in [0, 60000]), survive write_link_trace and a
// second read unchanged, and replay (trace_sample) and give an empirical model within range.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <string>

#include "netkf/links/link.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_trace.hpp"

namespace {

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_link_trace: %s: %s\n", what, detail.c_str());
  std::abort();
}

// Small enough that the fuzzer's inputs reach the bound.
constexpr std::size_t kMaxRows = 4096;

void check_trace(const netkf::LinkTrace& t) {
  if (t.size() == 0 || t.size() > kMaxRows) finding("accepted a trace with a bad row count", std::to_string(t.size()));
  if (t.has_delay != (t.delay_ms.size() == t.size())) finding("delay column and rows disagree", "");
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t.delivered[i] > 1) finding("delivered other than 0/1", std::to_string(i));
    if (!t.has_delay) continue;
    const double d = t.delay_ms[i];
    if (t.delivered[i] ? !(d >= 0.0 && d <= 60000.0) : !std::isnan(d)) finding("bad delay accepted", std::to_string(i));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  netkf::LinkTrace trace;
  try {
    trace = netkf::read_link_trace(in, "fuzz.csv", kMaxRows);
  } catch (const netkf::TraceError& e) {
    if (std::string(e.what()).rfind("fuzz.csv:", 0) != 0) finding("an error without FILE:LINE:COL", e.what());
    return 0;
  }
  check_trace(trace);
  std::ostringstream written;
  netkf::write_link_trace(written, trace, "fuzz");
  std::istringstream again_in(written.str());
  netkf::LinkTrace again;
  try {
    again = netkf::read_link_trace(again_in, "again.csv", kMaxRows);
  } catch (const netkf::TraceError& e) {
    finding("a written trace does not read again", e.what());
  }
  if (again.first_k != trace.first_k || again.delivered != trace.delivered || again.has_delay != trace.has_delay)
    finding("a trace changed on its trip through write_link_trace", "");
  for (std::size_t i = 0; i < trace.size() && trace.has_delay; ++i)
    if (trace.delivered[i] && again.delay_ms[i] != trace.delay_ms[i]) finding("a delay changed on its trip", std::to_string(i));

  const auto shared = std::make_shared<const netkf::LinkTrace>(trace);
  const netkf::LinkModel model = netkf::empirical_link_model(*shared);
  netkf::validate_link_model(model);
  const double loss = netkf::stationary_loss(model);
  const double observed = 1.0 - static_cast<double>(trace.delivered_count()) / static_cast<double>(trace.size());
  if (!(std::fabs(loss - observed) < 1e-9)) finding("the empirical model's loss is not the trace's", std::to_string(loss));
  netkf::TraceLink link{"fuzz.csv", size % 2 == 0, size % trace.size(), shared};
  for (std::uint64_t n = 0; n < 2 * trace.size() + 2; ++n) {
    const auto s = netkf::trace_sample(link, n);
    const std::uint64_t row = link.offset + n;
    const bool expected = row < trace.size() ? trace.delivered[row] != 0
                                             : link.loop && trace.delivered[row % trace.size()] != 0;
    if (s.delivered != expected) finding("trace_sample disagrees with the rows", std::to_string(n));
  }
  return 0;
}
