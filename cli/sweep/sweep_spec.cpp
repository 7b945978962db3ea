#include "netkf/cli/sweep/sweep_spec.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <set>
#include <stdexcept>

#include "netkf/support/random.hpp"

namespace netkf::cli::sweep {
namespace {

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const auto pos = text.find(sep, start);
    parts.push_back(text.substr(start, pos == std::string::npos ? std::string::npos : pos - start));
    if (pos == std::string::npos) return parts;
    start = pos + 1;
  }
}

double number(const std::string& text, const std::string& what) {
  double v = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || !std::isfinite(v))
    throw std::invalid_argument(what + ": '" + text + "' is not a finite number");
  return v;
}

std::string format_value(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  return buf;
}

std::vector<std::string> range_values(const std::string& key, const std::vector<std::string>& parts) {
  const std::string what = "--vary " + key + " range FROM:TO:N";
  const double from = number(parts[0], what);
  const double to = number(parts[1], what);
  int n = 0;
  const auto [end, ec] = std::from_chars(parts[2].data(), parts[2].data() + parts[2].size(), n);
  if (parts[2].empty() || ec != std::errc() || end != parts[2].data() + parts[2].size() || n < 1 || n > 100000)
    throw std::invalid_argument(what + ": N must be a whole number from 1 to 100000, got '" + parts[2] + "'");
  std::vector<std::string> values;
  for (int i = 0; i < n; ++i)
    values.push_back(format_value(n == 1 ? from : from + (to - from) * static_cast<double>(i) / (n - 1)));
  return values;
}

// The YAML node a `sensors.ID` segment selects: every sensor with that id (or all, for `*`).
std::vector<YAML::Node> select_sensors(YAML::Node sensors, const std::string& segment, const std::string& key) {
  if (!sensors.IsSequence()) throw std::invalid_argument("--vary " + key + ": the scenario's sensors are not a list");
  std::vector<YAML::Node> out;
  for (std::size_t i = 0; i < sensors.size(); ++i) {
    YAML::Node s = sensors[i];
    if (segment == "*" || (s.IsMap() && s["id"] && s["id"].IsScalar() && s["id"].Scalar() == segment)) out.push_back(s);
  }
  if (out.empty()) throw std::invalid_argument("--vary " + key + ": no sensor with id " + segment + " in the scenario");
  return out;
}

void apply_path(YAML::Node node, const std::vector<std::string>& path, std::size_t at, const std::string& key,
                const std::string& value, bool parent_is_sensors) {
  const std::string& segment = path[at];
  const bool last = at + 1 == path.size();
  std::vector<YAML::Node> next;
  if (parent_is_sensors) {
    next = select_sensors(node, segment, key);
  } else if (node.IsSequence()) {
    std::size_t index = 0;
    const auto [end, ec] = std::from_chars(segment.data(), segment.data() + segment.size(), index);
    if (ec != std::errc() || end != segment.data() + segment.size() || index >= node.size())
      throw std::invalid_argument("--vary " + key + ": '" + segment + "' is not an index of a list of " +
                                  std::to_string(node.size()));
    next.push_back(node[index]);
  } else if (node.IsMap() || node.IsNull()) {
    if (last) {
      if (node[segment] && !node[segment].IsScalar() && !node[segment].IsNull())
        throw std::invalid_argument("--vary " + key + ": it names a mapping or list, not a value");
      node[segment] = value;
      return;
    }
    if (!node[segment]) node[segment] = YAML::Node(YAML::NodeType::Map);
    next.push_back(node[segment]);
  } else {
    throw std::invalid_argument("--vary " + key + ": '" + path[at - 1] + "' is a value, not a mapping or list");
  }
  for (auto& n : next) {
    if (last) {
      if (!n.IsScalar() && !n.IsNull())
        throw std::invalid_argument("--vary " + key + ": it names a mapping or list, not a value");
      n = value;
    } else {
      apply_path(n, path, at + 1, key, value, !parent_is_sensors && at == 0 && segment == "sensors");
    }
  }
}

}  // namespace

