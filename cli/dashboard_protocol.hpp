#pragma once
// The dashboard's side of the Foxglove WebSocket protocol (foxglove.websocket.v1), without
// sockets: the channels netkf advertises and their JSON messages, the binary message-data
// frame, the parsing of client messages, and the link parameters (link.ID.NAME) mapped to
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

#include "live_records.hpp"
#include "live_snapshot.hpp"
#include "netkf/scenario.hpp"

namespace netkf::cli::dashboard {

inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

/// The channels every connection is offered (ids are fixed: a reconnecting client may cache them).
enum class ChannelId : std::uint32_t { scenario = 1, estimate = 2, truth = 3, link_status = 4, theory = 5, network = 6,
  // Recordings only (netkf launch --record FILE.mcap), not offered by the dashboard:
  delivered = 7, link_change = 8, events = 9 };

struct Channel {
  ChannelId id;
  std::string topic;
  std::string schema_name;
  nlohmann::json schema;  // JSON schema of the messages
};
const std::vector<Channel>& channels();
const Channel* find_channel(std::uint32_t id);
/// Any channel by id: the dashboard's and the recordings' own (delivered, link_change).
/// The topic is the DDS topic the messages come from (netkf/truth, netkf/estimate, ...).
const Channel& channel(ChannelId id);

/// A malformed or unknown client message; what() is the reason sent back to the client.
struct ProtocolError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// ---- server -> client (JSON text messages)
nlohmann::json server_info(const std::string& session_id, const Scenario& scenario);
nlohmann::json advertise();
nlohmann::json status_message(LiveEvent::Level level, const std::string& message);

// ---- channel messages
nlohmann::json scenario_message(const Scenario& scenario);
nlohmann::json estimate_message(const EstimateRecord& estimate);
nlohmann::json truth_message(const TruthRecord& truth);
nlohmann::json link_status_message(const LinkView& link);
/// Recordings: a delivered measurement, and one entry of the channel's link journal (the
/// link after the change, keys as in link_status_message).
nlohmann::json delivered_message(const DeliveredRecord& sample);
nlohmann::json link_change_message(const LinkChangeRecord& change);
/// Recordings: an event of the live model (the dashboard's event log) as Foxglove's
/// well-known foxglove.Log, so Foxglove's Log panel lists it; `time_ns` on the run's clock.
nlohmann::json log_message(const LiveEvent& event, std::uint64_t time_ns);
nlohmann::json theory_message(const TheoryView& theory);
nlohmann::json network_message(const LiveSnapshot& snapshot);

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
// loss, p, r, loss_good, loss_bad, mean_burst, delay_ms, jitter_ms, delay_distribution
/// The links' current parameters (each link's keys; a Gilbert-Elliott link in both forms);
/// `names` empty: all of them; names that do not exist are left out.
nlohmann::json parameter_values(const std::vector<LinkView>& links, const std::vector<std::string>& names,
                                const std::optional<std::string>& id);
/// The parameters of one link only.
nlohmann::json link_parameter_values(const LinkView& link, const std::optional<std::string>& id);

/// One link's requested change: the keys to send and the link they make of the current one,
/// or why it is refused (then nothing changes).
struct LinkChange {
  int sensor_id = 0;
  std::optional<LinkKeys> keys;
  LinkSpec link;        // the link after the change (when keys is set)
  std::string refusal;  // set when keys is empty
};
/// Group a setParameters by link and check each link's keys against its current link.
/// Names that are not link.ID.NAME of a known link and parameter are refused (sensor_id
/// then is the id named, or -1 when none could be read).
std::vector<LinkChange> link_changes(const SetParameters& request, const std::vector<LinkView>& links);

}  // namespace netkf::cli::dashboard
