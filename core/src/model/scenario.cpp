// The scenario model: semantic validation (shared by the YAML loader and by
// programmatic scenarios), the built-in default scenario and YAML serialisation.
// Parsing the YAML text itself lives in scenario_loader.cpp.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <sstream>
#include <string>
#include <utility>

#include <yaml-cpp/yaml.h>

#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/relay/relay_config.hpp"
#include "netkf/theory/lqr.hpp"

namespace netkf {
namespace {

// Relative tolerance of the symmetry check: matrices typed by hand with a few
// decimals are exactly symmetric; programmatic ones (e.g. A P A') may differ in the
// last bits, which must not be rejected.
constexpr double kSymmetryTolerance = 1e-9;

std::string shape(const Matrix& M) { return std::to_string(M.rows()) + "x" + std::to_string(M.cols()); }

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// Largest |entry|: tolerances are relative to it, so a covariance in small units
// (say 1e-8 m²) is judged like the same one in large units.
double scale_of(const Matrix& M) { return M.size() == 0 ? 0.0 : M.cwiseAbs().maxCoeff(); }

double smallest_eigenvalue(const Matrix& M) {
  Eigen::SelfAdjointEigenSolver<Matrix> es(0.5 * (M + M.transpose()), Eigen::EigenvaluesOnly);
  return es.eigenvalues().minCoeff();
}

double spectral_radius(const Matrix& M) {
  return Eigen::EigenSolver<Matrix>(M, false).eigenvalues().cwiseAbs().maxCoeff();
}

// "FILE:LINE:COL: " when the loader knows where `path` is, else "FILE: " or "scenario 'NAME': ".
std::string message_prefix(const Scenario& s, const ScenarioLocator& locate, const std::string& path) {
  SourceLocation where;
  if (locate) where = locate(path);
  if (where.file.empty()) where.file = s.source.empty() ? "scenario '" + s.name + "'" : s.source;
  std::string prefix = where.file;
  if (where.line > 0) prefix += ":" + std::to_string(where.line) + ":" + std::to_string(std::max(1, where.column));
  return prefix + ": ";
}

// lqr_gain() prefixes its messages with "lqr: "; here the key path says it already.
std::string without_lqr_prefix(const std::string& what) {
  return what.rfind("lqr: ", 0) == 0 ? what.substr(5) : what;
}

// The gain plant.control.lqr stands for: the LQR gain, or with an actuation link that loses
// inputs the TCP-like optimum at its arrival rate ν̄ (lossy_lqr_gain, Schenato et al. 2007
// Sec. V). Chosen for every on_loss and for UDP-like links too: the papers give no linear
// optimum there, and analyze judges the loop with whatever gain this is.
Matrix lqr_gain_of(const Scenario& s, const ScenarioLocator& locate) {
  const ControlSpec& c = *s.plant.control;
  const double rate = actuation_arrival_rate(s);
  try {
    return rate < 1.0 ? theory::lossy_lqr_gain(s.plant.A, *s.plant.B, *c.lqr_Qx, *c.lqr_Ru, rate)
                      : theory::lqr_gain(s.plant.A, *s.plant.B, *c.lqr_Qx, *c.lqr_Ru);
  } catch (const std::invalid_argument& e) {
    std::string hint;
    if (rate < 1.0)
      hint = " (the actuation link delivers inputs in time at rate " + num(rate) +
             "; give plant.control.gain to run a fixed gain at this rate)";
    throw ScenarioError(message_prefix(s, locate, "plant.control.lqr") + "plant.control.lqr: " +
                        without_lqr_prefix(e.what()) + hint);
  }
}

class Validator {
 public:
  Validator(const Scenario& s, const ScenarioLocator& locate) : s_(s), locate_(locate) {}

  void run(bool gain_may_be_pending) {
    if (s_.name.empty()) fail("name", "name must not be empty");
    if (s_.period_ms <= 0) fail("period_ms", "period_ms must be > 0, got " + std::to_string(s_.period_ms));
    if (s_.estimator.deadline_ms) {
      const int d = *s_.estimator.deadline_ms;
      if (d <= 0 || d > s_.period_ms)
        fail("estimator.deadline_ms", "estimator.deadline_ms must be in (0, period_ms] = (0, " +
                                          std::to_string(s_.period_ms) + "], got " + std::to_string(d));
    }
    positive("estimator.divergence_trace_bound", s_.estimator.divergence_trace_bound);
    late_policy();
    plant(gain_may_be_pending);
    sensors();
    events();
  }

