#include "netkf/cli/dashboard/dashboard_protocol.hpp"

#include <limits>
#include <cmath>
#include <map>

#include "netkf/links/link_keys.hpp"
#include "netkf/theory/report.hpp"

namespace netkf::cli::dashboard {

using nlohmann::json;

namespace {
// ---- client message fields

const json& field(const json& j, const char* name) {
  auto it = j.find(name);
  if (it == j.end()) throw ProtocolError(std::string("missing field '") + name + "'");
  return *it;
}

const json& array_field(const json& j, const char* name) {
  const json& a = field(j, name);
  if (!a.is_array()) throw ProtocolError(std::string("'") + name + "' must be an array");
  if (a.size() > 10000) throw ProtocolError(std::string("'") + name + "' has too many entries");
  return a;
}

std::uint32_t u32(const json& v, const char* what) {
  if (!v.is_number_integer() && !v.is_number_unsigned()) throw ProtocolError(std::string(what) + " must be an integer");
  if (v.is_number_unsigned()) {
    const auto x = v.get<std::uint64_t>();
    if (x > 0xffffffffULL) throw ProtocolError(std::string(what) + " is out of range");
    return static_cast<std::uint32_t>(x);
  }
  const auto x = v.get<std::int64_t>();
  if (x < 0 || x > 0xffffffffLL) throw ProtocolError(std::string(what) + " is out of range");
  return static_cast<std::uint32_t>(x);
}

std::vector<std::string> string_list(const json& j, const char* name) {
  std::vector<std::string> out;
  auto it = j.find(name);
  if (it == j.end() || it->is_null()) return out;
  if (!it->is_array()) throw ProtocolError(std::string("'") + name + "' must be an array of strings");
  for (const auto& v : *it) {
    if (!v.is_string()) throw ProtocolError(std::string("'") + name + "' must be an array of strings");
    out.push_back(v.get<std::string>());
  }
  return out;
}

std::optional<std::string> request_id(const json& j) {
  auto it = j.find("id");
  if (it == j.end() || it->is_null()) return std::nullopt;
  if (!it->is_string()) throw ProtocolError("'id' must be a string");
  return it->get<std::string>();
}

/// "link.2.loss" -> (2, "loss"); nullopt when not of that form.
std::optional<std::pair<int, std::string>> split_parameter_name(const std::string& name) {
  if (name.rfind("link.", 0) != 0) return std::nullopt;
  const auto dot = name.find('.', 5);
  if (dot == std::string::npos || dot == 5 || dot + 1 >= name.size()) return std::nullopt;
  const std::string id_text = name.substr(5, dot - 5);
  if (id_text == kControlLinkName) return std::make_pair(kControlLinkId, name.substr(dot + 1));  // the actuation link
  // A relayed topic's link id (relay_topic_link_id) has up to 10 digits after its sign.
  if (id_text.size() > (id_text[0] == '-' ? 11u : 9u)) return std::nullopt;
  std::size_t i = id_text[0] == '-' ? 1 : 0;
  if (i == id_text.size()) return std::nullopt;
  for (; i < id_text.size(); ++i)
    if (id_text[i] < '0' || id_text[i] > '9') return std::nullopt;
  const long long id = std::stoll(id_text);
  if (id < std::numeric_limits<int>::min()) return std::nullopt;
  return std::make_pair(static_cast<int>(id), name.substr(dot + 1));
}

}  // namespace

json server_info(const std::string& session_id, const Scenario& scenario) {
  return json{{"op", "serverInfo"},
              {"name", "netkf launch"},
              {"capabilities", {"parameters", "parametersSubscribe"}},
              {"metadata", {{"scenario", scenario.name}}},
              {"sessionId", session_id}};
}

json advertise() {
  json list = json::array();
  for (const auto& c : catalogue::channels())
    list.push_back({{"id", static_cast<std::uint32_t>(c.id)},
                    {"topic", c.topic},
                    {"encoding", "json"},
                    {"schemaName", c.schema_name},
                    {"schema", c.schema.dump()},
                    {"schemaEncoding", "jsonschema"}});
  return json{{"op", "advertise"}, {"channels", std::move(list)}};
}

json status_message(LiveEvent::Level level, const std::string& message) {
  return json{{"op", "status"}, {"level", static_cast<int>(level)}, {"message", message}};
}

std::string message_data_frame(std::uint32_t subscription_id, std::uint64_t timestamp_ns, std::string_view payload) {
  std::string frame;
  frame.reserve(13 + payload.size());
  frame.push_back(static_cast<char>(0x01));
  for (int i = 0; i < 4; ++i) frame.push_back(static_cast<char>((subscription_id >> (8 * i)) & 0xff));
  for (int i = 0; i < 8; ++i) frame.push_back(static_cast<char>((timestamp_ns >> (8 * i)) & 0xff));
  frame.append(payload);
  return frame;
}

ClientMessage parse_client_message(std::string_view text) {
  json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) throw ProtocolError("not valid JSON");
  if (!j.is_object()) throw ProtocolError("a message must be a JSON object");
  const json& op_field = field(j, "op");
  if (!op_field.is_string()) throw ProtocolError("'op' must be a string");
  const std::string op = op_field.get<std::string>();
  if (op == "subscribe") {
    Subscribe s;
    for (const auto& sub : array_field(j, "subscriptions")) {
      if (!sub.is_object()) throw ProtocolError("each subscription must be an object");
      s.subscriptions.emplace_back(u32(field(sub, "id"), "subscription id"),
                                   u32(field(sub, "channelId"), "channelId"));
    }
    return s;
  }
  if (op == "unsubscribe") {
    Unsubscribe u;
    for (const auto& id : array_field(j, "subscriptionIds")) u.subscription_ids.push_back(u32(id, "subscription id"));
    return u;
  }
  if (op == "getParameters") return GetParameters{string_list(j, "parameterNames"), request_id(j)};
  if (op == "setParameters") {
    SetParameters s;
    s.id = request_id(j);
    for (const auto& p : array_field(j, "parameters")) {
      if (!p.is_object()) throw ProtocolError("each parameter must be an object");
      const json& name = field(p, "name");
      if (!name.is_string()) throw ProtocolError("a parameter's 'name' must be a string");
      auto value = p.find("value");
      s.parameters.emplace_back(name.get<std::string>(), value == p.end() ? json(nullptr) : *value);
    }
    return s;
  }
  if (op == "subscribeParameterUpdates") return ParameterUpdates{true, string_list(j, "parameterNames")};
  if (op == "unsubscribeParameterUpdates") return ParameterUpdates{false, string_list(j, "parameterNames")};
  throw ProtocolError("unsupported op '" + op.substr(0, 64) + "'");
}

