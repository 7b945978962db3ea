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
#include <initializer_list>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "netkf/scenario.hpp"

namespace netkf {
namespace {

std::string join(std::initializer_list<const char*> names) {
  std::string out;
  for (const char* n : names) {
    if (!out.empty()) out += ", ";
    out += n;
  }
  return out;
}

std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null: return "nothing (null)";
    case YAML::NodeType::Scalar: return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Map: return "a mapping";
    default: return "nothing";
  }
}

bool valid(const YAML::Mark& m) { return m.line >= 0 && m.column >= 0; }

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
    std::vector<YAML::Node> docs;
    try {
      docs = YAML::LoadAll(text);
    } catch (const YAML::ParserException& e) {
      fail(e.mark, "YAML syntax error: " + e.msg);
    }
    if (docs.empty() || docs.front().IsNull())
      fail(YAML::Mark::null_mark(), "the scenario file is empty (expected a mapping with at least 'period_ms', 'plant' and 'sensors')");
    if (docs.size() > 1)
      fail(docs[1].Mark(), "the file holds " + std::to_string(docs.size()) + " YAML documents, expected one scenario");
    const YAML::Node& root = docs.front();

    Scenario s;
    s.source = source_;
    const MapView top = open_map(root, "", YAML::Mark::null_mark(),
                                 {"name", "period_ms", "seed", "plant", "sensors", "estimator"});
    s.name = top.has("name") ? read_string(top.values.at("name"), "name") : default_name();
    s.period_ms = read_int(require(top, "period_ms"), "period_ms");
    // Optional: a scenario without a seed is still reproducible (seed 0).
    if (top.has("seed")) s.seed = read_seed(top.values.at("seed"));
    read_plant(require(top, "plant"), s.plant);
    read_sensors(require(top, "sensors"), s.sensors);
    if (top.has("estimator")) read_estimator(top.values.at("estimator"), s.estimator);

    complete_scenario(s, [this](const std::string& path) { return locate(path); });
    return s;
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
                   std::initializer_list<const char*> allowed) {
    const YAML::Mark at = valid(key_mark) ? key_mark : node.Mark();
    const std::string what = path.empty() ? "the scenario" : path;
    if (!node.IsMap()) fail(at, what + " must be a mapping (key: value), got " + describe(node));
    MapView view{path, at, {}};
    std::map<std::string, YAML::Mark> key_marks;
    for (const auto& kv : node) {
      if (!kv.first.IsScalar()) fail(kv.first.Mark(), "keys in " + what + " must be plain names");
      const std::string key = kv.first.Scalar();
      bool known = false;
      for (const char* a : allowed) known = known || key == a;
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
    if (ec != std::errc{} || end != last || first == last)
      fail(node.Mark(), path + " must be an integer, got " + describe(node));
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
      const MapView c = open_map(m.values.at("control"), "plant.control", marks_["plant.control"], {"gain", "lqr"});
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

  LinkModel read_link(const YAML::Node& node, const std::string& at) {
    const YAML::Mark where = mark_of(node, at);
    if (!node.IsMap()) fail(where, at + " must be a mapping such as { model: bernoulli, loss: 0.1 }, got " + describe(node));
    const YAML::Node model_node = node["model"];
    if (!model_node) {
      // Catch a misspelt 'model' (or any other typo) as an unknown key first.
      open_map(node, at, where, {"model", "loss", "p", "r", "loss_good", "loss_bad"});
      fail(where, "missing required key '" + at + ".model' (bernoulli or gilbert_elliott)");
    }
    const std::string model = read_string(model_node, at + ".model");
    if (model == "bernoulli") {
      const MapView m = open_map(node, at, where, {"model", "loss"});
      BernoulliLink link;
      link.loss = read_double(require(m, "loss"), at + ".loss");
      return link;
    }
    if (model == "gilbert_elliott") {
      const MapView m = open_map(node, at, where, {"model", "p", "r", "loss_good", "loss_bad"});
      GilbertElliottLink link;  // loss_good = 0, loss_bad = 1 by default: the simple Gilbert channel
      link.p = read_double(require(m, "p"), at + ".p");
      link.r = read_double(require(m, "r"), at + ".r");
      if (m.has("loss_good")) link.loss_good = read_double(m.values.at("loss_good"), at + ".loss_good");
      if (m.has("loss_bad")) link.loss_bad = read_double(m.values.at("loss_bad"), at + ".loss_bad");
      return link;
    }
    fail(model_node.Mark(), "unknown link model '" + model + "' in " + at +
                                ".model (expected one of: bernoulli, gilbert_elliott)");
  }

  void read_estimator(const YAML::Node& node, EstimatorSpec& estimator) {
    const MapView m = open_map(node, "estimator", marks_["estimator"], {"deadline_ms", "divergence_trace_bound"});
    if (m.has("deadline_ms")) estimator.deadline_ms = read_int(m.values.at("deadline_ms"), "estimator.deadline_ms");
    if (m.has("divergence_trace_bound"))
      estimator.divergence_trace_bound =
          read_positive(m.values.at("divergence_trace_bound"), "estimator.divergence_trace_bound");
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

Scenario load_scenario_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw ScenarioError(path.string() + ": is a directory, not a scenario file");
  std::ifstream in(path, std::ios::binary);
  // errno says why (no such file, permission denied); the message names it.
  if (!in) throw ScenarioError(path.string() + ": cannot open scenario file: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw ScenarioError(path.string() + ": error while reading the scenario file");
  return parse_scenario(text.str(), path.string());
}

}  // namespace netkf
