// Reading a link trace (netkf/links/link_trace.hpp): every refusal names FILE:LINE:COL.
#include "netkf/links/link_trace.hpp"

#include "netkf/support/input_file.hpp"

#include <algorithm>
#include <charconv>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <string_view>

namespace netkf {
namespace {

// The same bound as a link's delay (netkf/links/link.hpp): a delay above a minute is a typo.
constexpr double kMaxTraceDelayMs = 60000.0;

struct Field {
  std::string_view text;  // trimmed
  std::size_t column = 1;  // 1-based column of the field's first character
};

std::string_view trim(std::string_view s, std::size_t& lead) {
  lead = 0;
  while (lead < s.size() && (s[lead] == ' ' || s[lead] == '\t')) ++lead;
  std::size_t end = s.size();
  while (end > lead && (s[end - 1] == ' ' || s[end - 1] == '\t')) --end;
  return s.substr(lead, end - lead);
}

std::vector<Field> split_fields(std::string_view line) {
  std::vector<Field> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    const std::string_view raw = line.substr(start, comma == std::string_view::npos ? line.npos : comma - start);
    std::size_t lead = 0;
    const std::string_view t = trim(raw, lead);
    fields.push_back({t, start + lead + 1});
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return fields;
}

std::string quoted(std::string_view s) {
  constexpr std::size_t kShown = 40;
  return "'" + std::string(s.substr(0, kShown)) + (s.size() > kShown ? "...'" : "'");
}

// The start of a header field that is not the expected name, up to its first character
// that no column name has: the offending word, not the line of a file of another kind
// (a message never shows what /etc/passwd holds).
std::string header_token(std::string_view s) {
  constexpr std::size_t kShown = 20;
  std::size_t n = 0;
  while (n < s.size() && n < kShown && (std::isalnum(static_cast<unsigned char>(s[n])) || s[n] == '_')) ++n;
  if (n == 0 && !s.empty()) {
    const auto c = static_cast<unsigned char>(s[0]);
    if (c < 0x20 || c >= 0x7f) {
      char byte[48];
      std::snprintf(byte, sizeof byte, "a field starting with the byte 0x%02X", c);
      return byte;
    }
    n = 1;
  }
  return "'" + std::string(s.substr(0, n)) + (n < s.size() ? "...'" : "'");
}

class TraceParser {
 public:
  TraceParser(std::istream& in, std::string name, std::size_t max_samples)
      : in_(in), name_(std::move(name)), max_samples_(max_samples) {}

  LinkTrace parse() {
    LinkTrace trace;
    bool header_seen = false;
    std::size_t columns = 0;
    std::string line;
    while (next_line(line)) {
      std::size_t lead = 0;
      const std::string_view body = trim(line, lead);
      if (body.empty() || body.front() == '#') continue;
      const auto fields = split_fields(line);
      if (!header_seen) {
        columns = check_header(fields, line.size());
        trace.has_delay = columns == 3;
        header_seen = true;
        continue;
      }
      if (trace.size() >= max_samples_)
        fail(1, "the trace has more than " + std::to_string(max_samples_) +
                    " samples, the most a trace may have (split it, or fit a part)");
      read_row(fields, columns, line.size(), trace);
    }
    if (!header_seen) fail(1, "missing header: a trace starts with the line 'k,delivered' or 'k,delivered,delay_ms'");
    if (trace.delivered.empty()) fail(1, "the trace has no samples (the header needs at least one row under it)");
    return trace;
  }