  void late_policy() {
    const EstimatorSpec& e = s_.estimator;
    if (e.late_policy == LatePolicy::drop) {
      if (e.max_delay_periods)
        fail("estimator.max_delay_periods",
             "estimator.max_delay_periods needs estimator.late_policy: fuse_within (late_policy is drop)");
      return;
    }
    if (!e.max_delay_periods)
      fail("estimator.late_policy", "estimator.late_policy: fuse_within needs estimator.max_delay_periods (1.." +
                                        std::to_string(EstimatorSpec::kMaxDelayPeriods) + ")");
    const int d = *e.max_delay_periods;
    if (d < 1 || d > EstimatorSpec::kMaxDelayPeriods)
      fail("estimator.max_delay_periods", "estimator.max_delay_periods must be in [1, " +
                                              std::to_string(EstimatorSpec::kMaxDelayPeriods) + "], got " +
                                              std::to_string(d));
  }

 private:
  [[noreturn]] void fail(const std::string& path, const std::string& message) const {
    throw ScenarioError(message_prefix(s_, locate_, path) + message);
  }

  // "first at line 9" when the location is known, else the key path.
  std::string where_is(const std::string& path) const {
    if (locate_) {
      const SourceLocation loc = locate_(path);
      if (loc.line > 0) return "line " + std::to_string(loc.line);
    }
    return path;
  }

  void positive(const std::string& path, double v) const {
    if (!std::isfinite(v) || v <= 0.0) fail(path, path + " must be a positive finite number, got " + num(v));
  }

  void finite(const std::string& path, const Matrix& M) const {
    for (Eigen::Index i = 0; i < M.rows(); ++i)
      for (Eigen::Index j = 0; j < M.cols(); ++j)
        if (!std::isfinite(M(i, j)))
          fail(path, path + "[" + std::to_string(i) + "][" + std::to_string(j) + "] must be a finite number, got " +
                         num(M(i, j)));
  }

  void square_shape(const std::string& path, const Matrix& M, Eigen::Index n, const std::string& why) const {
    if (M.rows() != n || M.cols() != n)
      fail(path, path + " must be " + std::to_string(n) + "x" + std::to_string(n) + " " + why + ", got " + shape(M));
  }

  void symmetric(const std::string& path, const Matrix& M) const {
    const Matrix asym = M - M.transpose();
    Eigen::Index i = 0, j = 0;
    const double worst = asym.cwiseAbs().maxCoeff(&i, &j);
    if (i > j) std::swap(i, j);  // name the upper-triangle entry first, as the user reads rows
    if (worst > kSymmetryTolerance * scale_of(M))
      fail(path, path + " must be symmetric, but " + path + "[" + std::to_string(i) + "][" + std::to_string(j) +
                     "] = " + num(M(i, j)) + " differs from " + path + "[" + std::to_string(j) + "][" +
                     std::to_string(i) + "] = " + num(M(j, i)));
  }

  // Covariances: symmetric and PSD (Q, Qx) or PD (R, P0, Ru). The eigenvalue
  // tolerance scales with the matrix so that rounding never decides the verdict.
  void covariance(const std::string& path, const Matrix& M, bool definite) const {
    finite(path, M);
    symmetric(path, M);
    const double lmin = smallest_eigenvalue(M);
    const double tol = 1e-12 * scale_of(M);
    if (definite && !(lmin > tol))
      fail(path, path + " is not positive definite (smallest eigenvalue " + num(lmin) +
                     (lmin > 0.0 ? ", numerically singular" : "") + ")");
    if (!definite && lmin < -tol)
      fail(path, path + " is not positive semidefinite (smallest eigenvalue " + num(lmin) + ")");
  }

