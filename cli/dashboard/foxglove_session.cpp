#include "foxglove_session.hpp"

#include <variant>

namespace netkf::cli::dashboard {

SessionActions FoxgloveSession::on_text(std::string_view text, const LatchedMessages& latched) {
  SessionActions actions;
  ClientMessage message;
  try {
    message = parse_client_message(text);
  } catch (const ProtocolError& e) {
    refuse(actions, std::string("message refused: ") + e.what());
    return actions;
  }
  if (auto* sub = std::get_if<Subscribe>(&message)) {
    subscribe(*sub, latched, actions);
  } else if (auto* unsub = std::get_if<Unsubscribe>(&message)) {
    for (auto id : unsub->subscription_ids) subscriptions_.erase(id);
  } else if (auto* get = std::get_if<GetParameters>(&message)) {
    actions.get_parameters = std::move(*get);
  } else if (auto* set = std::get_if<SetParameters>(&message)) {
    actions.set_parameters = std::move(*set);
  } else if (auto* updates = std::get_if<ParameterUpdates>(&message)) {
    update_parameter_subscriptions(*updates);
  }
  return actions;
}

SessionActions FoxgloveSession::on_binary() {
  SessionActions actions;
  refuse(actions, "binary client messages are not supported by this server");
  return actions;
}

void FoxgloveSession::subscribe(const Subscribe& request, const LatchedMessages& latched, SessionActions& actions) {
  for (const auto& [subscription, channel] : request.subscriptions) {
    if (!catalogue::find_channel(channel)) {
      refuse(actions, "subscribe: unknown channel " + std::to_string(channel));
      continue;
    }
    // The spec lets a server ignore a reused id with an error status; the first stays.
    if (subscriptions_.count(subscription)) {
      refuse(actions, "subscribe: subscription id " + std::to_string(subscription) + " is already in use");
      continue;
    }
    subscriptions_[subscription] = channel;
    for (const auto& [key, value] : latched)
      if (key.first == channel)
        actions.send.push_back({true, {}, message_data_frame(subscription, value.timestamp_ns, value.payload), true});
  }
  actions.send_data_now = true;
}

void FoxgloveSession::update_parameter_subscriptions(const ParameterUpdates& request) {
  if (request.subscribe) {
    if (request.names.empty()) all_parameters_ = true;
    parameter_subscriptions_.insert(request.names.begin(), request.names.end());
  } else if (request.names.empty()) {
    all_parameters_ = false;
    parameter_subscriptions_.clear();
  } else {
    for (const auto& n : request.names) parameter_subscriptions_.erase(n);
  }
}

void FoxgloveSession::refuse(SessionActions& actions, const std::string& why) {
  ++refused_;
  actions.refused.push_back(why);
  actions.send.push_back({false, status_message(LiveEvent::Level::error, why), {}});
}

std::vector<std::string> FoxgloveSession::message_frames(std::uint32_t channel, std::uint64_t timestamp_ns,
                                                         std::string_view payload) const {
  std::vector<std::string> frames;
  for (const auto& [subscription, ch] : subscriptions_)
    if (ch == channel) frames.push_back(message_data_frame(subscription, timestamp_ns, payload));
  return frames;
}

std::optional<nlohmann::json> FoxgloveSession::parameter_update(const nlohmann::json& parameter_values) const {
  nlohmann::json mine = nlohmann::json::array();
  for (const auto& p : parameter_values["parameters"])
    if (all_parameters_ || parameter_subscriptions_.count(p["name"].get<std::string>())) mine.push_back(p);
  if (mine.empty()) return std::nullopt;
  return nlohmann::json{{"op", "parameterValues"}, {"parameters", std::move(mine)}};
}

}  // namespace netkf::cli::dashboard
