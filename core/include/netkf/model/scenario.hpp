#pragma once
// The scenario model: everything a run of netkf is configured by (see
// docs/scenario-format.md). Loading validates every field and reports problems as
// ScenarioError with "file:line:col: what is wrong".
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "netkf/links/link.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/support/types.hpp"

namespace netkf {

struct SensorSpec {
  int id = 0;
  Matrix C;  // C_i (m_i x n)
  Matrix R;  // R_i (m_i x m_i), symmetric positive definite
  LinkSpec link;  // what happens to its samples on the way (loss, delay)
};

/// What the plant applies at a tick whose input u_{k-1} did not arrive over the actuation link.
enum class OnLoss {
  zero,  // nothing: u = 0 (Schenato et al. 2007's actuator)
  hold,  // the input it applied at the previous tick (zero before the first one arrived)
};
const char* to_string(OnLoss on_loss);

/// LQG feedback u = -gain x̂_{k|k}; either given, or computed from LQR weights.
struct ControlSpec {
  Matrix gain;                 // L (p x n); filled from lqr weights at load time when absent
  std::optional<Matrix> lqr_Qx;
  std::optional<Matrix> lqr_Ru;
  /// The actuation link: how u_k travels from the estimator to the plant (a link like a
  /// sensor's). nullopt: a perfect path, every input applied at the next tick.
  std::optional<LinkSpec> link;
  OnLoss on_loss = OnLoss::zero;
  /// true (TCP-like): the plant reports the input it applied and the estimator predicts with
  /// it. false (UDP-like): the estimator never learns whether its input arrived.
  bool acknowledged = true;
};

struct PlantSpec {
  Matrix A;                    // n x n
  Matrix Q;                    // process noise covariance, symmetric PSD
  std::optional<Matrix> B;     // n x p, present iff the loop is closed
  std::optional<ControlSpec> control;
  Vector x0;                   // initial state mean (default zeros)
  Matrix P0;                   // initial covariance (default identity)
  double state_bound = 1e8;    // an uncontrolled run ends cleanly when |x|_inf exceeds this
};

/// What the estimator does with a sample that arrives after its period was fused.
enum class LatePolicy {
  drop,         // counted late, never fused (the in-time estimate is the only one)
  fuse_within,  // fused into a revised estimate when at most max_delay_periods late
};
const char* to_string(LatePolicy policy);

struct EstimatorSpec {
  std::optional<int> deadline_ms;          // default: period_ms * 0.8
  double divergence_trace_bound = 1e6;     // Tr P above this => state "diverging"
  LatePolicy late_policy = LatePolicy::drop;
  std::optional<int> max_delay_periods;    // D, 1..kMaxDelayPeriods; required with fuse_within, refused with drop
  /// Periods of history the estimator may re-run: the periods a sample for k stays fusable
  /// (0 with drop).
  int fusable_delay_periods() const {
    return late_policy == LatePolicy::fuse_within ? max_delay_periods.value_or(0) : 0;
  }
  static constexpr int kMaxDelayPeriods = 64;
};

/// A change of one link at a given period (the scenario's `events:`, or a replayed live
/// session): `set` applies its keys from the first sample of period `at_period`; a ramp
/// moves each numeric key of `keys` linearly from its value at `at_period` to the value
/// given, one step per period, reaching it at at_period + ramp_periods.
struct LinkEvent {
  enum class Kind { set, ramp };
  std::int64_t at_period = 0;  // K
  int link = 0;                // sensor id of the link
  Kind kind = Kind::set;
  LinkKeys keys;
  std::int64_t ramp_periods = 0;
  bool operator==(const LinkEvent&) const = default;
};

/// How the live network names its DDS topics and types (docs/ros2.md): netkf's own names
/// (netkf/estimate of type netkf::wire::Estimate) or ROS 2's (rt/netkf/estimate of type
/// netkf_msgs::msg::dds_::Estimate_, the .msg twins in netkf_msgs/), so ROS 2 tools read it.
enum class TopicNaming {
  netkf,
  ros2,
};
const char* to_string(TopicNaming naming);
/// "netkf" or "ros2"; nullopt for anything else.
std::optional<TopicNaming> topic_naming_from_string(std::string_view word);

struct Scenario {
  std::string name;
  std::string source;          // file the scenario was loaded from (for messages)
  int period_ms = 10;
  std::uint64_t seed = 0;
  PlantSpec plant;
  std::vector<SensorSpec> sensors;
  EstimatorSpec estimator;
  std::vector<LinkEvent> events;  // in the order they apply (stable by at_period)
  /// `naming:` the default for every process of the run (a --naming flag or $NETKF_NAMING wins).
  TopicNaming naming = TopicNaming::netkf;

