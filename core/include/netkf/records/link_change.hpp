#pragma once
// One entry of a link journal: a link after a change, and where it took effect. The channel
// emulator and `netkf relay` make them, dds/ carries them (idl/netkf.idl, LinkChange), the
// recorders write them and replays read them back.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "netkf/links/link.hpp"

namespace netkf {

struct LinkChange {
  /// Who made the change: a live request (ctl, the dashboard) or the scenario's timeline.
  enum class Origin { request, timeline };
  int sensor_id = 0;             // the link's id (a relayed topic's: relay_topic_link_id of it)
  std::int64_t at_period = 0;    // the period of the first sample it applied to (a relayed topic: that sample's index)
  Origin origin = Origin::request;
  std::uint64_t request_id = 0;  // Origin::request (0: a request without an id, e.g. the WebSocket)
  LinkSpec link;                 // the whole link after the change
  std::string topic;             // a relayed topic's link; empty for a channel's link
  std::string failure;           // a timeline event that could not apply (the link is unchanged; not published)
};

/// "request" / "timeline", as the wire and the recordings write it.
const char* to_string(LinkChange::Origin origin);
/// The origin a text names; nullopt for anything else.
std::optional<LinkChange::Origin> parse_link_change_origin(std::string_view text);

}  // namespace netkf
