#pragma once
// `netkf trace extract`: the arrival trace a link had in a recording (docs/cli.md,
// "netkf trace extract"). The samples CSV (`--record-samples`) and the MCAP's
// `netkf/measurement/delivered` channel list every sample the channel delivered; a link's
// trace says, for each period of the recording, whether its sample was among them.
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>

#include "netkf/cli/recording/ros2_bag.hpp"
#include "netkf/links/link_trace.hpp"

namespace netkf::cli {

/// The delivered (sensor, period) pairs of a recording.
struct DeliveredSamples {
  std::map<int, std::set<std::int64_t>> periods_by_sensor;
  std::optional<std::int64_t> first_k, last_k;  // over every sensor: the periods the recording saw
};

/// A recording's delivered samples: a samples CSV (header `k,sensor_id,...`) or an MCAP file
/// (by its name's `.mcap`; a ros2-profile MCAP is decoded with `codec`, without one it is
/// refused). Throws std::runtime_error naming FILE (and LINE for a CSV).
DeliveredSamples read_delivered_samples(const std::string& path, const ros2::Ros2Codec* codec = nullptr);
/// The actuation link's (link `control`, kControlLinkId) arrivals: a period CSV (`--record`,
/// its `nu` column) or an MCAP (the truth's `input_arrived`) of a scenario with
/// plant.control.link; input k's fate is in period k + 1's row. Throws like the above.
DeliveredSamples read_input_arrivals(const std::string& path, const ros2::Ros2Codec* codec = nullptr);

/// Link `sensor_id`'s trace over the periods first..last (default: the first and last period
/// any sensor delivered in; a period after the last delivered sample of every link is unknown).
/// Throws std::runtime_error for a link with no sample, an empty range or one above
/// max_trace_samples.
LinkTrace extract_link_trace(const DeliveredSamples& samples, int sensor_id, std::optional<std::int64_t> first = {},
                             std::optional<std::int64_t> last = {});

/// A `netkf relay --record` file (docs/relay.md): each relayed sample's fate by topic and index.
/// Unlike a launch's recordings it lists the dropped samples too, and the delay of each delivered one.
struct RelayFates {
  struct Fate {
    bool delivered = false;
    double delay_ms = 0.0;
  };
  std::map<std::string, std::map<std::uint64_t, Fate>> by_topic;  // topic -> index -> fate
};
/// Whether a file starts with the relay record's header (`topic,index,...`), so `trace extract`
/// can say what to give for it.
bool is_relay_record(const std::string& path);
/// Reads a relay's record, checked as the relay writes it (the header, five fields after the
/// topic, an index once per topic, fate `delivered` or `dropped`, a delay >= 0). Throws
/// std::runtime_error naming FILE:LINE.
RelayFates read_relay_fates(const std::string& path);
/// Topic `topic`'s trace over its indexes first..last (default: the first and last the record has):
/// k is the topic's sample index; a delay_ms column when a delivered sample of the range was
/// delayed. Throws std::runtime_error for a topic not in the record, an index of the range missing
/// from it (a cut record), an empty range or one above max_trace_samples.
LinkTrace extract_topic_trace(const RelayFates& fates, const std::string& topic, std::optional<std::int64_t> first = {},
                              std::optional<std::int64_t> last = {});

}  // namespace netkf::cli