  void plant(bool gain_may_be_pending) {
    const PlantSpec& p = s_.plant;
    if (p.A.size() == 0) fail("plant.A", "plant.A must not be empty");
    finite("plant.A", p.A);
    if (p.A.rows() != p.A.cols()) fail("plant.A", "plant.A must be square, got " + shape(p.A));
    const Eigen::Index n = p.A.rows();
    square_shape("plant.Q", p.Q, n, "to match A");
    covariance("plant.Q", p.Q, false);
    if (p.x0.size() != n)
      fail("plant.x0", "plant.x0 must have " + std::to_string(n) + " entries to match A, got " +
                           std::to_string(p.x0.size()));
    for (Eigen::Index i = 0; i < n; ++i)
      if (!std::isfinite(p.x0(i)))
        fail("plant.x0", "plant.x0[" + std::to_string(i) + "] must be a finite number, got " + num(p.x0(i)));
    square_shape("plant.P0", p.P0, n, "to match A");
    covariance("plant.P0", p.P0, true);
    positive("plant.state_bound", p.state_bound);

    if (p.B && !p.control) fail("plant.B", "plant.B is given but plant.control is missing (give a gain or lqr weights)");
    if (p.control && !p.B) fail("plant.control", "plant.control needs plant.B (the input matrix, n x p)");
    if (!p.B) return;
    const Matrix& B = *p.B;
    if (B.rows() != n || B.cols() == 0)
      fail("plant.B", "plant.B must have " + std::to_string(n) + " rows to match A (n x p, p >= 1), got " + shape(B));
    finite("plant.B", B);
    const Eigen::Index inputs = B.cols();
    const ControlSpec& c = *p.control;
    if (c.link) link("plant.control.link", *c.link);  // before the gain, which reads its rate
    if (c.lqr_Qx.has_value() != c.lqr_Ru.has_value())
      fail("plant.control.lqr", "plant.control.lqr needs both Qx and Ru");
    const bool lqr = c.lqr_Qx.has_value();
    if (lqr) {
      square_shape("plant.control.lqr.Qx", *c.lqr_Qx, n, "to match A");
      covariance("plant.control.lqr.Qx", *c.lqr_Qx, false);
      square_shape("plant.control.lqr.Ru", *c.lqr_Ru, inputs, "to match the columns of B");
      covariance("plant.control.lqr.Ru", *c.lqr_Ru, true);
    }
    if (c.gain.size() == 0) {
      if (!lqr) fail("plant.control", "plant.control needs 'gain' or 'lqr' (with Qx and Ru)");
      if (gain_may_be_pending) return;
      fail("plant.control.gain", "plant.control.gain is empty: call complete_scenario() to compute it from the lqr weights");
    }
    if (c.gain.rows() != inputs || c.gain.cols() != n)
      fail("plant.control.gain", "plant.control.gain must be " + std::to_string(inputs) + "x" + std::to_string(n) +
                                     " (B columns x states), got " + shape(c.gain));
    finite("plant.control.gain", c.gain);
    // u = -L x̂ must stabilise the plant, or the live run diverges whatever the links do.
    const double rho = spectral_radius(p.A - B * c.gain);
    if (!(rho < 1.0))
      fail("plant.control.gain", "plant.control.gain does not stabilise the plant: A - B*gain has spectral radius " +
                                     num(rho) + " (must be < 1)");
    if (lqr) {
      const Matrix expected = lqr_gain_of(s_, locate_);
      if ((expected - c.gain).norm() > 1e-8 * std::max(1.0, expected.norm()))
        fail("plant.control.gain", "plant.control.gain differs from the LQR gain of plant.control.lqr (give one of them)");
    }
  }

  void sensors() {
    if (s_.sensors.empty()) fail("sensors", "sensors must list at least one sensor");
    const Eigen::Index n = s_.plant.A.rows();
    std::map<int, std::size_t> first_index;
    for (std::size_t k = 0; k < s_.sensors.size(); ++k) {
      const SensorSpec& sensor = s_.sensors[k];
      const std::string at = "sensors[" + std::to_string(k) + "]";
      if (sensor.id < 0) fail(at + ".id", at + ".id must be a non-negative integer, got " + std::to_string(sensor.id));
      const auto [it, inserted] = first_index.emplace(sensor.id, k);
      if (!inserted)
        fail(at + ".id", "duplicate sensor id " + std::to_string(sensor.id) + " in " + at + " (first at " +
                             where_is("sensors[" + std::to_string(it->second) + "].id") + ")");
      const Matrix& C = sensor.C;
      if (C.rows() == 0 || C.cols() != n)
        fail(at + ".C", at + ".C must have " + std::to_string(n) + " columns to match A (m x " + std::to_string(n) +
                            ", m >= 1), got " + shape(C));
      finite(at + ".C", C);
      const Matrix& R = sensor.R;
      if (R.rows() != C.rows() || R.cols() != C.rows())
        fail(at + ".R", at + ".R must be " + std::to_string(C.rows()) + "x" + std::to_string(C.rows()) +
                            " to match C (" + std::to_string(C.rows()) + " rows), got " + shape(R));
      covariance(at + ".R", R, true);
      link(at + ".link", sensor.link);
    }
  }

