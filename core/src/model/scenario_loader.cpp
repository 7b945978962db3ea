// Reading a scenario from YAML (docs/scenario-format.md): structure and types are
// checked here, while walking the document, so that every message can carry the
// line and column of the offending node; the meaning (dimensions, definiteness,
// probabilities, duplicate ids, ...) is checked by validate_scenario() with the
// marks recorded here, so programmatic scenarios get exactly the same checks.
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>
#include <yaml-cpp/yaml.h>

#include "netkf/links/link_keys.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/relay/relay_config.hpp"
#include "netkf/support/input_file.hpp"

namespace netkf {
namespace {

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) {
    if (!out.empty()) out += ", ";
    out += n;
  }
  return out;
}

// A value as messages show it: a scalar's first line, cut at 40 characters (a message
// names the offending value; it never prints a whole file that was not YAML).
std::string describe(const YAML::Node& node) {
  constexpr std::size_t kShown = 40;
  switch (node.Type()) {
    case YAML::NodeType::Null: return "nothing (null)";
    case YAML::NodeType::Scalar: {
      const std::string& text = node.Scalar();
      const std::size_t cut = std::min(text.find('\n'), kShown);
      return "'" + text.substr(0, cut) + (cut < text.size() ? "...'" : "'");
    }
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Map: return "a mapping";
    default: return "nothing";
  }
}

bool valid(const YAML::Mark& m) { return m.line >= 0 && m.column >= 0; }

// The documents of a YAML stream, counted without YAML::LoadAll: yaml-cpp 0.7's LoadAll
// never ends on some malformed streams ("[0],": the parser keeps yielding empty documents
// without consuming the input; yaml-cpp issue #1040), which hung the loader. As yaml-cpp's
// later fix does, the count stops at the first empty document.
struct DocumentCount {
  int count = 0;
  YAML::Mark second = YAML::Mark::null_mark();  // where the second document starts
};

class DocumentEvents : public YAML::EventHandler {
 public:
  bool empty = true;  // the document so far is nothing (null) at most
  YAML::Mark first = YAML::Mark::null_mark();  // its root node
  void OnDocumentStart(const YAML::Mark&) override { empty = true; }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { node(mark); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t, const std::string&) override { node(mark); }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(mark);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(mark);
  }
  void OnMapEnd() override {}

 private:
  void node(const YAML::Mark& mark) {
    if (empty) first = mark;
    empty = false;
  }
};

DocumentCount count_documents(const std::string& text) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  DocumentEvents events;
  DocumentCount result;
  while (parser.HandleNextDocument(events) && !events.empty) {
    if (++result.count == 2) result.second = events.first;
  }
  return result;
}

// A mapping whose keys were checked against the allowed set.
struct MapView {
  std::string path;
  YAML::Mark mark;
  std::map<std::string, YAML::Node> values;
  bool has(const std::string& key) const { return values.count(key) != 0; }
};

class Loader {
 public:
  explicit Loader(std::string source) : source_(source.empty() ? "<scenario>" : std::move(source)) {}

  Scenario load(const std::string& text) {
    YAML::Node root;
    DocumentCount documents;
    try {
      documents = count_documents(text);
      root = YAML::Load(text);
    } catch (const YAML::ParserException& e) {
      fail(e.mark, "YAML syntax error: " + e.msg);
    }
    if (documents.count == 0 || root.IsNull())
      fail(YAML::Mark::null_mark(), "the scenario file is empty (expected a mapping with at least 'period_ms', 'plant' and 'sensors')");
    if (documents.count > 1)
      fail(documents.second, "the file holds " + std::to_string(documents.count) + " YAML documents, expected one scenario");

    Scenario s;
    s.source = source_;
    const MapView top = open_map(root, "", YAML::Mark::null_mark(),
                                 {"name", "period_ms", "seed", "naming", "plant", "sensors", "estimator", "events"});
    s.name = top.has("name") ? read_string(top.values.at("name"), "name") : default_name();
    s.period_ms = read_int(require(top, "period_ms"), "period_ms");
    // Optional: a scenario without a seed is still reproducible (seed 0).
    if (top.has("seed")) s.seed = read_seed(top.values.at("seed"));
    if (top.has("naming")) {
      const YAML::Node& v = top.values.at("naming");
      const auto naming = topic_naming_from_string(read_string(v, "naming"));
      if (!naming) fail(v.Mark(), "naming must be netkf or ros2, got " + describe(v));
      s.naming = *naming;
    }
    read_plant(require(top, "plant"), s.plant);
    read_sensors(require(top, "sensors"), s.sensors);
    if (top.has("estimator")) read_estimator(top.values.at("estimator"), s.estimator);
    if (top.has("events")) s.events = read_events(top.values.at("events"), "events", s);

    complete_scenario(s, [this](const std::string& path) { return locate(path); });
    return s;
  }

