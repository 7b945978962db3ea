#pragma once
// One client's side of the Foxglove WebSocket protocol (foxglove.websocket.v1), without
// sockets: its subscriptions (subscription id -> channel id), its parameter-update
// subscriptions, and what to send when it speaks. dashboard_server.cpp owns the socket and
// sends what this decides; the link-control path (the caller's hooks) answers parameters.
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "netkf/cli/dashboard/dashboard_protocol.hpp"

namespace netkf::cli::dashboard {

/// A channel's latest message, kept for new subscribers, by (channel id, latch key).
struct LatchedMessage {
  std::string payload;
  std::uint64_t timestamp_ns = 0;
};
using LatchedMessages = std::map<std::pair<std::uint32_t, int>, LatchedMessage>;

/// One message for the client: JSON text, or a binary Message Data frame (`binary`).
struct Outgoing {
  bool binary = false;
  nlohmann::json message;  // text
  std::string frame;       // binary
  bool keep = false;       // binary: a latched state frame, never dropped for a slow client
};

/// What a client message asks of the connection, in the order to do it.
struct SessionActions {
  /// Text goes out at once, Message Data frames with the next batch.
  std::vector<Outgoing> send;
  bool send_data_now = false;  // send the queued data frames now, not with the next batch
  std::optional<GetParameters> get_parameters;  // to answer with the links' values
  std::optional<SetParameters> set_parameters;  // to pass on to the link-control path
  std::vector<std::string> refused;              // why parts of the message were refused (for the log)
};

class FoxgloveSession {
 public:
  /// A text message of the client; `latched`: the channels' latest messages, sent at once to
  /// a new subscriber so a page opened mid-run shows the state.
  SessionActions on_text(std::string_view text, const LatchedMessages& latched);
  /// A binary message of the client (this server takes none: clientPublish is not offered).
  SessionActions on_binary();

  /// The Message Data frames of one channel message, one per subscription to the channel.
  std::vector<std::string> message_frames(std::uint32_t channel, std::uint64_t timestamp_ns,
                                          std::string_view payload) const;
  /// The part of a parameterValues message this client subscribed to; nullopt: none.
  std::optional<nlohmann::json> parameter_update(const nlohmann::json& parameter_values) const;

  const std::map<std::uint32_t, std::uint32_t>& subscriptions() const { return subscriptions_; }
  /// Client messages (or subscriptions in one) refused with an error status so far.
  std::uint64_t refused() const { return refused_; }

 private:
  void subscribe(const Subscribe& request, const LatchedMessages& latched, SessionActions& actions);
  void update_parameter_subscriptions(const ParameterUpdates& request);
  void refuse(SessionActions& actions, const std::string& why);

  std::map<std::uint32_t, std::uint32_t> subscriptions_;  // subscription id -> channel id
  std::set<std::string> parameter_subscriptions_;
  bool all_parameters_ = false;
  std::uint64_t refused_ = 0;
};

}  // namespace netkf::cli::dashboard
