#pragma once
// What the live commands (launch, record, ctl) see of the network, in plain C++:
// filled from the DDS library's types in one adapter (live_bus.cpp), consumed by the
// recorder and the status view, which therefore need no DDS to be tested.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "netkf/analysis/recent_loss_fit.hpp"
#include "netkf/estimate.hpp"
#include "netkf/scenario.hpp"

namespace netkf::cli {

/// Ground truth x_k of period k at time t_k (from the plant).
struct TruthRecord {
  std::int64_t k = 0;
  double t = 0.0;
  std::vector<double> x;
  std::vector<double> u;  // closed loop: the input u_{k-1} the plant applied to produce x_k (else empty)
  bool input_arrived = true;  // ν_{k-1}: u_{k-1} reached the plant in time (true at k = 0 and in an open loop)
};

/// The estimator's output for period k is the core type `netkf::Estimate` (netkf/estimate.hpp).
using netkf::Estimate;

/// A measurement the channel delivered to the estimator.
struct DeliveredRecord {
  int sensor_id = 0;
  std::int64_t k = 0;
  double stamp = 0.0;          // sensor publish stamp, seconds
  std::vector<double> y;
};

/// One link of the channel emulator, as it last reported itself.
struct LinkStatusRecord {
  int sensor_id = 0;
  LinkSpec link;
  double in_time = 1.0;          // theory: P(delay <= deadline)
  std::uint64_t held = 0;        // delivered samples waiting out their delay
  std::uint64_t past_deadline = 0;  // of `delivered`: delayed beyond the deadline (late whatever else happens)
  // Since the current model was set (they describe the model shown):
  std::uint64_t samples_in = 0;
  std::uint64_t delivered = 0;
  std::uint64_t dropped = 0;
  double observed_loss = 0.0;
  double mean_burst_length = 0.0;
  // Since the channel started (not reset by a change):
  std::uint64_t samples_total = 0;
  std::uint64_t delivered_total = 0;
  std::uint64_t dropped_total = 0;
  std::uint64_t last_request_id = 0;
  std::string rejection_reason;  // empty when the last request was applied
  /// The model the link's last samples show (recent_loss_fit.hpp; none before its first sample).
  std::optional<analysis::RecentLossFit> recent_fit;
  /// A link of `netkf relay` (docs/relay.md): the topic it relays (sensor_id is then the topic's
  /// own negative id); empty for a channel's link.
  std::string topic;

  /// The link's name for people: its topic, "control", or its sensor id.
  std::string name() const { return topic.empty() ? link_name(sensor_id) : topic; }

  /// λ = (1 − stationary loss) · P(in time): the rate at which the link's samples reach the
  /// estimator before the deadline (docs/scenario-format.md, "Delay"), the rate the theory uses.
  double arrival_rate() const { return netkf::arrival_rate(link.loss, in_time); }
};

/// One entry of the channel's link journal: the link after a change, and the period of the
/// first sample it applied to.
struct LinkChangeRecord {
  int sensor_id = 0;
  std::int64_t at_period = 0;
  std::string origin;            // "request" | "timeline"
  std::uint64_t request_id = 0;
  LinkSpec link;
  std::string topic;  // a relayed topic's link (at_period: the index of its first sample changed)
};

/// The channel's answer to one link change request.
struct LinkReplyRecord {
  std::uint64_t request_id = 0;
  int sensor_id = 0;
  bool applied = false;
  std::string reason;
};

}  // namespace netkf::cli
