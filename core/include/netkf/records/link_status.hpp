#pragma once
// One link's status, as its owner (the channel emulator, `netkf relay`) publishes it about once a
// second and after every change: the one link-status type every layer passes along (the owner
// fills it, dds/ converts it to and from the wire, the CLI records and shows it). Field names
// follow the wire type (idl/netkf.idl, LinkStatus).
#include <cstdint>
#include <optional>
#include <string>

#include "netkf/fit/recent_loss_fit.hpp"
#include "netkf/links/link.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/loss_model.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf {

struct LinkStatus {
  int sensor_id = 0;             // the link's id: its sensor, kControlLinkId, or a relayed topic's own id
  LinkSpec link;                 // the link as it is now
  double in_time = 1.0;          // theory: P(delay <= deadline)
  std::uint64_t held = 0;        // delivered samples waiting out their delay now
  std::uint64_t past_deadline = 0;  // of `delivered`: delayed beyond the deadline (late whatever else happens)
  // Since the current model was set (they describe the model shown; a ramp's steps do not reset them):
  std::uint64_t samples_in = 0;
  std::uint64_t delivered = 0;
  std::uint64_t dropped = 0;
  double observed_loss = 0.0;
  double mean_burst_length = 0.0;  // observed mean run of consecutive drops
  // Since the owner started (not reset by a change):
  std::uint64_t samples_total = 0;
  std::uint64_t delivered_total = 0;
  std::uint64_t dropped_total = 0;
  std::uint64_t last_request_id = 0;  // the last change request handled for this link (0: none)
  std::string rejection_reason;       // why that request was refused (empty when it was applied)
  /// The model the link's last samples show (recent_loss_fit.hpp; none before its first sample).
  std::optional<fit::RecentLossFit> recent_fit;
  /// A link of `netkf relay` (docs/relay.md): the topic it relays (sensor_id is then
  /// relay_topic_link_id of it); empty for a channel's link.
  std::string topic;

  /// The counts from the owner's running statistics: since the model was set, and in all.
  void count(const LinkStatistics& since_change, const LinkStatistics& lifetime) {
    samples_in = since_change.samples();
    delivered = since_change.delivered();
    dropped = since_change.dropped();
    observed_loss = since_change.observed_loss();
    mean_burst_length = since_change.mean_burst_length();
    samples_total = lifetime.samples();
    delivered_total = lifetime.delivered();
    dropped_total = lifetime.dropped();
  }
  /// The link's name for people: its topic, "control", or its sensor id.
  std::string name() const { return topic.empty() ? link_name(sensor_id) : topic; }
  /// λ = (1 − stationary loss) · P(in time): the rate at which the link's samples reach the
  /// estimator before the deadline (docs/scenario-format.md, "Delay"), the rate the theory uses.
  double arrival_rate() const { return netkf::arrival_rate(link.loss, in_time); }
};

}  // namespace netkf