 private:
  // One line into `line` (without its end of line, CR LF too); false at the end of input.
  bool next_line(std::string& line) {
    line.clear();
    auto* buf = in_.rdbuf();
    if (!buf) return false;
    int c = buf->sbumpc();
    if (c == std::char_traits<char>::eof()) return false;
    ++line_no_;
    while (c != std::char_traits<char>::eof() && c != '\n') {
      if (line.size() >= max_trace_line)
        fail(max_trace_line + 1, "line longer than " + std::to_string(max_trace_line) + " characters");
      line.push_back(static_cast<char>(c));
      c = buf->sbumpc();
    }
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // A UTF-8 byte-order mark (some editors write one) is not part of the header.
    if (line_no_ == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    return true;
  }

  [[noreturn]] void fail(std::size_t column, const std::string& what) const {
    throw TraceError(name_ + ":" + std::to_string(line_no_ == 0 ? 1 : line_no_) + ":" + std::to_string(column) +
                     ": " + what);
  }

  std::size_t check_header(const std::vector<Field>& f, std::size_t line_length) const {
    static const char* const expected[] = {"k", "delivered", "delay_ms"};
    const char* usage = " (the header is 'k,delivered' or 'k,delivered,delay_ms')";
    if (f.size() > 3) fail(f[3].column, "unexpected column " + header_token(f[3].text) + usage);
    for (std::size_t i = 0; i < f.size(); ++i) {
      if (f[i].text != expected[i])
        fail(f[i].column, "bad header: column " + std::to_string(i + 1) + " must be '" + expected[i] + "', got " +
                              header_token(f[i].text) + usage);
    }
    if (f.size() < 2) fail(line_length + 1, "bad header: missing column 'delivered'" + std::string(usage));
    return f.size();
  }

  void read_row(const std::vector<Field>& f, std::size_t columns, std::size_t line_length, LinkTrace& trace) {
    if (f.size() > columns)
      fail(f[columns].column, "unexpected field " + quoted(f[columns].text) + " (the header has " +
                                  std::to_string(columns) + " columns)");
    if (f.size() < columns)
      fail(line_length + 1, "missing field '" + std::string(columns == 3 && f.size() == 2 ? "delay_ms" : "delivered") +
                                "' (the header has " + std::to_string(columns) + " columns)");
    const std::uint64_t k = read_k(f[0]);
    if (trace.delivered.empty()) {
      trace.first_k = k;
    } else if (k != trace.first_k + trace.size()) {
      fail(f[0].column, "k must count the samples: expected " + std::to_string(trace.first_k + trace.size()) +
                            ", got " + std::to_string(k) + " (a missing row is a sample of unknown fate)");
    }
    if (f[1].text != "0" && f[1].text != "1")
      fail(f[1].column, "delivered must be 0 or 1, got " + quoted(f[1].text));
    const bool delivered = f[1].text == "1";
    trace.delivered.push_back(delivered ? 1 : 0);
    if (columns == 3) trace.delay_ms.push_back(read_delay(f[2], delivered));
  }

  std::uint64_t read_k(const Field& f) const {
    std::uint64_t k = 0;
    const char* end = f.text.data() + f.text.size();
    const auto [ptr, ec] = std::from_chars(f.text.data(), end, k);
    if (f.text.empty() || ec != std::errc() || ptr != end)
      fail(f.column, "k must be a non-negative integer, got " + quoted(f.text));
    return k;
  }

  double read_delay(const Field& f, bool delivered) const {
    if (f.text.empty()) {
      if (delivered) fail(f.column, "delay_ms is missing on a delivered sample");
      return std::numeric_limits<double>::quiet_NaN();
    }
    double d = 0.0;
    const char* end = f.text.data() + f.text.size();
    const auto [ptr, ec] = std::from_chars(f.text.data(), end, d);
    if (ec != std::errc() || ptr != end) fail(f.column, "delay_ms must be a number, got " + quoted(f.text));
    if (!std::isfinite(d)) fail(f.column, "delay_ms must be a finite number, got " + quoted(f.text));
    if (d < 0.0) fail(f.column, "delay_ms must not be negative, got " + quoted(f.text));
    if (d > kMaxTraceDelayMs) fail(f.column, "delay_ms above a minute (60000 ms), got " + quoted(f.text));
    return delivered ? d : std::numeric_limits<double>::quiet_NaN();
  }

  std::istream& in_;
  std::string name_;
  std::size_t max_samples_;
  std::size_t line_no_ = 0;
};

}  // namespace

std::size_t LinkTrace::delivered_count() const {
  return static_cast<std::size_t>(std::count(delivered.begin(), delivered.end(), std::uint8_t{1}));
}

LinkTrace read_link_trace(std::istream& in, const std::string& name, std::size_t max_samples) {
  return TraceParser(in, name, max_samples).parse();
}

void write_link_trace(std::ostream& out, const LinkTrace& trace, const std::string& comment) {
  std::size_t start = 0;
  while (!comment.empty() && start <= comment.size()) {
    const std::size_t end = comment.find('\n', start);
    out << "# " << comment.substr(start, end == std::string::npos ? std::string::npos : end - start) << "\n";
    if (end == std::string::npos) break;
    start = end + 1;
  }
  out << (trace.has_delay ? "k,delivered,delay_ms\n" : "k,delivered\n");
  char delay[40];
  for (std::size_t i = 0; i < trace.size(); ++i) {
    out << trace.first_k + i << ',' << int{trace.delivered[i]};
    if (trace.has_delay) {
      out << ',';
      if (trace.delivered[i]) {
        std::snprintf(delay, sizeof delay, "%.17g", trace.delay_ms[i]);
        out << delay;
      }
    }
    out << '\n';
  }
}

LinkTrace read_link_trace_file(const std::string& path) {
  // The parser bounds the rows and the line length: no size limit on the file itself.
  std::optional<InputFile> file;
  try {
    file.emplace(path, "trace file", std::numeric_limits<std::uintmax_t>::max());
  } catch (const InputFileError& e) {
    throw TraceError(path + ":1:1: " + e.reason());
  }
  return read_link_trace(file->stream(), path);
}

TraceSample trace_sample(const TraceLink& trace, std::uint64_t periods_since_start) {
  TraceSample out;
  const std::uint64_t n = trace.rows ? trace.rows->size() : 0;
  if (n == 0) return out;
  std::uint64_t row = trace.offset + periods_since_start;
  if (row < periods_since_start) return out;  // beyond 2^64 rows: no trace is that long
  if (row >= n) {
    if (!trace.loop) return out;  // past the end without loop: every sample is dropped
    row %= n;                     // loop: after the last row comes row 0, not the offset
  }
  out.delivered = trace.rows->delivered[row] != 0;
  out.delay_ms = trace.rows->has_delay && out.delivered ? trace.rows->delay_ms[row]
                                                         : std::numeric_limits<double>::quiet_NaN();
  return out;
}

}  // namespace netkf
