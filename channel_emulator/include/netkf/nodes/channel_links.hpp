#pragma once
// The channel emulator's links (docs/architecture.md, "channel_emulator"): per sensor a seeded
// loss process and a seeded delay, the scenario's timeline of link events, and changes made
// live. Everything that changes a link applies from the first sample of a period, and every
// change is journaled with that period, so the same seed and the same events make the same
// drop decisions and delays for every (sensor, period).
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "netkf/analysis/recent_loss_fit.hpp"
#include "netkf/loss_model.hpp"
#include "netkf/scenario.hpp"

namespace netkf::nodes {

/// What one link is and did (since its current model was set).
struct LinkReport {
  int sensor_id = 0;
  LinkSpec link;
  LinkStatistics stats;     // since the current model was set (a ramp's steps do not reset it)
  LinkStatistics lifetime;  // since the channel started (not reset by a change)
  std::uint64_t past_deadline = 0;  // delivered with a delay above the link's deadline (as stats)
  double deadline_ms = 0.0;  // the estimator's deadline; the actuation link's: until the plant's next tick
  std::uint64_t last_request_id = 0;
  bool last_request_rejected = false;
  std::string reject_reason;
  std::optional<analysis::RecentLossFit> recent_fit;  // the last samples since the model was set (reports())
};

/// The answer to one change request.
struct LinkChangeResult {
  std::uint64_t request_id = 0;
  int sensor_id = 0;
  bool applied = false;
  std::string reason;  // empty when applied
};

/// One entry of the journal: a link change and the period of the first sample it applied to.
struct AppliedLinkChange {
  enum class Origin { request, timeline };
  int sensor_id = 0;
  std::int64_t at_period = 0;
  Origin origin = Origin::request;
  std::uint64_t request_id = 0;  // Origin::request
  LinkSpec link;                 // the whole link after the change
  std::string failure;           // a timeline event that could not apply (the link is unchanged)
};
const char* to_string(AppliedLinkChange::Origin origin);

/// The decision for one sample.
struct SampleFate {
  enum class Verdict { delivered, dropped, unknown_sensor };
  Verdict verdict = Verdict::dropped;
  double delay_ms = 0.0;  // delivered: how long to hold it before relaying
};

class ChannelLinks {
 public:
  using Verdict = SampleFate::Verdict;

  /// One link per scenario sensor; link i draws its losses from derive_seed(seed, "link", i) and
  /// its delays from derive_seed(seed, "link-delay", i). With plant.control.link, the actuation
  /// link too (id kControlLinkId, its own streams kActuationLinkStream and
  /// kActuationLinkDelayStream). The scenario's events are the timeline.
  explicit ChannelLinks(const Scenario& scenario);

  /// The fate of sample `k` of `sensor_id`. First what is due for this period applies: a
  /// change requested since the link's previous sample (journaled at k), then the timeline's
  /// events with at_period <= k, then a running ramp's step; then the loss draw, and for a
  /// delivered sample the delay draw.
  SampleFate on_sample(int sensor_id, std::int64_t k);
  /// Shorthand for tests of the loss process alone: period = the link's sample count.
  Verdict on_sample(int sensor_id);

  /// A live change (ctl, dashboard): `keys` are applied to the link's current spec (only the
  /// keys given change) and take effect from the link's next sample. Invalid keys or unknown
  /// sensors change nothing and are rejected with the reason.
  /// A trace the keys name is taken from `preloaded` when there (read by the caller outside
  /// any lock), else read here.
  LinkChangeResult request(std::uint64_t request_id, int sensor_id, const LinkKeys& keys,
                           const TraceRows* preloaded = nullptr);
  /// Record a request that could not even be decoded.
  LinkChangeResult reject(std::uint64_t request_id, int sensor_id, const std::string& reason);

  /// The journal entries made since the previous call (requests once their period is known,
  /// timeline events, a ramp's start and end).
  std::vector<AppliedLinkChange> take_changes();

  std::vector<LinkReport> reports() const;
  const LinkReport* report(int sensor_id) const;
  std::uint64_t unknown_sensor_samples() const { return unknown_sensor_samples_; }

 private:
  struct Ramp {
    std::int64_t start_period = 0;
    std::int64_t periods = 0;
    std::vector<std::pair<std::string, double>> from;  // value of each key at start_period
    LinkKeys to;
  };
  struct Link {
    Link(LinkLossProcess loss_process, LinkDelayProcess delay_process, LinkReport first_report)
        : loss(std::move(loss_process)), delay(std::move(delay_process)), report(std::move(first_report)) {}
    LinkLossProcess loss;
    LinkDelayProcess delay;
    LinkReport report;
    std::vector<LinkEvent> timeline;        // this link's events in the order they apply
    std::size_t next_event = 0;
    std::optional<std::uint64_t> unjournaled_request;  // applied, period not yet known
    std::optional<Ramp> ramp;
    std::int64_t samples_seen = 0;
    analysis::RecentArrivals recent;  // emptied with `report.stats`
    // A trace link's period 0: the sample of period k gets the trace's row offset + (k − trace_start).
    std::int64_t trace_start = 0;
    bool trace_restart = false;  // a change made it a (new) trace link: its start is the next sample's period
    double deadline_ms = 0.0;    // a sample delayed longer is late whatever else happens
  };

  void set_link(Link& link, const LinkSpec& spec, bool reset_statistics);
  void apply_due(Link& link, std::int64_t k);
  void step_ramp(Link& link, std::int64_t k);

  std::map<int, Link> links_;
  TraceRows timeline_traces_;  // the traces the timeline switches to, read at start (never per sample)
  std::vector<AppliedLinkChange> changes_;
  std::uint64_t unknown_sensor_samples_ = 0;
};

}  // namespace netkf::nodes
