// The trace a link had in a recording (trace_extract.hpp).
#include "netkf/cli/recording/trace_extract.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "netkf/cli/recording/recording.hpp"  // is_mcap_path
#include "netkf/model/scenario.hpp"
#include "netkf/support/input_file.hpp"

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

// The longest line a samples CSV may have (a row is k, sensor, stamp, flags and m numbers of
// at most 24 characters: far below this for any measurement size a scenario runs).
constexpr std::size_t kMaxLine = 1u << 20;

[[noreturn]] void refuse(const std::string& where, const std::string& what) {
  throw std::runtime_error(where + ": " + what);
}

std::string shown(std::string_view text) {
  constexpr std::size_t kShown = 40;
  return "'" + std::string(text.substr(0, kShown)) + (text.size() > kShown ? "...'" : "'");
}

template <typename T>
T integer_field(std::string_view text, const std::string& where, const char* name) {
  T v{};
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec == std::errc::result_out_of_range) refuse(where, std::string(name) + " is out of range, got " + shown(text));
  if (text.empty() || ec != std::errc() || ptr != text.data() + text.size())
    refuse(where, std::string(name) + " must be an integer, got " + shown(text));
  return v;
}

void number_field(std::string_view text, const std::string& where, const std::string& name, bool may_be_empty) {
  if (text.empty() && may_be_empty) return;
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec == std::errc::invalid_argument || ptr != text.data() + text.size())
    refuse(where, name + " must be a number, got " + shown(text));
}

bool flag_field(std::string_view text, const std::string& where, const std::string& name) {
  if (text != "0" && text != "1") refuse(where, name + " must be 0 or 1, got " + shown(text));
  return text == "1";
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> fields;
  for (std::size_t start = 0;;) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(line.substr(start, comma == line.npos ? line.npos : comma - start));
    if (comma == line.npos) return fields;
    start = comma + 1;
  }
}

/// One line without its end of line (CR LF too); false at the end of the file. `ended`: the
/// line had its '\n' (every row the recorder writes has one: a row without is cut).
bool next_line(std::streambuf& in, std::string& line, bool& ended, const std::string& where) {
  line.clear();
  ended = false;
  int c = in.sbumpc();
  if (c == std::char_traits<char>::eof()) return false;
  while (c != std::char_traits<char>::eof()) {
    if (c == '\n') {
      ended = true;
      break;
    }
    if (line.size() >= kMaxLine) refuse(where, "line longer than " + std::to_string(kMaxLine) + " characters");
    line.push_back(static_cast<char>(c));
    c = in.sbumpc();
  }
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return true;
}

/// The header's columns, checked as the recorder writes them: k,sensor_id,stamp,fused,
/// [fused_in_time,] y0, y1, ...
std::vector<std::string> samples_columns(std::string_view header, const std::string& where) {
  if (header.rfind("\xEF\xBB\xBF", 0) == 0) header.remove_prefix(3);  // a UTF-8 byte-order mark
  if (header.rfind("k,sensor_id,", 0) != 0)
    refuse(where, "not a samples CSV (its header starts with 'k,sensor_id,'; it is written by --record-samples)");
  std::vector<std::string> columns;
  for (const auto f : split(header)) columns.emplace_back(f);
  std::size_t i = 2;
  const auto expect = [&](const std::string& name) {
    if (i >= columns.size() || columns[i] != name)
      refuse(where, "bad header: column " + std::to_string(i + 1) + " must be '" + name + "', got " +
                        (i < columns.size() ? shown(columns[i]) : std::string("nothing")));
    ++i;
  };
  expect("stamp");
  expect("fused");
  if (i < columns.size() && columns[i] == "fused_in_time") ++i;
  for (int y = 0; i < columns.size(); ++y) expect("y" + std::to_string(y));
  return columns;
}