  // An events file's list: `events: [...]` or the bare list (a launch's and a relay's alike).
  YAML::Node events_list(const std::string& text) {
    YAML::Node root;
    try {
      root = YAML::Load(text);
    } catch (const YAML::ParserException& e) {
      fail(e.mark, "YAML syntax error: " + e.msg);
    }
    // An empty file is more likely a mistake (a truncated copy, the wrong file) than a replay
    // without changes, which --record writes as `events: []`.
    if (root.IsNull())
      fail(YAML::Mark::null_mark(), "the events file is empty (expected 'events:' with a list of link changes; "
                                    "'events: []' for none)");
    if (root.IsScalar())
      fail(root.Mark(), "an events file is 'events:' with a list of link changes, got plain text (is this a YAML file?)");
    if (!root.IsMap()) return root;
    const MapView top = open_map(root, "", YAML::Mark::null_mark(), {"events"});
    return require(top, "events");
  }

  // An events file for `scenario`'s links and period.
  std::vector<LinkEvent> load_events(const std::string& text, const Scenario& scenario) {
    std::vector<LinkEvent> events = read_events(events_list(text), "events", scenario);
    // Checked as they will run: before the scenario's own events of the same period, and
    // together with its timeline (an event may rely on an earlier change of the scenario's).
    // The replayed events come first, so the messages' events[i] are this file's.
    Scenario check = scenario;
    check.events = events;
    check.events.insert(check.events.end(), scenario.events.begin(), scenario.events.end());
    validate_scenario(check, [this](const std::string& path) { return locate(path); });
    return events;
  }

  // A relay file (netkf/relay/relay_config.hpp).
  RelayConfig load_relay(const std::string& text) {
    YAML::Node root;
    try {
      root = YAML::Load(text);
    } catch (const YAML::ParserException& e) {
      fail(e.mark, "YAML syntax error: " + e.msg);
    }
    if (root.IsNull() || !root.IsMap())
      fail(root.IsNull() ? YAML::Mark::null_mark() : root.Mark(),
           "a relay file is a mapping with 'relay:' (from_domain, to_domain, topics), got " +
               (root.IsNull() ? std::string("nothing") : describe(root)));
    const MapView top = open_map(root, "", YAML::Mark::null_mark(), {"relay", "events"});
    const YAML::Node& node = require(top, "relay");
    const MapView m = open_map(node, "relay", mark_of(node, "relay"), {"from_domain", "to_domain", "seed", "depth", "topics"});
    RelayConfig c;
    auto domain = [&](const std::string& key) {
      const std::string path = "relay." + key;
      const YAML::Node& n = require(m, key);
      const int d = read_int(n, path);
      if (d < 0 || d > 232) fail(mark_of(n, path), path + " must be a DDS domain id in [0, 232], got " + n.Scalar());
      return d;
    };
    c.from_domain = domain("from_domain");
    c.to_domain = domain("to_domain");
    if (c.to_domain == c.from_domain)
      fail(mark_of(m.values.at("to_domain"), "relay.to_domain"),
           "relay.to_domain must differ from relay.from_domain (the relay would relay its own samples)");
    if (m.has("seed")) c.seed = read_seed(m.values.at("seed"));
    if (m.has("depth")) {
      c.depth = read_int(m.values.at("depth"), "relay.depth");
      if (c.depth < 1 || c.depth > 100000)
        fail(mark_of(m.values.at("depth"), "relay.depth"), "relay.depth must be in [1, 100000], got " + std::to_string(c.depth));
    }
    const YAML::Node& topics = require(m, "topics");
    if (!topics.IsSequence() || topics.size() == 0)
      fail(mark_of(topics, "relay.topics"), "relay.topics must be a non-empty list of {name, link}, got " + describe(topics));
    std::map<std::string, std::size_t> seen;
    for (std::size_t i = 0; i < topics.size(); ++i) {
      const std::string at = "relay.topics[" + std::to_string(i) + "]";
      const YAML::Node t = topics[i];
      const MapView tm = open_map(t, at, t.Mark(), {"name", "type", "link", "per_writer"});
      RelayTopic topic;
      topic.name = read_string(require(tm, "name"), at + ".name");
      if (const auto [it, fresh] = seen.emplace(topic.name, i); !fresh)
        fail(mark_of(tm.values.at("name"), at + ".name"),
             "topic " + topic.name + " is relayed twice (also relay.topics[" + std::to_string(it->second) + "])");
      if (tm.has("type")) topic.type = read_string(tm.values.at("type"), at + ".type");
      topic.link = read_link(require(tm, "link"), at + ".link");
      if (tm.has("per_writer")) topic.per_writer = read_bool(tm.values.at("per_writer"), at + ".per_writer");
      c.topics.push_back(std::move(topic));
    }
    // Beside `relay:`, as a scenario's `events:` is beside its links.
    if (top.has("events")) c.events = read_relay_events(top.values.at("events"), "events", c);
    return c;
  }

