#pragma once
// The dashboard's side of the Foxglove WebSocket protocol (foxglove.websocket.v1), without
// sockets: the advertisement of the channel catalogue (channel_catalogue.hpp), the binary
// message-data frame, the parsing of client messages, and the link parameters (link.ID.NAME) mapped to
// and from link models. docs/dashboard.md is the user-facing description.
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "netkf/cli/live/channel_catalogue.hpp"
#include "netkf/cli/live/live_snapshot.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::cli::dashboard {

inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

/// A malformed or unknown client message; what() is the reason sent back to the client.
struct ProtocolError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// ---- server -> client (JSON text messages)
nlohmann::json server_info(const std::string& session_id, const Scenario& scenario);
nlohmann::json advertise();
nlohmann::json status_message(LiveEvent::Level level, const std::string& message);

/// The binary Message Data frame: opcode 0x01, subscription id (u32 LE), timestamp in ns
/// (u64 LE), then the payload.
std::string message_data_frame(std::uint32_t subscription_id, std::uint64_t timestamp_ns, std::string_view payload);

// ---- client -> server
struct Subscribe {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> subscriptions;  // (subscription id, channel id)
};
struct Unsubscribe {
  std::vector<std::uint32_t> subscription_ids;
};
struct GetParameters {
  std::vector<std::string> names;  // empty: all
  std::optional<std::string> id;
};
struct SetParameters {
  std::vector<std::pair<std::string, nlohmann::json>> parameters;  // name, value (null: unset)
  std::optional<std::string> id;
};
struct ParameterUpdates {
  bool subscribe = true;
  std::vector<std::string> names;  // empty: all
};
using ClientMessage = std::variant<Subscribe, Unsubscribe, GetParameters, SetParameters, ParameterUpdates>;

/// Parse one text message of a client. Throws ProtocolError with the reason (not JSON, no
/// `op`, an op this server does not support, a field of the wrong type or out of range).
ClientMessage parse_client_message(std::string_view text);

// ---- parameters: link.ID.KEY for every link key (docs/scenario-format.md, "Links"): model,
// loss, p, r, loss_good, loss_bad, mean_burst, delay_ms, jitter_ms, delay_distribution (a trace
// link is not made from the dashboard: trace, model trace are refused)
/// The links' current parameters (each link's keys; a Gilbert-Elliott link in both forms);
/// `names` empty: all of them; names that do not exist are left out.
nlohmann::json parameter_values(const std::vector<LinkView>& links, const std::vector<std::string>& names,
                                const std::optional<std::string>& id);
/// The parameters of one link only.
nlohmann::json link_parameter_values(const LinkView& link, const std::optional<std::string>& id);

/// One link's requested change: the keys to send and the link they make of the current one,
/// or why it is refused (then nothing changes).
struct RequestedLinkChange {
  int sensor_id = 0;
  std::optional<LinkKeys> keys;
  LinkSpec link;        // the link after the change (when keys is set)
  std::string refusal;  // set when keys is empty
};
/// Group a setParameters by link and check each link's keys against its current link.
/// Names that are not link.ID.NAME of a known link and parameter are refused (sensor_id
/// then is the id named, or -1 when none could be read).
std::vector<RequestedLinkChange> link_changes(const SetParameters& request, const std::vector<LinkView>& links);

}  // namespace netkf::cli::dashboard