DeliveredSamples read_samples_csv(std::istream& in, const std::string& path) {
  DeliveredSamples s;
  std::string line;
  std::vector<std::string> columns;
  std::size_t line_no = 0;
  bool ended = false;
  auto& buf = *in.rdbuf();
  while (next_line(buf, line, ended, path + ":" + std::to_string(line_no + 1))) {
    ++line_no;
    const std::string where = path + ":" + std::to_string(line_no);
    if (line_no == 1) {
      columns = samples_columns(line, where);
      continue;
    }
    if (!ended) refuse(where, "the last row is cut (no end of line): the file is truncated");
    if (line.empty()) continue;
    const auto f = split(line);
    if (f.size() != columns.size())
      refuse(where, "a row of " + std::to_string(f.size()) + " fields, the header has " +
                        std::to_string(columns.size()));
    const auto k = integer_field<std::int64_t>(f[0], where, "k");
    const auto sensor = integer_field<int>(f[1], where, "sensor_id");
    number_field(f[2], where, "stamp", false);
    for (std::size_t i = 3; i < f.size(); ++i) {
      if (columns[i][0] == 'y') number_field(f[i], where, columns[i], /*may_be_empty=*/true);
      else flag_field(f[i], where, columns[i]);
    }
    add(s, sensor, k, where);
  }
  if (line_no == 0) throw std::runtime_error(path + ": empty file (a samples CSV starts with 'k,sensor_id,')");
  return s;
}

// The actuation link's arrivals: row k of a period CSV says in `nu` whether u_{k-1} reached the
// plant in time, so input k-1 was delivered. Every row's period is known, delivered or not.
void add_input(DeliveredSamples& s, std::int64_t row_k, bool arrived, const std::string& where) {
  if (row_k < 1) return;  // row 0: no input was due
  const std::int64_t k = row_k - 1;
  s.periods_by_sensor[kControlLinkId];  // the link is in the recording even if nothing arrived
  if (arrived) add(s, kControlLinkId, k, where);
  s.first_k = s.first_k ? std::min(*s.first_k, k) : k;
  s.last_k = s.last_k ? std::max(*s.last_k, k) : k;
}

DeliveredSamples read_inputs_csv(std::istream& in, const std::string& path) {
  DeliveredSamples s;
  std::string line;
  std::size_t columns = 0, line_no = 0;
  bool ended = false;
  auto& buf = *in.rdbuf();
  while (next_line(buf, line, ended, path + ":" + std::to_string(line_no + 1))) {
    ++line_no;
    const std::string where = path + ":" + std::to_string(line_no);
    const auto f = split(line);
    if (line_no == 1) {
      if (f.empty() || f[0] != "k" || f.back() != "nu")
        refuse(where, "not a period recording of a scenario with an actuation link (its header ends with nu; "
                      "record the run with --record RUN.csv)");
      columns = f.size();
      continue;
    }
    if (!ended) refuse(where, "the last row is cut (no end of line): the file is truncated");
    if (line.empty()) continue;
    if (f.size() != columns)
      refuse(where, "a row of " + std::to_string(f.size()) + " fields, the header has " + std::to_string(columns));
    add_input(s, integer_field<std::int64_t>(f[0], where, "k"), flag_field(f.back(), where, "nu"), where);
  }
  if (line_no == 0) throw std::runtime_error(path + ": empty file (a period recording starts with 'k,t,')");
  return s;
}

/// The codec of a ros2-profile file's CDR; none: refused, naming what is missing.
const ros2::Ros2Codec& cdr_codec(const ros2::Ros2Codec* codec, const std::string& path) {
  if (!codec) throw std::runtime_error(path + ": a ros2-profile MCAP (CDR messages), and no CDR decoder was given");
  return *codec;
}