  // An events file of a relay (`events: [...]` or the bare list, as --record's journal writes
  // it), for the relay `c`'s topics.
  std::vector<RelayEvent> load_relay_events(const std::string& text, const RelayConfig& c) {
    return read_relay_events(events_list(text), "events", c);
  }

 private:
  [[noreturn]] void fail(const YAML::Mark& mark, const std::string& message) const {
    std::string prefix = source_;
    if (valid(mark)) prefix += ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
    throw ScenarioError(prefix + ": " + message);
  }

  std::string default_name() const {
    const std::string stem = std::filesystem::path(source_).stem().string();
    return stem.empty() ? "scenario" : stem;
  }

  // Location of a key path for validate_scenario: the path itself, else its closest
  // recorded ancestor (a defaulted field is reported where its parent is).
  SourceLocation locate(std::string path) const {
    while (true) {
      const auto it = marks_.find(path);
      if (it != marks_.end() && valid(it->second)) return {source_, it->second.line + 1, it->second.column + 1};
      const auto cut = path.find_last_of(".[");
      if (cut == std::string::npos || path.empty()) break;
      path.erase(cut);
    }
    return {source_, 0, 0};
  }

  static std::string child(const std::string& parent, const std::string& key) {
    return parent.empty() ? key : parent + "." + key;
  }

  // `key_mark`: where the key naming this mapping is (messages about the mapping as a
  // whole point there, not at its first entry); null for the document itself.
  MapView open_map(const YAML::Node& node, const std::string& path, const YAML::Mark& key_mark,
                   const std::vector<std::string>& allowed) {
    const YAML::Mark at = valid(key_mark) ? key_mark : node.Mark();
    const std::string what = path.empty() ? "the scenario" : path;
    // A whole document that is one scalar is a file of another kind (a text, a CSV): named as
    // such, its text not shown.
    if (!node.IsMap())
      fail(at, what + " must be a mapping (key: value), got " +
                   (path.empty() && node.IsScalar() ? std::string("plain text (is this a YAML file?)") : describe(node)));
    MapView view{path, at, {}};
    std::map<std::string, YAML::Mark> key_marks;
    for (const auto& kv : node) {
      if (!kv.first.IsScalar()) fail(kv.first.Mark(), "keys in " + what + " must be plain names");
      const std::string key = kv.first.Scalar();
      bool known = false;
      for (const auto& a : allowed) known = known || key == a;
      if (!known)
        fail(kv.first.Mark(), "unknown key '" + key + "' in " + (path.empty() ? "the top level" : path) +
                                  " (expected one of: " + join(allowed) + ")");
      if (const auto prev = key_marks.find(key); prev != key_marks.end())
        fail(kv.first.Mark(), "duplicate key '" + key + "' in " + (path.empty() ? "the top level" : path) +
                                  " (first at line " + std::to_string(prev->second.line + 1) + ")");
      key_marks[key] = kv.first.Mark();
      view.values[key] = kv.second;
      // Where validate_scenario() reports problems with this field: its key, which is on
      // the line the user reads the name on (a block value starts on the next line).
      marks_[child(path, key)] = kv.first.Mark();
    }
    return view;
  }

  const YAML::Node& require(const MapView& map, const std::string& key) const {
    const auto it = map.values.find(key);
    if (it == map.values.end()) fail(map.mark, "missing required key '" + child(map.path, key) + "'");
    return it->second;
  }

  // The key of a field when it has one, else the node itself (list elements).
  YAML::Mark mark_of(const YAML::Node& node, const std::string& path) const {
    const auto it = marks_.find(path);
    if (it != marks_.end() && valid(it->second)) return it->second;
    return node.Mark();
  }

