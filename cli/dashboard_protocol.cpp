#include "dashboard_protocol.hpp"

#include <cmath>
#include <map>

#include "netkf/analysis/report.hpp"

namespace netkf::cli::dashboard {

using nlohmann::json;

namespace {

// JSON has no NaN or infinity: a non-finite number is sent as null (e.g. the mean burst
// length of a link that never delivers).
json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json optional_number(const std::optional<double>& v) { return v ? number_or_null(*v) : json(nullptr); }

json schema_object(json properties, std::vector<std::string> required) {
  return json{{"type", "object"}, {"properties", std::move(properties)}, {"required", std::move(required)}};
}
json number_array() { return json{{"type", "array"}, {"items", {{"type", "number"}}}}; }
json nullable_number() { return json{{"type", json::array({"number", "null"})}}; }

json link_model_schema() {
  return json{{"model", {{"type", "string"}, {"enum", {"bernoulli", "gilbert_elliott"}}}},
              {"loss", {{"type", "number"}}},
              {"p", {{"type", "number"}}},
              {"r", {{"type", "number"}}},
              {"loss_good", {{"type", "number"}}},
              {"loss_bad", {{"type", "number"}}}};
}

json assessment_schema() {
  return json{{"type", json::array({"object", "null"})},
              {"properties",
               {{"arrival_rates", number_array()},
                {"stable", {{"type", "string"}, {"enum", {"yes", "no", "unknown"}}}},
                {"lower_trace", nullable_number()},
                {"upper_trace", nullable_number()},
                {"markov_criterion", nullable_number()},
                {"reason", {{"type", "string"}}}}}};
}

std::vector<Channel> make_channels() {
  std::vector<Channel> c;
  json link_props = link_model_schema();
  c.push_back({ChannelId::scenario, "netkf/scenario", "netkf.Scenario",
               schema_object({{"name", {{"type", "string"}}},
                              {"period_ms", {{"type", "number"}}},
                              {"state_dim", {{"type", "integer"}}},
                              {"seed", {{"type", "integer"}}},
                              {"sensors",
                               {{"type", "array"},
                                {"items", schema_object({{"id", {{"type", "integer"}}},
                                                         {"measurement_dim", {{"type", "integer"}}},
                                                         {"link", schema_object(link_props, {"model"})}},
                                                        {"id", "link"})}}}},
                             {"name", "period_ms", "state_dim", "sensors"})});
  c.push_back({ChannelId::estimate, "netkf/estimate", "netkf.wire.Estimate",
               schema_object({{"k", {{"type", "integer"}}},
                              {"t", {{"type", "number"}}},
                              {"x_hat", number_array()},
                              {"P", number_array()},
                              {"fused", {{"type", "array"}, {"items", {{"type", "integer"}}}}},
                              {"late", {{"type", "integer"}}},
                              {"late_total", {{"type", "integer"}}},
                              {"rejected_total", {{"type", "integer"}}},
                              {"state", {{"type", "string"}, {"enum", {"ok", "diverging"}}}},
                              {"trace_P", {{"type", "number"}}},
                              {"trace_P_pred", {{"type", "number"}}}},
                             {"k", "t", "x_hat", "P", "fused", "state", "trace_P", "trace_P_pred"})});
  c.push_back({ChannelId::truth, "netkf/truth", "netkf.wire.Truth",
               schema_object({{"k", {{"type", "integer"}}}, {"t", {{"type", "number"}}}, {"x", number_array()}},
                             {"k", "t", "x"})});
  json status_props = link_props;
  for (const char* counter : {"sensor_id", "samples_in", "delivered", "dropped", "samples_total", "delivered_total",
                              "dropped_total", "last_request_id"})
    status_props[counter] = {{"type", "integer"}};
  status_props["stationary_loss"] = {{"type", "number"}};
  status_props["observed_loss"] = {{"type", "number"}};
  status_props["mean_burst_length"] = nullable_number();
  status_props["configured_arrival_rate"] = {{"type", "number"}};
  status_props["observed_arrival_rate"] = nullable_number();
  status_props["last_request_rejected"] = {{"type", "boolean"}};
  status_props["reject_reason"] = {{"type", "string"}};
  c.push_back({ChannelId::link_status, "netkf/link/status", "netkf.wire.LinkStatus",
               schema_object(status_props, {"sensor_id", "model", "samples_in", "delivered", "dropped"})});
  c.push_back({ChannelId::theory, "netkf/theory", "netkf.Theory",
               schema_object({{"k", {{"type", "integer"}}},
                              {"configured", assessment_schema()},
                              {"observed", assessment_schema()},
                              {"region",
                               {{"type", json::array({"array", "null"})},
                                {"items", schema_object({{"lambda1", {{"type", "number"}}},
                                                         {"lambda2_lower", nullable_number()},
                                                         {"lambda2_upper", nullable_number()}},
                                                        {"lambda1", "lambda2_lower"})}}}},
                             {"k", "configured"})});
  c.push_back({ChannelId::network, "netkf/network", "netkf.Network",
               schema_object({{"k", {{"type", json::array({"integer", "null"})}}},
                              {"estimates", {{"type", "integer"}}},
                              {"rms_error", nullable_number()},
                              {"mean_trace_P", {{"type", "number"}}},
                              {"mean_trace_P_pred", {{"type", "number"}}},
                              {"late_total", {{"type", "integer"}}},
                              {"rejected_total", {{"type", "integer"}}},
                              {"invalid_samples", {{"type", "integer"}}},
                              {"processes",
                               {{"type", "array"},
                                {"items", schema_object({{"name", {{"type", "string"}}},
                                                         {"pid", {{"type", "integer"}}},
                                                         {"running", {{"type", "boolean"}}},
                                                         {"restarts", {{"type", "integer"}}}},
                                                        {"name"})}}}},
                             {"estimates", "processes"})});
  return c;
}

json link_model_json(const LinkModel& model) {
  json j{{"model", link_model_name(model)}};
  for (const auto& [name, value] : link_parameters(model)) j[name] = value;
  return j;
}

json assessment_json(const AssessmentView& a) {
  return json{{"arrival_rates", a.arrival_rates},
              {"stable", analysis::to_string(a.result.stable)},
              {"lower_trace", optional_number(a.result.lower_trace)},
              {"upper_trace", optional_number(a.result.upper_trace)},
              {"markov_criterion", optional_number(a.result.markov_criterion)},
              {"reason", a.result.reason}};
}

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
  if (id_text.size() > 9) return std::nullopt;
  std::size_t i = id_text[0] == '-' ? 1 : 0;
  if (i == id_text.size()) return std::nullopt;
  for (; i < id_text.size(); ++i)
    if (id_text[i] < '0' || id_text[i] > '9') return std::nullopt;
  return std::make_pair(std::stoi(id_text), name.substr(dot + 1));
}

bool is_link_parameter(const std::string& p) {
  return p == "model" || p == "loss" || p == "p" || p == "r" || p == "loss_good" || p == "loss_bad";
}

}  // namespace