  int state_dim() const { return static_cast<int>(plant.A.rows()); }
  /// The sampling period in seconds.
  double period_s() const { return period_ms / 1000.0; }
  const SensorSpec* find_sensor(int id) const;
  int deadline_ms() const;
  /// How long after its period's tick a sample can still reach the final estimate: the
  /// deadline plus D periods with late_policy fuse_within, the deadline with drop.
  double final_horizon_ms() const {
    return deadline_ms() + static_cast<double>(estimator.fusable_delay_periods()) * period_ms;
  }
  /// The actuation link (plant.control.link), or null for a perfect path or an open loop.
  const LinkSpec* actuation_link() const {
    return plant.control && plant.control->link ? &*plant.control->link : nullptr;
  }
  /// How long an input may travel and still be applied: u_k leaves the estimator when period k
  /// is fused (at the latest at the deadline) and is applied at tick k + 1, so a delay up to
  /// period_ms − deadline_ms is in time (exact when the period is fused at its deadline; an
  /// estimator that fused earlier leaves its input more time).
  double actuation_deadline_ms() const { return static_cast<double>(period_ms) - deadline_ms(); }
};

class ScenarioError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The scenario as the estimator sees it: every link replaced by its effective loss model at
/// the scenario's deadline, without delay (a sample later than the deadline is never fused,
/// so it counts as lost; netkf/links/link_statistics.hpp, effective_loss_model). The theory and the offline
/// simulation take this; their link analyses read `link.loss` only.
Scenario with_effective_links(const Scenario& scenario);
/// The same for a sample that counts when its delay is at most `horizon_ms` (the final
/// estimate with late_policy fuse_within: horizon final_horizon_ms()).
Scenario with_effective_links(const Scenario& scenario, double horizon_ms);

/// Indexes of `events` in the order they apply: by at_period, ties in list order.
std::vector<std::size_t> event_application_order(const std::vector<LinkEvent>& events);
/// Parse an `events:` file (the format `--record` writes: a mapping with one key,
/// `events`, or a bare list) for `scenario`'s links and period; errors as FILE:LINE:COL.
std::vector<LinkEvent> load_events_file(const std::filesystem::path& path, const Scenario& scenario);
/// Same, from YAML text; `source_name` is used in error messages.
std::vector<LinkEvent> parse_events(const std::string& yaml_text, const Scenario& scenario,
                                    const std::string& source_name);
/// The events as YAML text in the scenario's `events:` format (what --record writes).
std::string events_to_yaml(const std::vector<LinkEvent>& events);
/// Add `replayed` to the scenario's events: at the same period a replayed event applies
/// before the scenario's own (a journaled live change happened before the timeline's step
/// in the run it was recorded from). Validates the result.
void add_replayed_events(Scenario& scenario, const std::vector<LinkEvent>& replayed);

/// Load and validate a scenario file. Throws ScenarioError("FILE:LINE:COL: message").
Scenario load_scenario_file(const std::filesystem::path& path);
/// Same, from YAML text; `source_name` is used in error messages.
Scenario parse_scenario(const std::string& yaml_text, const std::string& source_name);
/// The built-in default scenario (three sensors, mixed links, closed loop) used by `netkf launch`.
Scenario default_scenario();
/// Serialise to YAML that parse_scenario accepts (used to hand the scenario to child processes).
std::string scenario_to_yaml(const Scenario& scenario);

/// A seed as written by a person (file or command line): a non-negative integer that fits in
/// 64 bits. Throws std::invalid_argument with the reason (no wrapping of -1 or 2^64).
std::uint64_t parse_seed(const std::string& text);

/// Validate an already-built scenario (used by parse and by programmatic construction).
/// Throws ScenarioError with a message naming the field.
void validate_scenario(const Scenario& scenario);

// ---- Additions (scenario engineer) -------------------------------------------------
//
// Scenario file keys (docs/scenario-format.md); anything else is an error, so typos
// are caught. Required: period_ms, plant.A, plant.Q, sensors (at least one), and per
// sensor id, C, R, link.model plus the model's parameters (bernoulli: loss;
// gilbert_elliott: p, r, or loss and mean_burst). Optional, with defaults:
//   name                  file stem
//   seed                  0 (a scenario without a seed is still reproducible)
//   plant.x0 / plant.P0   zeros / identity
//   plant.B + plant.control   both or neither; control is { gain: [[..]] } (p x n,
//                         u = -gain x̂) or { lqr: { Qx: .., Ru: .. } } (gain from lqr_gain;
//                         with a lossy actuation link from lossy_lqr_gain at its arrival rate)
//   plant.control.link / on_loss / acknowledged   a perfect path / zero / true
//   plant.state_bound     1e8 (|x|_inf ending an uncontrolled run)
//   link.loss_good / link.loss_bad   0 / 1 (the simple Gilbert channel)
//   link.delay_ms / jitter_ms / delay_distribution   0 / 0 / uniform (netkf/links/link.hpp)
//   events                nothing: a timeline of link changes (LinkEvent)
//   estimator.deadline_ms             80 % of period_ms; must be in (0, period_ms]
//   estimator.divergence_trace_bound  1e6
//   estimator.late_policy             drop (or fuse_within, then estimator.max_delay_periods 1..64)
// Covariances: Q and lqr.Qx symmetric PSD; R, P0 and lqr.Ru symmetric PD (symmetry
// up to a relative 1e-9). A given gain must make A - B gain Schur stable.

/// Where a key path such as "sensors[1].R" sits in the scenario's source file.
/// line/column are 1-based; 0 when unknown (programmatic scenarios).
struct SourceLocation {
  std::string file;
  int line = 0;
  int column = 0;
};
/// Maps a key path to its location; used to put "FILE:LINE:COL:" in front of messages.
using ScenarioLocator = std::function<SourceLocation(const std::string& key_path)>;

/// validate_scenario() with messages placed by `locate` (the loader passes the YAML marks).
void validate_scenario(const Scenario& scenario, const ScenarioLocator& locate);

/// Fill what is derived from other fields, then validate: when plant.control has LQR
/// weights and no gain, the gain is computed with lqr_gain() (netkf/theory/lqr.hpp), or, with an
/// actuation link that loses inputs, with lossy_lqr_gain() at its arrival rate
/// (actuation_arrival_rate). Use this for programmatic scenarios that give control by LQR weights.
void complete_scenario(Scenario& scenario, const ScenarioLocator& locate = {});

/// The rate ν̄ at which inputs reach the plant in time: the actuation link's effective arrival
/// rate at actuation_deadline_ms() (netkf/links/link_statistics.hpp); 1 without an actuation link.
double actuation_arrival_rate(const Scenario& scenario);

/// Seeded streams of the links' decisions (netkf/support/random.hpp, derive_seed): a sensor's link i
/// draws its losses from derive_seed(seed, "link", i) and its delays from
/// derive_seed(seed, "link-delay", i); the actuation link from the names below (index 0),
/// streams of their own, so adding an actuation link changes no sensor's decisions.
inline constexpr const char* kActuationLinkStream = "actuation-link";
inline constexpr const char* kActuationLinkDelayStream = "actuation-link-delay";

/// The actuation link's id where links are numbered by sensor id (the channel's links, link
/// status, the journal, timelines' `link:`): sensor ids are >= 0. People call it "control".
inline constexpr int kControlLinkId = -1;
inline constexpr const char* kControlLinkName = "control";
/// "control" for the actuation link, else the sensor id in decimal.
std::string link_name(int link_id);
/// A link as a person names it ("control" or a sensor id); nullopt when it is neither.
std::optional<int> parse_link_name(const std::string& text);

}  // namespace netkf
