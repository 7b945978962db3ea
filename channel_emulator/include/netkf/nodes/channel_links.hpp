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

#include "netkf/fit/recent_loss_fit.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/loss_model.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/records/link_change.hpp"
#include "netkf/records/link_reply.hpp"
#include "netkf/records/link_status.hpp"

namespace netkf::nodes {

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
  LinkReply request(std::uint64_t request_id, int sensor_id, const LinkKeys& keys,
                    const TraceRows* preloaded = nullptr);
  /// Record a request that could not even be decoded.
  LinkReply reject(std::uint64_t request_id, int sensor_id, const std::string& reason);

  /// The journal entries made since the previous call (requests once their period is known,
  /// timeline events, a ramp's start and end).
  /// Entries with a `failure` are timeline events that could not apply (logged, not published).
  std::vector<LinkChange> take_changes();

  /// Every link's status (`held` is the caller's: it holds the delayed samples).
  std::vector<LinkStatus> statuses() const;
  /// One link's status; nullopt for an unknown link.
  std::optional<LinkStatus> status(int sensor_id) const;
  /// The link as it is now, without its statistics (status() also fits its recent samples);
  /// nullopt for an unknown link.
  std::optional<LinkSpec> link(int sensor_id) const;
  /// The deadline a link's delays are judged by (the estimator's; the actuation link's: the
  /// plant's next tick); nullopt for an unknown link.
  std::optional<double> deadline_ms(int sensor_id) const;
  std::uint64_t unknown_sensor_samples() const { return unknown_sensor_samples_; }

 private:
  struct Ramp {
    std::int64_t start_period = 0;
    std::int64_t periods = 0;
    std::vector<std::pair<std::string, double>> from;  // value of each key at start_period
    LinkKeys to;
  };
  struct Link {
    Link(int link_id, const LinkSpec& first, LinkLossProcess loss_process, LinkDelayProcess delay_process)
        : id(link_id), spec(first), loss(std::move(loss_process)), delay(std::move(delay_process)) {}
    int id = 0;
    LinkSpec spec;  // the link as it is now
    LinkLossProcess loss;
    LinkDelayProcess delay;
    LinkStatistics stats;     // since the current model was set (a ramp's steps do not reset it)
    LinkStatistics lifetime;  // since the channel started (not reset by a change)
    std::uint64_t past_deadline = 0;  // delivered with a delay above the deadline (as stats)
    std::uint64_t last_request_id = 0;
    std::string reject_reason;        // of the last request (empty: applied)
    std::vector<LinkEvent> timeline;        // this link's events in the order they apply
    std::size_t next_event = 0;
    std::optional<std::uint64_t> unjournaled_request;  // applied, period not yet known
    std::optional<Ramp> ramp;
    std::int64_t samples_seen = 0;
    fit::RecentArrivals recent;  // emptied with `stats`
    // A trace link's period 0: the sample of period k gets the trace's row offset + (k − trace_start).
    std::int64_t trace_start = 0;
    bool trace_restart = false;  // a change made it a (new) trace link: its start is the next sample's period
    double deadline_ms = 0.0;    // a sample delayed longer is late whatever else happens
  };

  void set_link(Link& link, const LinkSpec& spec, bool reset_statistics);
  void apply_due(Link& link, std::int64_t k);
  void step_ramp(Link& link, std::int64_t k);
  static LinkStatus status_of(const Link& link);

  std::map<int, Link> links_;
  TraceRows timeline_traces_;  // the traces the timeline switches to, read at start (never per sample)
  std::vector<LinkChange> changes_;
  std::uint64_t unknown_sensor_samples_ = 0;
};

}  // namespace netkf::nodes