  std::string read_string(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar() || node.Scalar().empty())
      fail(mark_of(node, path), path + " must be a non-empty string, got " + describe(node));
    return node.Scalar();
  }

  double read_double(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar()) fail(mark_of(node, path), path + " must be a number, got " + describe(node));
    double value = 0.0;
    // yaml-cpp's conversion requires the whole scalar to be a number and knows .inf/.nan.
    if (!YAML::convert<double>::decode(node, value))
      fail(node.Mark(), path + " must be a number, got " + describe(node));
    if (!std::isfinite(value)) fail(node.Mark(), path + " must be a finite number, got " + describe(node));
    return value;
  }

  long long read_integer(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar()) fail(mark_of(node, path), path + " must be an integer, got " + describe(node));
    const std::string& text = node.Scalar();
    long long value = 0;
    const char* first = text.data();
    const char* last = text.data() + text.size();
    if (first != last && *first == '+') ++first;
    const auto [end, ec] = std::from_chars(first, last, value);
    if (ec == std::errc::result_out_of_range && end == last)
      fail(node.Mark(), path + " is out of range (at most " + std::to_string(std::numeric_limits<long long>::max()) +
                            "), got " + describe(node));
    if (ec != std::errc{} || end != last || first == last)
      fail(node.Mark(), path + " must be an integer, got " + describe(node));
    return value;
  }

  bool read_bool(const YAML::Node& node, const std::string& path) const {
    bool value = false;
    if (!node.IsScalar() || !YAML::convert<bool>::decode(node, value))
      fail(mark_of(node, path), path + " must be true or false, got " + describe(node));
    return value;
  }

  int read_int(const YAML::Node& node, const std::string& path) const {
    const long long v = read_integer(node, path);
    if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
      fail(node.Mark(), path + " is out of range, got " + node.Scalar());
    return static_cast<int>(v);
  }

  std::uint64_t read_seed(const YAML::Node& node) const {
    if (!node.IsScalar()) fail(mark_of(node, "seed"), "seed must be a non-negative integer, got " + describe(node));
    try {
      return parse_seed(node.Scalar());
    } catch (const std::invalid_argument& e) {
      fail(node.Mark(), e.what());
    }
    return 0;
  }

  // Matrices are nested lists, row-major: [[a, b], [c, d]].
  Matrix read_matrix(const YAML::Node& node, const std::string& path) const {
    const YAML::Mark at = mark_of(node, path);
    if (!node.IsSequence() || node.size() == 0)
      fail(at, path + " must be a matrix written as a non-empty list of rows, e.g. [[1.0, 0.0], [0.0, 1.0]], got " +
                   describe(node));
    const std::size_t rows = node.size();
    std::size_t cols = 0;
    for (std::size_t i = 0; i < rows; ++i) {
      const YAML::Node row = node[i];
      const std::string row_path = path + "[" + std::to_string(i) + "]";
      if (!row.IsSequence() || row.size() == 0)
        fail(valid(row.Mark()) ? row.Mark() : at,
             row_path + " must be a non-empty list of numbers (a matrix row, e.g. " + path + ": [[1.0]]), got " +
                 describe(row));
      if (i == 0) cols = row.size();
      if (row.size() != cols)
        fail(row.Mark(), path + " is ragged: row " + std::to_string(i) + " has " + std::to_string(row.size()) +
                             " entries but row 0 has " + std::to_string(cols));
    }
    Matrix M(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
    for (std::size_t i = 0; i < rows; ++i)
      for (std::size_t j = 0; j < cols; ++j)
        M(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
            read_double(node[i][j], path + "[" + std::to_string(i) + "][" + std::to_string(j) + "]");
    return M;
  }

  Vector read_vector(const YAML::Node& node, const std::string& path) const {
    if (!node.IsSequence() || node.size() == 0)
      fail(mark_of(node, path), path + " must be a non-empty list of numbers, e.g. [0.0, 0.0], got " + describe(node));
    Vector v(static_cast<Eigen::Index>(node.size()));
    for (std::size_t i = 0; i < node.size(); ++i)
      v(static_cast<Eigen::Index>(i)) = read_double(node[i], path + "[" + std::to_string(i) + "]");
    return v;
  }

  double read_positive(const YAML::Node& node, const std::string& path) const {
    const double v = read_double(node, path);
    if (v <= 0.0) fail(node.Mark(), path + " must be > 0, got " + node.Scalar());
    return v;
  }

  void read_plant(const YAML::Node& node, PlantSpec& plant) {
    const MapView m = open_map(node, "plant", marks_["plant"], {"A", "Q", "B", "control", "x0", "P0", "state_bound"});
    plant.A = read_matrix(require(m, "A"), "plant.A");
    plant.Q = read_matrix(require(m, "Q"), "plant.Q");
    const auto n = plant.A.rows();
    plant.x0 = m.has("x0") ? read_vector(m.values.at("x0"), "plant.x0") : Vector::Zero(n);
    plant.P0 = m.has("P0") ? read_matrix(m.values.at("P0"), "plant.P0") : Matrix::Identity(n, n);
    if (m.has("state_bound")) plant.state_bound = read_positive(m.values.at("state_bound"), "plant.state_bound");
    if (m.has("B")) plant.B = read_matrix(m.values.at("B"), "plant.B");
    if (m.has("control")) {
      const MapView c = open_map(m.values.at("control"), "plant.control", marks_["plant.control"],
                                 {"gain", "lqr", "link", "on_loss", "acknowledged"});
      ControlSpec control;
      if (c.has("gain") && c.has("lqr"))
        fail(c.mark, "plant.control takes either 'gain' or 'lqr', not both (the LQR weights define the gain)");
      if (!c.has("gain") && !c.has("lqr"))
        fail(c.mark, "plant.control needs 'gain' (a p x n matrix) or 'lqr' (with Qx and Ru)");
      if (c.has("gain")) control.gain = read_matrix(c.values.at("gain"), "plant.control.gain");
      if (c.has("lqr")) {
        const MapView l = open_map(c.values.at("lqr"), "plant.control.lqr", marks_["plant.control.lqr"], {"Qx", "Ru"});
        control.lqr_Qx = read_matrix(require(l, "Qx"), "plant.control.lqr.Qx");
        control.lqr_Ru = read_matrix(require(l, "Ru"), "plant.control.lqr.Ru");
      }
      // The actuation link: the same keys and rules as a sensor's link.
      if (c.has("link")) control.link = read_link(c.values.at("link"), "plant.control.link");
      if (c.has("on_loss")) {
        const YAML::Node& v = c.values.at("on_loss");
        const std::string word = read_string(v, "plant.control.on_loss");
        if (word == "zero") control.on_loss = OnLoss::zero;
        else if (word == "hold") control.on_loss = OnLoss::hold;
        else fail(v.Mark(), "plant.control.on_loss must be zero or hold, got '" + word + "'");
      }
      if (c.has("acknowledged")) control.acknowledged = read_bool(c.values.at("acknowledged"), "plant.control.acknowledged");
      plant.control = std::move(control);
    }
  }

  void read_sensors(const YAML::Node& node, std::vector<SensorSpec>& sensors) {
    if (!node.IsSequence())
      fail(mark_of(node, "sensors"), "sensors must be a list of sensors (- id: ..., C: ..., R: ..., link: ...), got " +
                                         describe(node));
    for (std::size_t k = 0; k < node.size(); ++k) {
      const std::string at = "sensors[" + std::to_string(k) + "]";
      marks_[at] = node[k].Mark();
      const MapView m = open_map(node[k], at, marks_[at], {"id", "C", "R", "link"});
      SensorSpec sensor;
      sensor.id = read_int(require(m, "id"), at + ".id");
      sensor.C = read_matrix(require(m, "C"), at + ".C");
      sensor.R = read_matrix(require(m, "R"), at + ".R");
      sensor.link = read_link(require(m, "link"), at + ".link");
      sensors.push_back(std::move(sensor));
    }
  }

  // A link's keys (a sensor's link, an event's `set` or ramp target). Names, types and
  // combinations are the link type's rules (netkf/links/link_keys.hpp), the same for ctl and the dashboard.
  LinkKeys read_link_keys(const YAML::Node& node, const std::string& at, const YAML::Mark& where) {
    if (!node.IsMap())
      fail(where, at + " must be a mapping such as { model: bernoulli, loss: 0.1 }, got " + describe(node));
    const MapView m = open_map(node, at, where, link_key_names());
    LinkKeys keys;
    for (const auto& name : link_key_names()) {
      if (!m.has(name)) continue;
      const std::string path = child(at, name);
      if (name == "trace") {
        keys.push_back({name, resolve_trace_path(read_string(m.values.at(name), path))});
      } else if (link_key_is_word(name)) {
        keys.push_back({name, read_string(m.values.at(name), path)});
      } else {
        keys.push_back({name, read_double(m.values.at(name), path)});
      }
    }
    return keys;
  }

  // A trace file is named relative to the scenario file's directory (a scenario that is not
  // a file: the working directory), and kept absolute, so that the link means the same file
  // in the channel, a journal's replay or a copy of the scenario written elsewhere.
  std::string resolve_trace_path(const std::string& name) const {
    const std::filesystem::path p(name);
    if (name.empty() || p.is_absolute()) return name;
    std::error_code ec;
    const auto full = std::filesystem::absolute(std::filesystem::path(source_).parent_path() / p, ec);
    return (ec ? std::filesystem::path(source_).parent_path() / p : full).lexically_normal().string();
  }

  [[noreturn]] void fail_link(const LinkError& e, const YAML::Node& node, const std::string& at) const {
    fail(mark_of(node, child(at, e.key())), link_error_at(at, e));
  }

  LinkSpec read_link(const YAML::Node& node, const std::string& at) {
    const YAML::Mark where = mark_of(node, at);
    const LinkKeys keys = read_link_keys(node, at, where);
    if (std::none_of(keys.begin(), keys.end(), [](const LinkKey& k) { return k.name == "model"; }))
      fail(where, "missing required key '" + at + ".model' (" + link_model_choices() + ")");
    try {
      return link_from_keys(keys);
    } catch (const LinkError& e) {
      fail_link(e, node, at);
    }
  }

  // An event's change: `set: { LINK KEYS }` or `ramp: { to: { LINK KEYS }, DURATION }` (a
  // scenario's and a relay's events alike). Returns the ramp's mapping, whose duration keys
  // (`durations`, shown in messages as `duration_form`) are the caller's to read.
  std::optional<MapView> read_set_or_ramp(const MapView& m, const std::string& path, const std::string& duration_form,
                                          const std::vector<std::string>& durations, LinkEvent::Kind& kind,
                                          LinkKeys& keys) {
    if (m.has("set") == m.has("ramp"))
      fail(m.mark, path + " needs exactly one of set: { LINK KEYS } or ramp: { to: { LINK KEYS }, " + duration_form + " }");
    if (m.has("set")) {
      kind = LinkEvent::Kind::set;
      keys = read_link_keys(m.values.at("set"), path + ".set", mark_of(m.values.at("set"), path + ".set"));
      return std::nullopt;
    }
    kind = LinkEvent::Kind::ramp;
    const std::string rp = path + ".ramp";
    std::vector<std::string> allowed{"to"};
    allowed.insert(allowed.end(), durations.begin(), durations.end());
    MapView r = open_map(m.values.at("ramp"), rp, mark_of(m.values.at("ramp"), rp), allowed);
    keys = read_link_keys(require(r, "to"), rp + ".to", mark_of(require(r, "to"), rp + ".to"));
    for (const auto& k : keys)
      if (link_key_is_word(k.name))
        fail(mark_of(r.values.at("to"), rp + ".to." + k.name),
             rp + ".to." + k.name + ": a ramp moves numbers; change " + k.name + " with set");
    return r;
  }

  // `events:`: when each link changes. Which keys are valid for the link at that point is
  // checked by validate_scenario(), which replays the events in order.
  std::vector<LinkEvent> read_events(const YAML::Node& node, const std::string& at, const Scenario& s) {
    if (!node.IsSequence())
      fail(mark_of(node, at), at + " must be a list such as - { at_period: 300, link: 2, set: { loss: 1.0 } }, got " +
                                  describe(node));
    std::vector<LinkEvent> events;
    for (std::size_t i = 0; i < node.size(); ++i) {
      const std::string path = at + "[" + std::to_string(i) + "]";
      marks_[path] = node[i].Mark();
      const MapView m = open_map(node[i], path, marks_[path], {"at_period", "at_s", "link", "set", "ramp"});
      LinkEvent e;
      if (m.has("at_period") == m.has("at_s"))
        fail(m.mark, path + " needs exactly one of at_period (a period index) or at_s (seconds from the start)");
      if (m.has("at_period")) {
        const YAML::Node& v = m.values.at("at_period");
        e.at_period = read_integer(v, path + ".at_period");
        if (e.at_period < 0) fail(v.Mark(), path + ".at_period: the event is before period 0, got " + v.Scalar());
      } else {
        const YAML::Node& v = m.values.at("at_s");
        const double seconds = read_double(v, path + ".at_s");
        if (seconds < 0.0) fail(v.Mark(), path + ".at_s: the event is before the start (period 0), got " + v.Scalar());
        e.at_period = periods_in(seconds, s, v, path + ".at_s");
      }
      const YAML::Node& link = require(m, "link");
      // A sensor id, or `control` for the actuation link (plant.control.link).
      if (link.IsScalar() && link.Scalar() == kControlLinkName) e.link = kControlLinkId;
      else e.link = read_int(link, path + ".link");
      if (e.link == kControlLinkId ? !s.actuation_link() : !s.find_sensor(e.link)) {
        std::string ids;
        for (const auto& sensor : s.sensors) ids += (ids.empty() ? "" : ", ") + std::to_string(sensor.id);
        if (s.actuation_link()) ids += std::string(", ") + kControlLinkName;
        fail(mark_of(link, path + ".link"),
             path + ".link: unknown link " + link_name(e.link) + " (the scenario's links: " + ids + ")");
      }
      if (const auto r = read_set_or_ramp(m, path, "over_s: S", {"over_s", "over_periods"}, e.kind, e.keys)) {
        const std::string rp = path + ".ramp";
        if (r->has("over_s") == r->has("over_periods"))
          fail(r->mark, rp + " needs exactly one of over_s (seconds) or over_periods");
        if (r->has("over_s")) {
          const YAML::Node& v = r->values.at("over_s");
          const double seconds = read_double(v, rp + ".over_s");
          if (seconds < 0.0) fail(v.Mark(), rp + ".over_s must be >= 0, got " + v.Scalar());
          e.ramp_periods = periods_in(seconds, s, v, rp + ".over_s");
        } else {
          const YAML::Node& v = r->values.at("over_periods");
          e.ramp_periods = read_integer(v, rp + ".over_periods");
          if (e.ramp_periods < 0) fail(v.Mark(), rp + ".over_periods must be >= 0, got " + v.Scalar());
        }
      }
      events.push_back(std::move(e));
    }
    return events;
  }

  // A relay's `events:`: when each topic's link changes, by the topic's sample index. Checked as
  // they will apply, from each topic's link in `c` (a key of the model the link then has).
  std::vector<RelayEvent> read_relay_events(const YAML::Node& node, const std::string& at, const RelayConfig& c) {
    if (!node.IsSequence())
      fail(mark_of(node, at), at + " must be a list such as - { at_sample: 200, topic: rt/scan, set: { loss: 1.0 } }, "
                                   "got " + describe(node));
    std::vector<RelayEvent> events;
    for (std::size_t i = 0; i < node.size(); ++i) {
      const std::string path = at + "[" + std::to_string(i) + "]";
      marks_[path] = node[i].Mark();
      const MapView m = open_map(node[i], path, marks_[path], {"at_sample", "at_s", "at_period", "topic", "set", "ramp"});
      for (const char* other : {"at_s", "at_period"})
        if (m.has(other))
          fail(mark_of(m.values.at(other), child(path, other)),
               path + "." + other + ": a relay's event names the topic's sample index, at_sample (its record's `index`: "
                                    "the same samples make the same decisions)");
      RelayEvent e;
      const YAML::Node& n = require(m, "at_sample");
      const long long index = read_integer(n, path + ".at_sample");
      if (index < 0) fail(n.Mark(), path + ".at_sample: the event is before the topic's first sample (0), got " + n.Scalar());
      e.at_sample = static_cast<std::uint64_t>(index);
      const YAML::Node& topic = require(m, "topic");
      e.topic = read_string(topic, path + ".topic");
      if (!relayed_topic_of(e.topic, c)) {
        std::vector<std::string> names;
        for (const auto& t : c.topics) names.push_back(t.name);
        const bool any_per_writer = std::any_of(c.topics.begin(), c.topics.end(), [](const RelayTopic& t) { return t.per_writer; });
        fail(mark_of(topic, path + ".topic"), path + ".topic: " + e.topic + " is not relayed (the relay's topics: " +
                                                  join(names) +
                                                  (any_per_writer ? "; a writer's link of a per_writer topic: TOPIC@WRITER)" : ")"));
      }
      if (const auto r = read_set_or_ramp(m, path, "over_samples: N", {"over_samples"}, e.kind, e.keys)) {
        const YAML::Node& v = require(*r, "over_samples");
        const long long samples = read_integer(v, path + ".ramp.over_samples");
        if (samples < 0) fail(v.Mark(), path + ".ramp.over_samples must be >= 0, got " + v.Scalar());
        e.ramp_samples = static_cast<std::uint64_t>(samples);
      }
      events.push_back(std::move(e));
    }
    check_relay_events(events, at, c);
    return events;
  }

  // The relayed topic a link name is: the topic itself, or a writer's link (TOPIC@WRITER, as a
  // journal names it) of a per_writer topic; nullptr for neither.
  static const RelayTopic* relayed_topic_of(const std::string& link, const RelayConfig& c) {
    for (const auto& t : c.topics)
      if (t.name == link) return &t;
    const auto at = link.rfind('@');
    if (at == std::string::npos) return nullptr;
    for (const auto& t : c.topics)
      if (t.per_writer && t.name == link.substr(0, at)) return &t;
    return nullptr;
  }

  // Replays the events in the order they apply (stable by at_sample), as RelayLinks will: each
  // must make sense for its link at that point (a writer's link starts as its topic's).
  void check_relay_events(const std::vector<RelayEvent>& events, const std::string& at, const RelayConfig& c) const {
    std::map<std::string, LinkSpec> links;
    for (const auto& e : events) links.try_emplace(e.topic, relayed_topic_of(e.topic, c)->link);
    std::vector<std::size_t> order(events.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return events[a].at_sample < events[b].at_sample; });
    for (const std::size_t i : order) {
      const RelayEvent& e = events[i];
      const std::string keys_at = at + "[" + std::to_string(i) + "]" + (e.kind == LinkEvent::Kind::set ? ".set" : ".ramp.to");
      LinkSpec& link = links.at(e.topic);
      try {
        if (e.kind == LinkEvent::Kind::ramp)
          for (const auto& k : e.keys) (void)link_key_value(link, k.name);  // the ramp starts from it
        link = apply_link_keys(link, e.keys);
      } catch (const LinkError& err) {
        const SourceLocation where = locate(keys_at + "." + err.key());
        throw ScenarioError(where.file + (where.line > 0 ? ":" + std::to_string(where.line) + ":" +
                                                              std::to_string(where.column)
                                                        : std::string()) +
                            ": " + link_error_at(keys_at, err));
      }
    }
  }

  // Seconds as a whole number of periods (rounded to the nearest).
  std::int64_t periods_in(double seconds, const Scenario& s, const YAML::Node& node, const std::string& path) const {
    // Events are read before validate_scenario() reports a period <= 0; converting by it
    // would give NaN or a negative count.
    if (s.period_ms <= 0) return 0;
    const double periods = std::round(seconds * 1000.0 / s.period_ms);
    if (!(periods <= 1e15)) fail(node.Mark(), path + " is too far in the future, got " + node.Scalar());
    return static_cast<std::int64_t>(periods);
  }

  void read_estimator(const YAML::Node& node, EstimatorSpec& estimator) {
    const MapView m = open_map(node, "estimator", marks_["estimator"],
                               {"deadline_ms", "divergence_trace_bound", "late_policy", "max_delay_periods"});
    if (m.has("deadline_ms")) estimator.deadline_ms = read_int(m.values.at("deadline_ms"), "estimator.deadline_ms");
    if (m.has("divergence_trace_bound"))
      estimator.divergence_trace_bound =
          read_positive(m.values.at("divergence_trace_bound"), "estimator.divergence_trace_bound");
    if (m.has("late_policy")) {
      const YAML::Node& v = m.values.at("late_policy");
      const std::string word = read_string(v, "estimator.late_policy");
      if (word == "drop") estimator.late_policy = LatePolicy::drop;
      else if (word == "fuse_within") estimator.late_policy = LatePolicy::fuse_within;
      else fail(v.Mark(), "estimator.late_policy must be drop or fuse_within, got '" + word + "'");
    }
    // The range (1..64) and the pairing with late_policy are checked by validate_scenario.
    if (m.has("max_delay_periods"))
      estimator.max_delay_periods = read_int(m.values.at("max_delay_periods"), "estimator.max_delay_periods");
  }

  std::string source_;
  std::map<std::string, YAML::Mark> marks_;
};

}  // namespace