  void link(const std::string& at, const LinkSpec& spec) const {
    try {
      validate_link(spec);  // the link type's one validation (netkf/links/link.hpp)
    } catch (const LinkError& e) {
      fail(at + "." + e.key(), link_error_at(at, e));
    }
  }

  // Replay the events in the order they apply, as the channel will: each must make sense for
  // its link at that point (a key of the model the link then has, valid values).
  void events() const {
    std::map<int, LinkSpec> links;
    for (const auto& sensor : s_.sensors) links[sensor.id] = sensor.link;
    if (const LinkSpec* control = s_.actuation_link()) links[kControlLinkId] = *control;
    for (const std::size_t i : event_application_order(s_.events)) {
      const LinkEvent& e = s_.events[i];
      const std::string at = "events[" + std::to_string(i) + "]";
      if (e.at_period < 0) fail(at + ".at_period", at + ".at_period: the event is before period 0");
      if (e.ramp_periods < 0) fail(at + ".ramp", at + ".ramp: negative duration");
      const auto link = links.find(e.link);
      if (link == links.end()) fail(at + ".link", at + ".link: unknown link " + link_name(e.link));
      const std::string keys_at = at + (e.kind == LinkEvent::Kind::set ? ".set" : ".ramp.to");
      try {
        if (e.kind == LinkEvent::Kind::ramp) {
          for (const auto& k : e.keys) {
            if (link_key_is_word(k.name)) throw LinkError(k.name, "a ramp moves numbers; change " + k.name + " with set");
            (void)link_key_value(link->second, k.name);  // the ramp starts from it
          }
        }
        link->second = apply_link_keys(link->second, e.keys);
      } catch (const LinkError& err) {
        fail(keys_at + "." + err.key(), link_error_at(keys_at, err));
      }
    }
  }

  const Scenario& s_;
  const ScenarioLocator& locate_;
};

void emit_matrix(YAML::Emitter& out, const Matrix& M) {
  out << YAML::Flow << YAML::BeginSeq;
  for (Eigen::Index i = 0; i < M.rows(); ++i) {
    out << YAML::Flow << YAML::BeginSeq;
    for (Eigen::Index j = 0; j < M.cols(); ++j) out << M(i, j);
    out << YAML::EndSeq;
  }
  out << YAML::EndSeq;
}

void emit_link_keys(YAML::Emitter& out, const LinkKeys& keys) {
  out << YAML::Flow << YAML::BeginMap;
  for (const auto& k : keys) {
    out << YAML::Key << k.name << YAML::Value;
    if (const auto* word = std::get_if<std::string>(&k.value)) {
      out << *word;
    } else {
      out << std::get<double>(k.value);
    }
  }
  out << YAML::EndMap;
}

// An event's change: `set: {keys}`, or `ramp: {to: {keys}, OVER: length}` (a launch's ramp in
// periods, a relay's in samples).
template <class Length>
void emit_change(YAML::Emitter& out, LinkEvent::Kind kind, const LinkKeys& keys, const char* over, Length length) {
  if (kind == LinkEvent::Kind::set) {
    out << YAML::Key << "set" << YAML::Value;
    emit_link_keys(out, keys);
    return;
  }
  out << YAML::Key << "ramp" << YAML::Value << YAML::BeginMap << YAML::Key << "to" << YAML::Value;
  emit_link_keys(out, keys);
  out << YAML::Key << over << YAML::Value << length << YAML::EndMap;
}

void emit_events(YAML::Emitter& out, const std::vector<LinkEvent>& events) {
  out << YAML::BeginSeq;
  for (const auto& e : events) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "at_period" << YAML::Value << e.at_period;
    if (e.link == kControlLinkId) out << YAML::Key << "link" << YAML::Value << kControlLinkName;
    else out << YAML::Key << "link" << YAML::Value << e.link;
    emit_change(out, e.kind, e.keys, "over_periods", e.ramp_periods);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
}

}  // namespace

Scenario with_effective_links(const Scenario& scenario) {
  return with_effective_links(scenario, scenario.deadline_ms());
}

Scenario with_effective_links(const Scenario& scenario, double horizon_ms) {
  Scenario out = scenario;
  for (auto& sensor : out.sensors) sensor.link = LinkSpec(effective_loss_model(sensor.link, horizon_ms));
  return out;
}

std::vector<std::size_t> event_application_order(const std::vector<LinkEvent>& events) {
  std::vector<std::size_t> order(events.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return events[a].at_period < events[b].at_period; });
  return order;
}

