#include "sweep_table.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <istream>
#include <stdexcept>

namespace netkf::cli::sweep {
namespace {

std::vector<std::string> split_csv(const std::string& line) {
  // The cells are numbers, keys and plain values: no quoting needed (keys hold no commas).
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const auto pos = line.find(',', start);
    out.push_back(line.substr(start, pos == std::string::npos ? std::string::npos : pos - start));
    if (pos == std::string::npos) return out;
    start = pos + 1;
  }
}

std::optional<double> parse_cell(const std::string& text, int line) {
  if (text.empty()) return std::nullopt;
  double v = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size())
    throw std::runtime_error("runs.csv line " + std::to_string(line) + ": '" + text + "' is not a number");
  return v;
}

int parse_int(const std::string& text, int line) {
  int v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size())
    throw std::runtime_error("runs.csv line " + std::to_string(line) + ": '" + text + "' is not a whole number");
  return v;
}

}  // namespace

Stats aggregate(const std::vector<std::optional<double>>& values) {
  Stats s;
  double sum = 0.0;
  for (const auto& v : values) {
    if (!v || !std::isfinite(*v)) continue;
    ++s.n;
    sum += *v;
    s.min = s.min ? std::min(*s.min, *v) : *v;
    s.max = s.max ? std::max(*s.max, *v) : *v;
  }
  if (s.n == 0) return s;
  const double mean = sum / s.n;
  s.mean = mean;
  if (s.n >= 2) {
    double ss = 0.0;
    for (const auto& v : values)
      if (v && std::isfinite(*v)) ss += (*v - mean) * (*v - mean);
    s.se = std::sqrt(ss / (s.n - 1) / s.n);
  }
  return s;
}

std::string cell(const std::optional<double>& v) {
  if (!v || !std::isfinite(*v)) return {};
  char buf[40];
  if (*v == std::floor(*v) && std::fabs(*v) < 9.0e15) std::snprintf(buf, sizeof buf, "%.0f", *v);
  else std::snprintf(buf, sizeof buf, "%.17g", *v);
  return buf;
}

std::string runs_header(const std::vector<Vary>& vary, const std::vector<std::string>& quantities) {
  std::string h = "point,seed";
  for (const auto& v : vary) h += "," + v.key;
  h += ",status";
  for (const auto& q : quantities) h += "," + q;
  return h;
}

std::string runs_line(const RunRow& row, const Point& point) {
  std::string line = std::to_string(row.point) + "," + std::to_string(row.seed);
  for (const auto& v : point.values) line += "," + v;
  line += row.ok ? ",ok" : ",failed";
  for (const auto& v : row.values) line += "," + cell(v);
  return line;
}

std::string points_header(const std::vector<Vary>& vary, const std::vector<std::string>& quantities) {
  std::string h = "point";
  for (const auto& v : vary) h += "," + v.key;
  h += ",seeds";
  for (const auto& q : quantities) h += "," + q + "_mean," + q + "_se," + q + "_min," + q + "_max";
  h += ",theory_stable,theory_trace_S_bar,theory_trace_V_bar,theory_critical_margin,theory_trace_P_sampled,"
       "theory_trace_P_sampled_se";
  return h;
}

Stats point_stats(int point, std::size_t q, const std::vector<RunRow>& rows) {
  std::vector<std::optional<double>> values;
  for (const auto& r : rows)
    if (r.point == point && r.ok && q < r.values.size()) values.push_back(r.values[q]);
  return aggregate(values);
}

std::string points_line(const Point& point, std::size_t quantities, const std::vector<RunRow>& rows,
                        const Theory& theory) {
  std::string line = std::to_string(point.index);
  for (const auto& v : point.values) line += "," + v;
  int seeds = 0;
  for (const auto& r : rows) seeds += r.point == point.index && r.ok;
  line += "," + std::to_string(seeds);
  for (std::size_t q = 0; q < quantities; ++q) {
    const Stats s = point_stats(point.index, q, rows);
    line += "," + cell(s.mean) + "," + cell(s.se) + "," + cell(s.min) + "," + cell(s.max);
  }
  line += theory.stable ? (*theory.stable ? ",true" : ",false") : ",";
  line += "," + cell(theory.trace_S_bar) + "," + cell(theory.trace_V_bar) + "," + cell(theory.critical_margin);
  line += "," + cell(theory.trace_P_sampled) + "," + cell(theory.trace_P_sampled_se);
  return line;
}

std::vector<RunRow> read_runs_csv(std::istream& in, const std::vector<Vary>& vary,
                                  const std::vector<std::string>& quantities) {
  std::string line;
  if (!std::getline(in, line)) return {};
  if (line != runs_header(vary, quantities))
    throw std::runtime_error("runs.csv has another header than this sweep's (another scenario or --vary?)");
  std::vector<RunRow> rows;
  const std::size_t columns = 3 + vary.size() + quantities.size();
  for (int number = 2; std::getline(in, line); ++number) {
    if (line.empty()) continue;
    const auto cells = split_csv(line);
    // A line cut by a kill mid-write is not a run: it is run again.
    if (cells.size() != columns) continue;
    RunRow r;
    r.point = parse_int(cells[0], number);
    r.seed = parse_int(cells[1], number);
    const std::string& status = cells[2 + vary.size()];
    if (status != "ok" && status != "failed")
      throw std::runtime_error("runs.csv line " + std::to_string(number) + ": status '" + status + "'");
    r.ok = status == "ok";
    for (std::size_t q = 0; q < quantities.size(); ++q) r.values.push_back(parse_cell(cells[3 + vary.size() + q], number));
    rows.push_back(std::move(r));
  }
  return rows;
}

std::set<std::pair<int, int>> done_runs(const std::vector<RunRow>& rows) {
  std::set<std::pair<int, int>> done;
  for (const auto& r : rows)
    if (r.ok) done.insert({r.point, r.seed});
  return done;
}

}  // namespace netkf::cli::sweep