Scenario parse_scenario(const std::string& yaml_text, const std::string& source_name) {
  try {
    return Loader(source_name).load(yaml_text);
  } catch (const YAML::Exception& e) {
    // Safety net: every yaml-cpp failure the walk above does not anticipate still
    // becomes a ScenarioError with the position yaml-cpp knows.
    std::string prefix = source_name;
    if (valid(e.mark)) prefix += ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1);
    throw ScenarioError(prefix + ": " + e.msg);
  }
}

std::uint64_t parse_seed(const std::string& text) {
  if (!text.empty() && text.front() == '-') throw std::invalid_argument("seed must be a non-negative integer, got " + text);
  std::uint64_t value = 0;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if (first != last && *first == '+') ++first;
  const auto [end, ec] = std::from_chars(first, last, value);
  if (ec == std::errc::result_out_of_range)
    throw std::invalid_argument("seed must fit in 64 bits (at most 18446744073709551615), got " + text);
  if (ec != std::errc{} || end != last || first == last)
    throw std::invalid_argument("seed must be a non-negative integer, got '" + text + "'");
  return value;
}

namespace {
std::string read_text_file(const std::filesystem::path& path, const char* what) {
  try {
    return read_input_file(path, what, max_yaml_input_bytes);
  } catch (const InputFileError& e) {
    throw ScenarioError(e.what());
  }
}
}  // namespace