const std::vector<Channel>& channels() {
  static const std::vector<Channel> all = make_channels();
  return all;
}

const Channel* find_channel(std::uint32_t id) {
  for (const auto& c : channels())
    if (static_cast<std::uint32_t>(c.id) == id) return &c;
  return nullptr;
}

json server_info(const std::string& session_id, const Scenario& scenario) {
  return json{{"op", "serverInfo"},
              {"name", "netkf launch"},
              {"capabilities", {"parameters", "parametersSubscribe"}},
              {"metadata", {{"scenario", scenario.name}}},
              {"sessionId", session_id}};
}

json advertise() {
  json list = json::array();
  for (const auto& c : channels())
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

json scenario_message(const Scenario& scenario) {
  json sensors = json::array();
  for (const auto& s : scenario.sensors)
    sensors.push_back({{"id", s.id}, {"measurement_dim", s.C.rows()}, {"link", link_model_json(s.link)}});
  return json{{"name", scenario.name},
              {"period_ms", scenario.period_ms},
              {"state_dim", scenario.state_dim()},
              {"seed", scenario.seed},
              {"sensors", std::move(sensors)}};
}

json estimate_message(const EstimateRecord& e) {
  return json{{"k", e.k},         {"t", e.t},
              {"x_hat", e.xhat},  {"P", e.P},
              {"fused", e.fused}, {"late", e.late},
              {"late_total", e.late_total},  {"rejected_total", e.rejected},
              {"state", e.state}, {"trace_P", number_or_null(e.trace_P)},
              {"trace_P_pred", number_or_null(e.trace_P_pred)}};
}

json truth_message(const TruthRecord& t) { return json{{"k", t.k}, {"t", t.t}, {"x", t.x}}; }

json link_status_message(const LinkView& l) {
  json j = link_model_json(l.model);
  j["sensor_id"] = l.sensor_id;
  j["stationary_loss"] = number_or_null(stationary_loss(l.model));
  j["samples_in"] = l.samples_in;
  j["delivered"] = l.delivered;
  j["dropped"] = l.dropped;
  j["observed_loss"] = number_or_null(l.observed_loss);
  j["mean_burst_length"] = number_or_null(l.mean_burst_length);
  j["samples_total"] = l.samples_total;
  j["delivered_total"] = l.delivered_total;
  j["dropped_total"] = l.dropped_total;
  j["configured_arrival_rate"] = number_or_null(l.configured_arrival_rate);
  j["observed_arrival_rate"] = optional_number(l.observed_arrival_rate);
  j["last_request_id"] = l.last_request_id;
  j["last_request_rejected"] = !l.rejection_reason.empty();
  j["reject_reason"] = l.rejection_reason;
  return j;
}

json theory_message(const TheoryView& t) {
  json region = nullptr;
  if (!t.region.empty()) {
    region = json::array();
    for (const auto& p : t.region)
      region.push_back({{"lambda1", p.lambda1},
                        {"lambda2_lower", number_or_null(p.lambda2_lower)},
                        {"lambda2_upper", optional_number(p.lambda2_upper)}});
  }
  return json{{"k", t.k},
              {"configured", assessment_json(t.configured)},
              {"observed", t.observed ? assessment_json(*t.observed) : json(nullptr)},
              {"region", std::move(region)}};
}

json network_message(const LiveSnapshot& s) {
  json processes = json::array();
  for (const auto& p : s.processes)
    processes.push_back({{"name", p.name}, {"pid", p.pid}, {"running", p.running}, {"restarts", p.restarts}});
  return json{{"k", s.period ? json(s.period->k) : json(nullptr)},
              {"estimates", s.estimates},
              {"rms_error", optional_number(s.rms_error)},
              {"mean_trace_P", number_or_null(s.mean_trace_P)},
              {"mean_trace_P_pred", number_or_null(s.mean_trace_P_pred)},
              {"late_total", s.late_total},
              {"rejected_total", s.rejected_total},
              {"invalid_samples", s.invalid_samples},
              {"processes", std::move(processes)}};
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
  const std::string prefix = "link." + std::to_string(link.sensor_id) + ".";
  list.push_back({{"name", prefix + "model"}, {"value", link_model_name(link.model)}});
  for (const auto& [name, value] : link_parameters(link.model))
    list.push_back({{"name", prefix + name}, {"value", value}, {"type", "float64"}});
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

std::vector<LinkChange> link_changes(const SetParameters& request, const std::vector<LinkView>& links) {
  // Gather each link's requested values; refuse names that are not link parameters.
  std::vector<LinkChange> refused;
  std::map<int, std::map<std::string, json>> by_link;
  for (const auto& [name, value] : request.parameters) {
    const auto parts = split_parameter_name(name);
    if (!parts) {
      refused.push_back({-1, std::nullopt, "unknown parameter '" + name.substr(0, 80) + "' (expected link.ID.NAME)"});
      continue;
    }
    by_link[parts->first][parts->second] = value;
  }
  std::vector<LinkChange> out;
  for (auto& [sensor_id, values] : by_link) {
    LinkChange change{sensor_id, std::nullopt, {}};
    const LinkView* link = nullptr;
    for (const auto& l : links)
      if (l.sensor_id == sensor_id) link = &l;
    auto refuse = [&](std::string why) {
      change.refusal = "link " + std::to_string(sensor_id) + ": " + std::move(why);
      out.push_back(change);
    };
    if (!link) {
      refuse("unknown link (no sensor with that id)");
      continue;
    }
    std::string problem;
    std::string model_name = link_model_name(link->model);
    std::map<std::string, double> numbers;
    for (const auto& [param, value] : values) {
      if (!is_link_parameter(param)) {
        problem = "unknown parameter '" + param.substr(0, 40) + "' (model, loss, p, r, loss_good, loss_bad)";
        break;
      }
      if (param == "model") {
        if (!value.is_string()) {
          problem = "model must be \"bernoulli\" or \"gilbert_elliott\"";
          break;
        }
        model_name = value.get<std::string>();
        if (model_name != "bernoulli" && model_name != "gilbert_elliott") {
          problem = "unknown model '" + model_name.substr(0, 40) + "' (bernoulli or gilbert_elliott)";
          break;
        }
        continue;
      }
      if (!value.is_number()) {
        problem = param + " must be a number";
        break;
      }
      numbers[param] = value.get<double>();
    }
    if (!problem.empty()) {
      refuse(problem);
      continue;
    }
    // Start from the current model's parameters when the model stays; a new model needs
    // its defining parameters (as `netkf ctl set-link` does).
    const bool same_model = model_name == link_model_name(link->model);
    auto value_of = [&](const std::string& name, std::optional<double> fallback) -> std::optional<double> {
      if (auto it = numbers.find(name); it != numbers.end()) return it->second;
      return fallback;
    };
    LinkModel model;
    if (model_name == "bernoulli") {
      const auto* current = std::get_if<BernoulliLink>(&link->model);
      const auto loss = value_of("loss", same_model && current ? std::optional<double>(current->loss) : std::nullopt);
      if (!loss) {
        refuse("switching to bernoulli needs link." + std::to_string(sensor_id) + ".loss");
        continue;
      }
      for (const auto& [name, v] : numbers)
        if (name != "loss") problem = name + " is not a parameter of the bernoulli model";
      model = BernoulliLink{*loss};
    } else {
      const auto* current = std::get_if<GilbertElliottLink>(&link->model);
      const GilbertElliottLink base = same_model && current ? *current : GilbertElliottLink{};
      const auto p = value_of("p", same_model ? std::optional<double>(base.p) : std::nullopt);
      const auto r = value_of("r", same_model ? std::optional<double>(base.r) : std::nullopt);
      if (!p || !r) {
        refuse("switching to gilbert_elliott needs link." + std::to_string(sensor_id) + ".p and .r");
        continue;
      }
      if (numbers.count("loss")) problem = "loss is not a parameter of the gilbert_elliott model (p, r, loss_good, loss_bad)";
      model = GilbertElliottLink{*p, *r, *value_of("loss_good", base.loss_good), *value_of("loss_bad", base.loss_bad)};
    }
    if (!problem.empty()) {
      refuse(problem);
      continue;
    }
    try {
      validate_link_model(model);  // the one validation every path uses (NaN, outside [0, 1])
    } catch (const std::exception& e) {
      refuse(e.what());
      continue;
    }
    change.model = model;
    out.push_back(change);
  }
  out.insert(out.end(), refused.begin(), refused.end());
  return out;
}

}  // namespace netkf::cli::dashboard
