// The trace a link had in a recording (trace_extract.hpp).
#include "trace_extract.hpp"

#include <charconv>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string_view>

#include "mcap_reader.hpp"

namespace netkf::cli {
namespace {

// The delivered samples a recording may hold: ten times a trace's bound (ten links).
constexpr std::size_t kMaxSamples = 10 * max_trace_samples;

void add(DeliveredSamples& s, int sensor, std::int64_t k, const std::string& where) {
  if (k < 0) throw std::runtime_error(where + ": a negative period " + std::to_string(k));
  auto& periods = s.periods_by_sensor[sensor];
  periods.insert(k);
  if (periods.size() > kMaxSamples) throw std::runtime_error(where + ": more samples than a recording may have");
  s.first_k = s.first_k ? std::min(*s.first_k, k) : k;
  s.last_k = s.last_k ? std::max(*s.last_k, k) : k;
}

template <typename T>
T field(std::string_view text, const std::string& where, const char* name) {
  T v{};
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || ptr != text.data() + text.size())
    throw std::runtime_error(where + ": " + name + " must be an integer, got '" + std::string(text.substr(0, 40)) + "'");
  return v;
}

DeliveredSamples read_samples_csv(std::istream& in, const std::string& path) {
  DeliveredSamples s;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string where = path + ":" + std::to_string(line_no);
    if (line_no == 1) {
      if (line.rfind("k,sensor_id,", 0) != 0)
        throw std::runtime_error(where + ": not a samples CSV (its header starts with 'k,sensor_id,'; "
                                 "it is written by --record-samples)");
      continue;
    }
    if (line.empty()) continue;
    const std::string_view row(line);
    const std::size_t c1 = row.find(',');
    const std::size_t c2 = c1 == row.npos ? row.npos : row.find(',', c1 + 1);
    if (c2 == row.npos) throw std::runtime_error(where + ": a row needs k and sensor_id");
    add(s, field<int>(row.substr(c1 + 1, c2 - c1 - 1), where, "sensor_id"),
        field<std::int64_t>(row.substr(0, c1), where, "k"), where);
  }
  if (line_no == 0) throw std::runtime_error(path + ": empty file (a samples CSV starts with 'k,sensor_id,')");
  return s;
}

DeliveredSamples read_samples_mcap(std::istream& in, const std::string& path) {
  DeliveredSamples s;
  read_mcap_messages(in, path, [&](const McapMessage& m) {
    if (m.topic != "netkf/measurement/delivered") return;
    const auto j = nlohmann::json::parse(m.data, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("k") || !j.contains("sensor_id") ||
        !j["k"].is_number_integer() || !j["sensor_id"].is_number_integer())
      throw std::runtime_error(path + ": a delivered message without integer k and sensor_id");
    add(s, j["sensor_id"].get<int>(), j["k"].get<std::int64_t>(), path);
  });
  return s;
}

}  // namespace

DeliveredSamples read_delivered_samples(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open the recording");
  const bool mcap = path.size() >= 5 && path.compare(path.size() - 5, 5, ".mcap") == 0;
  DeliveredSamples s = mcap ? read_samples_mcap(in, path) : read_samples_csv(in, path);
  if (!s.first_k)
    throw std::runtime_error(path + ": no delivered samples (record them with --record-samples; an MCAP has them "
                             "on netkf/measurement/delivered only then)");
  return s;
}

LinkTrace extract_link_trace(const DeliveredSamples& samples, int sensor_id, std::optional<std::int64_t> first,
                             std::optional<std::int64_t> last) {
  const auto it = samples.periods_by_sensor.find(sensor_id);
  if (it == samples.periods_by_sensor.end()) {
    std::string ids;
    for (const auto& [id, periods] : samples.periods_by_sensor) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
    throw std::runtime_error("link " + std::to_string(sensor_id) + " delivered no sample in the recording (links with samples: " +
                             ids + ")");
  }
  const std::int64_t from = first.value_or(*samples.first_k);
  const std::int64_t to = last.value_or(*samples.last_k);
  if (from < 0 || to < from)
    throw std::runtime_error("no periods to extract (" + std::to_string(from) + ".." + std::to_string(to) + ")");
  if (static_cast<std::uint64_t>(to - from) >= max_trace_samples)
    throw std::runtime_error("periods " + std::to_string(from) + ".." + std::to_string(to) + " are more than a trace may have (" +
                             std::to_string(max_trace_samples) + ")");
  LinkTrace t;
  t.first_k = static_cast<std::uint64_t>(from);
  t.delivered.assign(static_cast<std::size_t>(to - from + 1), 0);
  for (auto k = it->second.lower_bound(from); k != it->second.end() && *k <= to; ++k)
    t.delivered[static_cast<std::size_t>(*k - from)] = 1;
  return t;
}

}  // namespace netkf::cli