std::vector<LinkEvent> parse_events(const std::string& yaml_text, const Scenario& scenario,
                                    const std::string& source_name) {
  try {
    return Loader(source_name).load_events(yaml_text, scenario);
  } catch (const YAML::Exception& e) {
    std::string prefix = source_name;
    if (valid(e.mark)) prefix += ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1);
    throw ScenarioError(prefix + ": " + e.msg);
  }
}

std::vector<LinkEvent> load_events_file(const std::filesystem::path& path, const Scenario& scenario) {
  return parse_events(read_text_file(path, "events file"), scenario, path.string());
}

Scenario load_scenario_file(const std::filesystem::path& path) {
  return parse_scenario(read_text_file(path, "scenario file"), path.string());
}

RelayConfig parse_relay_config(const std::string& yaml_text, const std::string& source_name) {
  try {
    return Loader(source_name.empty() ? "<relay>" : source_name).load_relay(yaml_text);
  } catch (const YAML::Exception& e) {
    std::string prefix = source_name;
    if (valid(e.mark)) prefix += ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1);
    throw ScenarioError(prefix + ": " + e.msg);
  }
}

RelayConfig load_relay_config_file(const std::filesystem::path& path) {
  return parse_relay_config(read_text_file(path, "relay file"), path.string());
}

std::vector<RelayEvent> parse_relay_events(const std::string& yaml_text, const RelayConfig& config,
                                           const std::string& source_name) {
  try {
    return Loader(source_name.empty() ? "<events>" : source_name).load_relay_events(yaml_text, config);
  } catch (const YAML::Exception& e) {
    std::string prefix = source_name;
    if (valid(e.mark)) prefix += ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1);
    throw ScenarioError(prefix + ": " + e.msg);
  }
}

std::vector<RelayEvent> load_relay_events_file(const std::filesystem::path& path, const RelayConfig& config) {
  return parse_relay_events(read_text_file(path, "events file"), config, path.string());
}

}  // namespace netkf