/// Decodes one CDR message, naming the file when it is not the type's CDR.
template <class Decode>
auto decoded(Decode decode, const std::string& path) {
  try {
    return decode();
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

DeliveredSamples read_inputs_mcap(std::istream& in, const std::string& path, const ros2::Ros2Codec* codec) {
  DeliveredSamples s;
  read_mcap_messages(in, path, [&](const McapMessage& m) {
    if (m.topic == ros2::topic_info(ros2::Channel::truth).topic) {
      const auto& c = cdr_codec(codec, path);
      const Truth t = decoded([&] { return c.decode_truth(m.data); }, path);
      if (!t.u.empty()) add_input(s, t.k, t.input_arrived, path);  // no input: an open loop
      return;
    }
    if (m.topic != "netkf/truth") return;
    const auto j = nlohmann::json::parse(m.data, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("k") || !j["k"].is_number_integer())
      throw std::runtime_error(path + ": a truth message without an integer k");
    if (!j.contains("input_arrived")) return;  // an open loop
    if (!j["input_arrived"].is_boolean()) throw std::runtime_error(path + ": a truth's input_arrived is not a boolean");
    add_input(s, j["k"].get<std::int64_t>(), j["input_arrived"].get<bool>(), path);
  });
  return s;
}

DeliveredSamples read_samples_mcap(std::istream& in, const std::string& path, const ros2::Ros2Codec* codec) {
  DeliveredSamples s;
  read_mcap_messages(in, path, [&](const McapMessage& m) {
    if (m.topic == ros2::topic_info(ros2::Channel::delivered).topic) {
      const auto& c = cdr_codec(codec, path);
      const DeliveredMeasurement d = decoded([&] { return c.decode_delivered(m.data); }, path);
      add(s, d.sensor_id, d.k, path);
      return;
    }
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

namespace {
// A regular file only (the readers bound its records, lines and samples), read as MCAP by its
// name's `.mcap`, else as CSV.
template <class CsvReader, class McapReader>
DeliveredSamples read_recording(const std::string& path, CsvReader csv, McapReader mcap) {
  InputFile file(path, "recording", std::numeric_limits<std::uintmax_t>::max());
  return is_mcap_path(path) ? mcap(file.stream(), path) : csv(file.stream(), path);
}
}  // namespace

DeliveredSamples read_delivered_samples(const std::string& path, const ros2::Ros2Codec* codec) {
  DeliveredSamples s = read_recording(path, read_samples_csv, [codec](std::istream& in, const std::string& p) {
    return read_samples_mcap(in, p, codec);
  });
  if (!s.first_k)
    throw std::runtime_error(path + ": no delivered samples (record them with --record-samples; an MCAP has them "
                             "on netkf/measurement/delivered only then)");
  return s;
}

DeliveredSamples read_input_arrivals(const std::string& path, const ros2::Ros2Codec* codec) {
  DeliveredSamples s = read_recording(path, read_inputs_csv, [codec](std::istream& in, const std::string& p) {
    return read_inputs_mcap(in, p, codec);
  });
  if (!s.first_k)
    throw std::runtime_error(path + ": no control input was due in the recording (a closed loop over an actuation "
                             "link, plant.control.link, records whether each arrived)");
  return s;
}

LinkTrace extract_link_trace(const DeliveredSamples& samples, int sensor_id, std::optional<std::int64_t> first,
                             std::optional<std::int64_t> last) {
  const auto it = samples.periods_by_sensor.find(sensor_id);
  if (it == samples.periods_by_sensor.end()) {
    std::string ids;
    for (const auto& [id, periods] : samples.periods_by_sensor) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
    throw std::runtime_error("link " + link_name(sensor_id) + " delivered no sample in the recording (links with samples: " +
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

namespace {

constexpr std::string_view kRelayRecordHeader = "topic,index,sequence,bytes,fate,delay_ms";

// One row of a relay record: the topic is everything before the last five fields (a topic name
// may hold a comma; the numbers and the fate cannot).
void add_relay_row(RelayFates& fates, std::string_view line, const std::string& where) {
  std::array<std::string_view, 5> f;
  std::size_t end = line.size();
  for (std::size_t i = f.size(); i-- > 0;) {
    const std::size_t comma = line.rfind(',', end == 0 ? 0 : end - 1);
    if (comma == line.npos || end == 0) refuse(where, "a row of fewer than 6 fields");
    f[i] = line.substr(comma + 1, end - comma - 1);
    end = comma;
  }
  const std::string topic(line.substr(0, end));
  if (topic.empty()) refuse(where, "a row without a topic");
  const auto index = integer_field<std::uint64_t>(f[0], where, "index");
  integer_field<std::int64_t>(f[1], where, "sequence");
  integer_field<std::uint64_t>(f[2], where, "bytes");
  if (f[3] != "delivered" && f[3] != "dropped") refuse(where, "fate must be delivered or dropped, got " + shown(f[3]));
  double delay = 0.0;
  const auto [ptr, ec] = std::from_chars(f[4].data(), f[4].data() + f[4].size(), delay);
  if (f[4].empty() || ec != std::errc() || ptr != f[4].data() + f[4].size() || !std::isfinite(delay) || delay < 0.0)
    refuse(where, "delay_ms must be a number >= 0, got " + shown(f[4]));
  auto& topic_fates = fates.by_topic[topic];
  if (!topic_fates.emplace(index, RelayFates::Fate{f[3] == "delivered", delay}).second)
    refuse(where, "index " + std::to_string(index) + " of " + topic + " a second time");
  if (topic_fates.size() > max_trace_samples) refuse(where, "more samples of " + topic + " than a trace may have");
}

}  // namespace

bool is_relay_record(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string first;
  if (!in || !std::getline(in, first)) return false;
  if (!first.empty() && first.back() == '\r') first.pop_back();
  return first == kRelayRecordHeader;
}

RelayFates read_relay_fates(const std::string& path) {
  InputFile file(path, "recording", std::numeric_limits<std::uintmax_t>::max());
  auto& buf = *file.stream().rdbuf();
  RelayFates fates;
  std::string line;
  std::size_t line_no = 0;
  bool ended = false;
  while (next_line(buf, line, ended, path + ":" + std::to_string(line_no + 1))) {
    ++line_no;
    const std::string where = path + ":" + std::to_string(line_no);
    if (line_no == 1) {
      if (line != kRelayRecordHeader)
        refuse(where, "not a relay's record (its header is '" + std::string(kRelayRecordHeader) +
                          "'; it is written by netkf relay --record)");
      continue;
    }
    if (!ended) refuse(where, "the last row is cut (no end of line): the file is truncated");
    if (!line.empty()) add_relay_row(fates, line, where);
  }
  if (line_no == 0) throw std::runtime_error(path + ": empty file (a relay's record starts with its header)");
  return fates;
}

LinkTrace extract_topic_trace(const RelayFates& fates, const std::string& topic, std::optional<std::int64_t> first,
                              std::optional<std::int64_t> last) {
  const auto it = fates.by_topic.find(topic);
  if (it == fates.by_topic.end() || it->second.empty()) {
    std::string topics;
    for (const auto& [name, f] : fates.by_topic) topics += (topics.empty() ? "" : ", ") + name;
    throw std::runtime_error("topic " + topic + " has no sample in the record (topics: " +
                             (topics.empty() ? std::string("none") : topics) + ")");
  }
  const auto& by_index = it->second;
  const std::int64_t from = first.value_or(static_cast<std::int64_t>(by_index.begin()->first));
  const std::int64_t to = last.value_or(static_cast<std::int64_t>(by_index.rbegin()->first));
  if (from < 0 || to < from)
    throw std::runtime_error("no samples to extract (" + std::to_string(from) + ".." + std::to_string(to) + ")");
  if (static_cast<std::uint64_t>(to - from) >= max_trace_samples)
    throw std::runtime_error("indexes " + std::to_string(from) + ".." + std::to_string(to) +
                             " are more than a trace may have (" + std::to_string(max_trace_samples) + ")");
  LinkTrace t;
  t.first_k = static_cast<std::uint64_t>(from);
  for (auto k = static_cast<std::uint64_t>(from); k <= static_cast<std::uint64_t>(to); ++k) {
    const auto fate = by_index.find(k);
    if (fate == by_index.end())
      throw std::runtime_error("sample " + std::to_string(k) + " of " + topic +
                               " is not in the record (it is cut, or give --first/--last within it)");
    t.delivered.push_back(fate->second.delivered ? 1 : 0);
    t.delay_ms.push_back(fate->second.delivered ? fate->second.delay_ms : std::nan(""));
    t.has_delay = t.has_delay || (fate->second.delivered && fate->second.delay_ms > 0.0);
  }
  if (!t.has_delay) t.delay_ms.clear();
  return t;
}

}  // namespace netkf::cli