Vary parse_vary(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos) throw std::invalid_argument("--vary '" + text + "': write KEY=V1,V2,... or KEY=FROM:TO:N");
  Vary v;
  v.key = text.substr(0, eq);
  const std::string rhs = text.substr(eq + 1);
  if (v.key.empty()) throw std::invalid_argument("--vary '" + text + "': no key before '='");
  for (const auto& seg : split(v.key, '.'))
    if (seg.empty()) throw std::invalid_argument("--vary '" + text + "': the key has an empty segment");
  const auto colon = split(rhs, ':');
  if (colon.size() == 3 && rhs.find(',') == std::string::npos) {
    v.values = range_values(v.key, colon);
    return v;
  }
  v.values = split(rhs, ',');
  for (const auto& value : v.values)
    if (value.empty()) throw std::invalid_argument("--vary '" + text + "': an empty value");
  return v;
}

void check_grid_size(const std::vector<Vary>& vary, int seeds) {
  // Saturating: two axes of 10^5 values overflow nothing, and a product past the limit stays past it.
  constexpr std::uint64_t cap = std::uint64_t{1} << 62;
  std::uint64_t points = 1;
  std::string factors;
  for (const auto& v : vary) {
    const auto n = static_cast<std::uint64_t>(v.values.size());
    points = n != 0 && points > cap / n ? cap : points * n;
    factors += (factors.empty() ? "" : " x ") + std::to_string(n);
  }
  const auto s = static_cast<std::uint64_t>(std::max(seeds, 1));
  const std::uint64_t runs = points > cap / s ? cap : points * s;
  if (runs <= kMaxRuns) return;
  auto count = [cap](std::uint64_t n) { return n >= cap ? std::string("more than 4.6e18") : std::to_string(n); };
  throw std::invalid_argument("the grid is " + (vary.size() > 1 ? factors + " = " : std::string()) + count(points) +
                              " points x " + std::to_string(s) + " seeds = " + count(runs) +
                              " runs; a sweep takes at most " + std::to_string(kMaxRuns) +
                              " runs (fewer --vary values or --seeds, or several sweeps)");
}

std::vector<Point> expand_grid(const std::vector<Vary>& vary) {
  std::set<std::string> keys;
  for (const auto& v : vary)
    if (!keys.insert(v.key).second) throw std::invalid_argument("--vary " + v.key + " is given twice");
  std::vector<Point> grid{Point{}};
  for (const auto& v : vary) {
    std::vector<Point> next;
    for (const auto& p : grid)
      for (const auto& value : v.values) {
        Point q = p;
        q.values.push_back(value);
        next.push_back(std::move(q));
      }
    grid = std::move(next);
  }
  for (std::size_t i = 0; i < grid.size(); ++i) grid[i].index = static_cast<int>(i);
  return grid;
}

std::uint64_t run_seed(std::uint64_t scenario_seed, int seed_index) {
  return derive_seed(scenario_seed, "sweep", static_cast<std::uint64_t>(seed_index));
}

void apply_key(YAML::Node root, const std::string& key, const std::string& value) {
  const auto path = split(key, '.');
  for (const auto& seg : path)
    if (seg.empty()) throw std::invalid_argument("--vary " + key + ": the key has an empty segment");
  if (!root.IsMap()) throw std::invalid_argument("the scenario is not a YAML mapping");
  apply_path(root, path, 0, key, value, false);
}

std::string point_label(const std::vector<Vary>& vary, const Point& point) {
  if (vary.empty()) return "the scenario";
  std::string out;
  for (std::size_t i = 0; i < vary.size() && i < point.values.size(); ++i)
    out += (i ? ", " : "") + vary[i].key + "=" + point.values[i];
  return out;
}

}  // namespace netkf::cli::sweep