json link_parameter_values(const LinkView& link, const std::optional<std::string>& id) {
  json list = json::array();
  const std::string prefix = "link." + link_name(link.sensor_id) + ".";
  const json keys = catalogue::link_json(link.link);  // named: items() refers into it
  for (const auto& [name, value] : keys.items()) {
    json p{{"name", prefix + name}, {"value", value}};
    if (value.is_number()) p["type"] = "float64";
    list.push_back(std::move(p));
  }
  json j{{"op", "parameterValues"}, {"parameters", std::move(list)}};
  if (id) j["id"] = *id;
  return j;
}

json parameter_values(const std::vector<LinkView>& links, const std::vector<std::string>& names,
                      const std::optional<std::string>& id) {
  json list = json::array();
  for (const auto& link : links) {
    json values = link_parameter_values(link, std::nullopt);  // named: the loop runs over a part of it
    for (auto& p : values["parameters"]) {
      const auto name = p["name"].get<std::string>();
      bool wanted = names.empty();
      for (const auto& n : names) wanted = wanted || n == name;
      if (wanted) list.push_back(std::move(p));
    }
  }
  json j{{"op", "parameterValues"}, {"parameters", std::move(list)}};
  if (id) j["id"] = *id;
  return j;
}

std::vector<RequestedLinkChange> link_changes(const SetParameters& request, const std::vector<LinkView>& links) {
  // Gather each link's requested values; refuse names that are not link parameters.
  std::vector<RequestedLinkChange> refused;
  std::map<int, std::map<std::string, json>> by_link;
  for (const auto& [name, value] : request.parameters) {
    const auto parts = split_parameter_name(name);
    if (!parts) {
      refused.push_back({-1, std::nullopt, {}, "unknown parameter '" + name.substr(0, 80) + "' (expected link.ID.NAME)"});
      continue;
    }
    by_link[parts->first][parts->second] = value;
  }
  std::vector<RequestedLinkChange> out;
  for (auto& [sensor_id, values] : by_link) {
    RequestedLinkChange change{sensor_id, std::nullopt, {}, {}};
    const LinkView* link = nullptr;
    for (const auto& l : links)
      if (l.sensor_id == sensor_id) link = &l;
    if (!link) {
      change.refusal = "link " + link_name(sensor_id) + ": unknown link (no sensor with that id, or no actuation link)";
      out.push_back(change);
      continue;
    }
    // The values become link keys by their JSON type; the link type judges them (names,
    // types, combinations, ranges), exactly as for a scenario file or `netkf ctl`.
    LinkKeys keys;
    std::string problem;
    for (const auto& [param, value] : values) {
      // A model equal to the link's changes nothing by itself (a panel sends it along).
      if (param == "model" && value.is_string() && value.get<std::string>() == link_kind(link->link)) continue;
      // A browser does not name files on the host: a trace link is made by a scenario or `netkf ctl`.
      if (param == "trace" || (param == "model" && value.is_string() && value.get<std::string>() == "trace")) {
        problem = "a trace link is set by the scenario or `netkf ctl set-link ID --trace FILE`, not from the dashboard";
        break;
      }
      if (value.is_string()) {
        keys.push_back({param, value.get<std::string>().substr(0, 64)});
      } else if (value.is_number()) {
        keys.push_back({param, value.get<double>()});
      } else {
        problem = param.substr(0, 40) + " must be a number or a name";
        break;
      }
    }
    if (problem.empty()) {
      try {
        change.link = apply_link_keys(link->link, keys);
        change.keys = std::move(keys);
      } catch (const LinkError& e) {
        problem = e.what();
      }
    }
    if (!problem.empty()) change.refusal = "link " + link->name() + ": " + problem;
    out.push_back(std::move(change));
  }
  out.insert(out.end(), refused.begin(), refused.end());
  return out;
}

}  // namespace netkf::cli::dashboard