std::string events_to_yaml(const std::vector<LinkEvent>& events) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);  // every double round-trips exactly: a replay is bit-identical
  out << YAML::BeginMap << YAML::Key << "events" << YAML::Value;
  if (events.empty()) {
    out << YAML::Flow << YAML::BeginSeq << YAML::EndSeq;
  } else {
    emit_events(out, events);
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::string relay_events_to_yaml(const std::vector<RelayEvent>& events) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap << YAML::Key << "events" << YAML::Value;
  if (events.empty()) out << YAML::Flow << YAML::BeginSeq << YAML::EndSeq;
  else {
    out << YAML::BeginSeq;
    for (const auto& e : events) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "at_sample" << YAML::Value << e.at_sample;
      out << YAML::Key << "topic" << YAML::Value << e.topic;
      emit_change(out, e.kind, e.keys, "over_samples", e.ramp_samples);
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

void add_replayed_events(Scenario& scenario, const std::vector<LinkEvent>& replayed) {
  std::vector<LinkEvent> all = replayed;
  all.insert(all.end(), scenario.events.begin(), scenario.events.end());
  scenario.events = std::move(all);
  validate_scenario(scenario);
}

const SensorSpec* Scenario::find_sensor(int id) const {
  for (const auto& s : sensors)
    if (s.id == id) return &s;
  return nullptr;
}

const char* to_string(LatePolicy policy) {
  return policy == LatePolicy::fuse_within ? "fuse_within" : "drop";
}

int Scenario::deadline_ms() const {
  // Default: 80 % of the period, leaving the rest for the fused update and publishing.
  // In 64 bits: period_ms * 4 overflows an int for the largest periods.
  return estimator.deadline_ms.value_or(static_cast<int>(std::max<std::int64_t>(1, std::int64_t{period_ms} * 4 / 5)));
}

void validate_scenario(const Scenario& scenario, const ScenarioLocator& locate) {
  Validator(scenario, locate).run(false);
}

void validate_scenario(const Scenario& scenario) { validate_scenario(scenario, ScenarioLocator{}); }

void complete_scenario(Scenario& scenario, const ScenarioLocator& locate) {
  Validator(scenario, locate).run(true);
  if (scenario.plant.control && scenario.plant.control->gain.size() == 0) {
    scenario.plant.control->gain = lqr_gain_of(scenario, locate);
    validate_scenario(scenario, locate);
  }
}

const char* to_string(OnLoss on_loss) { return on_loss == OnLoss::hold ? "hold" : "zero"; }

const char* to_string(TopicNaming naming) { return naming == TopicNaming::ros2 ? "ros2" : "netkf"; }

std::optional<TopicNaming> topic_naming_from_string(std::string_view word) {
  if (word == "netkf") return TopicNaming::netkf;
  if (word == "ros2") return TopicNaming::ros2;
  return std::nullopt;
}

std::string link_name(int link_id) {
  return link_id == kControlLinkId ? std::string(kControlLinkName) : std::to_string(link_id);
}

std::optional<int> parse_link_name(const std::string& text) {
  if (text == kControlLinkName) return kControlLinkId;
  if (text.empty() || text.size() > 9 || !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  return std::stoi(text);
}

double actuation_arrival_rate(const Scenario& scenario) {
  const LinkSpec* link = scenario.actuation_link();
  return link ? effective_arrival_rate(*link, scenario.actuation_deadline_ms()) : 1.0;
}

Scenario default_scenario() {
  // The demo (deploy/scenarios/default.yaml explains it): an unstable 2-state plant
  // (α = 1.25) closed by LQR; only sensors 2 and 3 see the unstable mode, sensor 3 over
  // a bursty link that cannot hold it alone, so link 2 is critical: stable while its loss
  // is below 0.914 (Markov criterion, multi-sensor paper Thm 7/9), unstable above.
  Scenario s;
  s.name = "default";
  s.source = "<built-in default scenario>";
  s.period_ms = 10;
  s.seed = 42;
  s.plant.A = (Matrix(2, 2) << 1.25, 0.1, 0.0, 0.95).finished();
  s.plant.Q = (Matrix(2, 2) << 0.1, 0.0, 0.0, 0.1).finished();
  s.plant.B = (Matrix(2, 1) << 0.0, 1.0).finished();
  ControlSpec control;
  control.lqr_Qx = Matrix::Identity(2, 2);
  control.lqr_Ru = Matrix::Identity(1, 1);
  s.plant.control = control;
  s.plant.x0 = (Vector(2) << 1.0, -0.5).finished();
  s.plant.P0 = Matrix::Identity(2, 2);
  s.sensors.push_back({1, (Matrix(1, 2) << 0.0, 1.0).finished(), Matrix::Constant(1, 1, 0.5), BernoulliLink{0.2}});
  s.sensors.push_back({2, (Matrix(1, 2) << 1.0, 1.0).finished(), Matrix::Constant(1, 1, 1.0), BernoulliLink{0.3}});
  s.sensors.push_back({3, (Matrix(1, 2) << 1.0, 0.0).finished(), Matrix::Constant(1, 1, 0.25),
                       GilbertElliottLink{0.05, 0.3, 0.02, 1.0}});
  s.estimator.deadline_ms = 8;
  complete_scenario(s);
  return s;
}

std::string scenario_to_yaml(const Scenario& s) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);  // 17 significant digits: every double round-trips exactly
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << s.name;
  out << YAML::Key << "period_ms" << YAML::Value << s.period_ms;
  out << YAML::Key << "seed" << YAML::Value << s.seed;
  // Only when set: a scenario with the default names keeps its text (and its hash).
  if (s.naming != TopicNaming::netkf) out << YAML::Key << "naming" << YAML::Value << to_string(s.naming);

  out << YAML::Key << "plant" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "A" << YAML::Value;
  emit_matrix(out, s.plant.A);
  out << YAML::Key << "Q" << YAML::Value;
  emit_matrix(out, s.plant.Q);
  if (s.plant.B) {
    out << YAML::Key << "B" << YAML::Value;
    emit_matrix(out, *s.plant.B);
  }
  if (s.plant.control) {
    const ControlSpec& c = *s.plant.control;
    out << YAML::Key << "control" << YAML::Value << YAML::BeginMap;
    if (c.lqr_Qx && c.lqr_Ru) {
      // The gain is derived from the weights; the reader recomputes it identically.
      out << YAML::Key << "lqr" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "Qx" << YAML::Value;
      emit_matrix(out, *c.lqr_Qx);
      out << YAML::Key << "Ru" << YAML::Value;
      emit_matrix(out, *c.lqr_Ru);
      out << YAML::EndMap;
    } else {
      out << YAML::Key << "gain" << YAML::Value;
      emit_matrix(out, c.gain);
    }
    // Only what is set: a scenario without an actuation link keeps its text (and its hash).
    if (c.link) {
      out << YAML::Key << "link" << YAML::Value;
      emit_link_keys(out, link_keys(*c.link));
    }
    if (c.on_loss != OnLoss::zero) out << YAML::Key << "on_loss" << YAML::Value << to_string(c.on_loss);
    if (!c.acknowledged) out << YAML::Key << "acknowledged" << YAML::Value << false;
    out << YAML::EndMap;
  }
  out << YAML::Key << "x0" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (Eigen::Index i = 0; i < s.plant.x0.size(); ++i) out << s.plant.x0(i);
  out << YAML::EndSeq;
  out << YAML::Key << "P0" << YAML::Value;
  emit_matrix(out, s.plant.P0);
  out << YAML::Key << "state_bound" << YAML::Value << s.plant.state_bound;
  out << YAML::EndMap;

  out << YAML::Key << "sensors" << YAML::Value << YAML::BeginSeq;
  for (const SensorSpec& sensor : s.sensors) {
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << sensor.id;
    out << YAML::Key << "C" << YAML::Value;
    emit_matrix(out, sensor.C);
    out << YAML::Key << "R" << YAML::Value;
    emit_matrix(out, sensor.R);
    out << YAML::Key << "link" << YAML::Value;
    emit_link_keys(out, link_keys(sensor.link));
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!s.events.empty()) {
    out << YAML::Key << "events" << YAML::Value;
    emit_events(out, s.events);
  }

  out << YAML::Key << "estimator" << YAML::Value << YAML::BeginMap;
  if (s.estimator.deadline_ms) out << YAML::Key << "deadline_ms" << YAML::Value << *s.estimator.deadline_ms;
  out << YAML::Key << "divergence_trace_bound" << YAML::Value << s.estimator.divergence_trace_bound;
  if (s.estimator.late_policy != LatePolicy::drop)
    out << YAML::Key << "late_policy" << YAML::Value << to_string(s.estimator.late_policy);
  if (s.estimator.max_delay_periods)
    out << YAML::Key << "max_delay_periods" << YAML::Value << *s.estimator.max_delay_periods;
  out << YAML::EndMap;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace netkf
