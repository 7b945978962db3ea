// The channel catalogue (channel_catalogue.hpp): schemas and messages, one per channel.
#include "netkf/cli/live/channel_catalogue.hpp"

#include <cmath>

#include "netkf/cli/live/observed_rate.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_text.hpp"
#include "netkf/theory/report.hpp"

namespace netkf::cli::catalogue {

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

// Each loss model as the pages show and edit it: its name, its label and its parameter keys
// in order, with the values of one valid link of it (core's one_link_of_each_model), so that a
// model core gains reaches the pages without a change to them (docs/dashboard.md).
json link_models() {
  json models = json::array();
  for (const LinkModel& model : one_link_of_each_model()) {
    json keys = json::array();
    json example = json::object();
    for (const auto& [key, value] : link_parameters(model)) {
      keys.push_back(key);
      example[key] = value;
    }
    models.push_back({{"name", link_model_name(model)},
                      {"label", link_model_label(model)},
                      {"keys", std::move(keys)},
                      {"example", std::move(example)}});
  }
  return models;
}

// Every link key (netkf/links/link_keys.hpp): a link is shown and set by the names of a scenario file.
json link_model_schema() {
  json props = json::object();
  for (const auto& name : link_key_names()) props[name] = {{"type", link_key_is_word(name) ? "string" : "number"}};
  json models = json::array();
  for (const LinkModel& model : one_link_of_each_model()) models.push_back(link_model_name(model));
  props["model"]["enum"] = models;
  // An annotation of netkf's own: JSON Schema readers ignore a keyword they do not know.
  props["model"]["x-netkf-models"] = link_models();
  props["delay_distribution"]["enum"] = {"uniform", "normal", "pareto", "paretonormal"};
  return props;
}

json assessment_schema() {
  return json{{"type", json::array({"object", "null"})},
              {"properties",
               {{"arrival_rates", number_array()},
                {"stable", {{"type", "string"}, {"enum", {"yes", "no", "unknown"}}}},
                {"lower_trace", nullable_number()},
                {"upper_trace", nullable_number()},
                {"upper_method", {{"type", "string"}, {"enum", {"enumerated", "grouped", "sampled"}}}},
                {"upper_standard_error", nullable_number()},
                {"markov_criterion", nullable_number()},
                {"reason", {{"type", "string"}}},
                {"estimator_stable", {{"type", "string"}, {"enum", {"yes", "no", "unknown"}}}},
                {"actuation",
                 {{"type", json::array({"object", "null"})},
                  {"properties",
                   {{"arrival_rate", nullable_number()},
                    {"critical_rate", nullable_number()},
                    {"critical_rate_lower", nullable_number()},
                    {"mss_radius", nullable_number()},
                    {"stable", {{"type", "string"}, {"enum", {"yes", "no", "unknown"}}}},
                    {"reason", {{"type", "string"}}},
                    {"on_loss", {{"type", "string"}, {"enum", {"zero", "hold"}}}},
                    {"acknowledged", {{"type", "boolean"}}},
                    {"cost_lower", nullable_number()},
                    {"cost_upper", nullable_number()}}}}}}}};
}

// The link status message's properties: the link's keys and what the link did.
json link_status_schema_properties(json status_props) {
  for (const char* counter : {"sensor_id", "samples_in", "delivered", "dropped", "samples_total", "delivered_total",
                              "dropped_total", "last_request_id"})
    status_props[counter] = {{"type", "integer"}};
  status_props["held"] = {{"type", "integer"}};
  status_props["past_deadline"] = {{"type", "integer"}};
  status_props["delivered_in_time"] = {{"type", "integer"}};
  status_props["late_total"] = {{"type", "integer"}};
  status_props["late_fraction"] = nullable_number();
  status_props["stationary_loss"] = {{"type", "number"}};
  status_props["in_time"] = {{"type", "number"}};
  status_props["observed_loss"] = {{"type", "number"}};
  status_props["mean_burst_length"] = nullable_number();
  status_props["configured_arrival_rate"] = {{"type", "number"}};
  status_props["observed_arrival_rate_since_change"] = nullable_number();
  status_props["observed_arrival_rate_window"] = nullable_number();
  status_props["observed_window_samples"] = {{"type", "integer"}};
  status_props["last_request_rejected"] = {{"type", "boolean"}};
  status_props["topic"] = {{"type", "string"}};  // only a link of netkf relay: the topic it relays
  status_props["recent_fit"] = {{"type", json::array({"object", "null"})},
                                {"properties",
                                 {{"family", {{"type", "string"}}},
                                  {"samples", {{"type", "integer"}}},
                                  {"dropped", {{"type", "integer"}}},
                                  {"loss", nullable_number()},
                                  {"mean_burst", nullable_number()},
                                  {"link", {{"type", "object"}}},
                                  {"aic_gain", nullable_number()}}}};
  status_props["reject_reason"] = {{"type", "string"}};
  return status_props;
}

Channel scenario_channel(const json& link_props) {
  return Channel{ChannelId::scenario, "netkf/scenario", "netkf.Scenario",
                 schema_object({{"name", {{"type", "string"}}},
                                {"period_ms", {{"type", "number"}}},
                                {"state_dim", {{"type", "integer"}}},
                                {"seed", {{"type", "integer"}}},
                                {"late_policy", {{"type", "string"}}},
                                {"max_delay_periods", {{"type", json::array({"integer", "null"})}}},
                                {"sensors",
                                 {{"type", "array"},
                                  {"items", schema_object({{"id", {{"type", "integer"}}},
                                                           {"measurement_dim", {{"type", "integer"}}},
                                                           {"link", schema_object(link_props, {"model"})}},
                                                          {"id", "link"})}}},
                                {"actuation",
                                 {{"type", json::array({"object", "null"})},
                                  {"properties",
                                   {{"link", schema_object(link_props, {"model"})},
                                    {"on_loss", {{"type", "string"}, {"enum", {"zero", "hold"}}}},
                                    {"acknowledged", {{"type", "boolean"}}}}}}}},
                               {"name", "period_ms", "state_dim", "sensors"})};
}

Channel estimate_channel() {
  return Channel{ChannelId::estimate, "netkf/estimate", "netkf.wire.Estimate",
                 schema_object({{"k", {{"type", "integer"}}},
                                {"revision", {{"type", "integer"}}},
                                {"t", {{"type", "number"}}},
                                {"x_hat", number_array()},
                                {"P", number_array()},
                                {"fused", {{"type", "array"}, {"items", {{"type", "integer"}}}}},
                                {"late", {{"type", "integer"}}},
                                {"late_samples",
                                 {{"type", "array"},
                                  {"items", schema_object({{"k", {{"type", "integer"}}},
                                                           {"sensor_id", {{"type", "integer"}}}},
                                                          {"k", "sensor_id"})}}},
                                {"late_total", {{"type", "integer"}}},
                                {"rejected_total", {{"type", "integer"}}},
                                {"state", {{"type", "string"}, {"enum", {"ok", "diverging"}}}},
                                {"trace_P", {{"type", "number"}}},
                                {"trace_P_pred", {{"type", "number"}}}},
                               {"k", "t", "x_hat", "P", "fused", "state", "trace_P", "trace_P_pred"})};
}

Channel truth_channel() {
  return Channel{ChannelId::truth, "netkf/truth", "netkf.wire.Truth",
                 schema_object({{"k", {{"type", "integer"}}},
                                {"t", {{"type", "number"}}},
                                {"x", number_array()},
                                {"u", number_array()},
                                {"input_arrived", {{"type", "boolean"}}}},
                               {"k", "t", "x"})};
}

Channel theory_channel() {
  return Channel{ChannelId::theory, "netkf/theory", "netkf.Theory",
                 schema_object({{"k", {{"type", "integer"}}},
                                {"configured", assessment_schema()},
                                {"observed", assessment_schema()},
                                {"final_estimate", assessment_schema()},
                                {"observed_rates_from", {{"type", "string"}}},
                                {"region",
                                 {{"type", json::array({"array", "null"})},
                                  {"items", schema_object({{"lambda1", {{"type", "number"}}},
                                                           {"lambda2_lower", nullable_number()},
                                                           {"lambda2_upper", nullable_number()}},
                                                          {"lambda1", "lambda2_lower"})}}}},
                               {"k", "configured"})};
}

Channel network_channel() {
  return Channel{ChannelId::network, "netkf/network", "netkf.Network",
                 schema_object({{"k", {{"type", json::array({"integer", "null"})}}},
                                {"estimates", {{"type", "integer"}}},
                                {"rms_error", nullable_number()},
                                {"mean_trace_P", {{"type", "number"}}},
                                {"mean_trace_P_pred", {{"type", "number"}}},
                                {"late_total", {{"type", "integer"}}},
                                {"rejected_total", {{"type", "integer"}}},
                                {"invalid_samples", {{"type", "integer"}}},
                                {"estimator_restarts", {{"type", "integer"}}},
                                {"restart_gap_periods", {{"type", "integer"}}},
                                {"mean_cost", nullable_number()},
                                {"periods_costed", {{"type", "integer"}}},
                                {"processes",
                                 {{"type", "array"},
                                  {"items", schema_object({{"name", {{"type", "string"}}},
                                                           {"pid", {{"type", "integer"}}},
                                                           {"running", {{"type", "boolean"}}},
                                                           {"restarts", {{"type", "integer"}}},
                                                           {"host", {{"type", "string"}}}},
                                                          {"name"})}}}},
                               {"estimates", "processes"})};
}

std::vector<Channel> make_channels() {
  const json link_props = link_model_schema();
  const json status_props = link_status_schema_properties(link_props);
  return {scenario_channel(link_props),
          estimate_channel(),
          truth_channel(),
          {ChannelId::link_status, "netkf/link/status", "netkf.wire.LinkStatus",
           schema_object(status_props, {"sensor_id", "model", "samples_in", "delivered", "dropped"})},
          theory_channel(),
          network_channel()};
}

// Channels of the recordings only (their topics are the DDS topics of the records).
std::vector<Channel> make_recording_channels() {
  std::vector<Channel> c;
  c.push_back({ChannelId::delivered, "netkf/measurement/delivered", "netkf.wire.Measurement",
               schema_object({{"sensor_id", {{"type", "integer"}}},
                              {"k", {{"type", "integer"}}},
                              {"stamp", {{"type", "number"}}},
                              {"y", number_array()}},
                             {"sensor_id", "k", "stamp", "y"})});
  json change_props = link_model_schema();
  change_props["sensor_id"] = {{"type", "integer"}};
  change_props["at_period"] = {{"type", "integer"}};
  change_props["origin"] = {{"type", "string"}, {"enum", {"request", "timeline"}}};
  change_props["request_id"] = {{"type", "integer"}};
  change_props["topic"] = {{"type", "string"}};  // only a link of netkf relay
  c.push_back({ChannelId::link_change, "netkf/link/change", "netkf.wire.LinkChange",
               schema_object(change_props, {"sensor_id", "at_period", "origin", "model"})});
  // foxglove.Log (docs.foxglove.dev, "Log" message schema): the name Foxglove recognises.
  json level = {{"type", "integer"}, {"enum", {0, 1, 2, 3, 4, 5}}};
  c.push_back({ChannelId::events, "netkf/events", "foxglove.Log",
               schema_object({{"timestamp", schema_object({{"sec", {{"type", "integer"}, {"minimum", 0}}},
                                                           {"nsec", {{"type", "integer"}, {"minimum", 0},
                                                                     {"maximum", 999999999}}}},
                                                          {"sec", "nsec"})},
                              {"level", level},
                              {"message", {{"type", "string"}}},
                              {"name", {{"type", "string"}}},
                              {"file", {{"type", "string"}}},
                              {"line", {{"type", "integer"}, {"minimum", 0}}}},
                             {"timestamp", "level", "message", "name", "file", "line"})});
  return c;
}


// The actuation link's side of a verdict (theory/actuation.hpp); null without one.
json actuation_json(const std::optional<theory::ActuationReport>& a) {
  if (!a) return nullptr;
  return json{{"arrival_rate", number_or_null(a->arrival_rate)},
              {"critical_rate", optional_number(a->critical_rate)},
              {"critical_rate_lower", optional_number(a->critical_rate_lower)},
              {"mss_radius", optional_number(a->mss_radius)},
              {"stable", theory::to_string(a->stable)},
              {"reason", a->stable_reason},
              {"on_loss", to_string(a->on_loss)},
              {"acknowledged", a->acknowledged},
              // Bounds on the long-run mean cost J (LQR weights, acknowledged): the running cost's theory.
              {"cost_lower", optional_number(a->cost_lower)},
              {"cost_upper", optional_number(a->cost_upper)}};
}

json assessment_json(const AssessmentView& a) {
  return json{{"arrival_rates", a.arrival_rates},
              // With an actuation link `stable` is the closed loop's; the estimator's alone here.
              {"estimator_stable", theory::to_string(a.result.estimator_stable)},
              {"actuation", actuation_json(a.result.actuation)},
              {"stable", theory::to_string(a.result.stable)},
              {"lower_trace", optional_number(a.result.lower_trace)},
              {"upper_trace", optional_number(a.result.upper_trace)},
              {"upper_method", theory::to_string(a.result.upper_method)},
              {"upper_standard_error", a.result.upper_method == theory::BoundMethod::sampled && a.result.upper_trace
                                           ? optional_number(a.result.upper_standard_error)
                                           : json(nullptr)},
              {"markov_criterion", optional_number(a.result.markov_criterion)},
              {"reason", a.result.reason}};
}

}  // namespace

// The link by its keys; a model not given by its loss (Gilbert-Elliott) also in the user's
// form (loss, mean_burst).
json link_json(const LinkSpec& link) {
  json j = json::object();
  for (const auto& k : link_keys(link)) {
    if (const auto* word = std::get_if<std::string>(&k.value)) {
      j[k.name] = *word;
    } else {
      j[k.name] = number_or_null(std::get<double>(k.value));
    }
  }
  if (!link_parameters_include_loss(link.loss)) {
    j["loss"] = number_or_null(stationary_loss(link.loss));
    j["mean_burst"] = number_or_null(mean_burst_length(link.loss));
  }
  return j;
}

const std::vector<Channel>& channels() {
  static const std::vector<Channel> all = make_channels();
  return all;
}

const Channel* find_channel(std::uint32_t id) {
  for (const auto& c : channels())
    if (static_cast<std::uint32_t>(c.id) == id) return &c;
  return nullptr;
}

const Channel& channel(ChannelId id) {
  static const std::vector<Channel> recording_only = make_recording_channels();
  if (const Channel* c = find_channel(static_cast<std::uint32_t>(id))) return *c;
  for (const auto& c : recording_only)
    if (c.id == id) return c;
  throw std::logic_error("no channel " + std::to_string(static_cast<std::uint32_t>(id)));
}

json scenario_message(const Scenario& scenario) {
  json sensors = json::array();
  for (const auto& s : scenario.sensors)
    sensors.push_back({{"id", s.id}, {"measurement_dim", s.C.rows()}, {"link", link_json(s.link)}});
  return json{{"name", scenario.name},
              {"period_ms", scenario.period_ms},
              {"state_dim", scenario.state_dim()},
              {"seed", scenario.seed},
              // fuse_within: revised estimates (revision > 0) follow on netkf/estimate for up to D periods.
              {"late_policy", to_string(scenario.estimator.late_policy)},
              {"max_delay_periods", scenario.estimator.late_policy == LatePolicy::fuse_within
                                        ? json(scenario.estimator.fusable_delay_periods())
                                        : json(nullptr)},
              {"sensors", std::move(sensors)},
              // plant.control.link: the link the estimator's inputs take to the plant (link "control").
              {"actuation", scenario.actuation_link()
                                ? json{{"link", link_json(*scenario.actuation_link())},
                                       {"on_loss", to_string(scenario.plant.control->on_loss)},
                                       {"acknowledged", scenario.plant.control->acknowledged}}
                                : json(nullptr)}};
}

json estimate_message(const Estimate& e) {
  std::vector<double> P;  // row-major, as on the wire
  P.reserve(static_cast<std::size_t>(e.P.size()));
  for (Eigen::Index r = 0; r < e.P.rows(); ++r)
    for (Eigen::Index c = 0; c < e.P.cols(); ++c) P.push_back(e.P(r, c));
  json late_samples = json::array();  // each late sample counted here, with the period it was for
  for (std::size_t i = 0; i < e.late_sensors.size() && i < e.late_periods.size(); ++i)
    late_samples.push_back({{"k", e.late_periods[i]}, {"sensor_id", e.late_sensors[i]}});
  return json{{"k", e.k},
              {"revision", e.revision},
              {"t", e.t},
              {"x_hat", std::vector<double>(e.x_hat.begin(), e.x_hat.end())},
              {"P", std::move(P)},
              {"fused", e.fused},
              {"late", e.late},
              {"late_samples", late_samples},
              {"late_total", e.late_total},
              {"rejected_total", e.rejected_total},
              {"state", to_string(e.state)},
              {"trace_P", number_or_null(e.trace_P())},
              {"trace_P_pred", number_or_null(e.trace_P_pred)}};
}

json truth_message(const Truth& t) {
  json j{{"k", t.k}, {"t", t.t}, {"x", t.x}};
  if (!t.u.empty()) {
    j["u"] = t.u;  // closed loop: the input u_{k-1} the plant applied to produce x_k
    j["input_arrived"] = t.input_arrived;  // ν_{k-1}: it reached the plant in time
  }
  return j;
}

json link_status_json(const LinkStatus& l) {
  json j = link_json(l.link);
  j["sensor_id"] = l.sensor_id;
  j["stationary_loss"] = number_or_null(stationary_loss(l.link.loss));
  j["in_time"] = number_or_null(l.in_time);
  j["configured_arrival_rate"] = number_or_null(l.arrival_rate());
  j["held"] = l.held;
  j["past_deadline"] = l.past_deadline;
  j["samples_in"] = l.samples_in;
  j["delivered"] = l.delivered;
  j["delivered_in_time"] = delivered_in_time(l);
  j["dropped"] = l.dropped;
  j["observed_arrival_rate_since_change"] = optional_number(observed_rate_since_change(l));
  j["observed_loss"] = number_or_null(l.observed_loss);
  j["mean_burst_length"] = number_or_null(l.mean_burst_length);
  j["samples_total"] = l.samples_total;
  j["delivered_total"] = l.delivered_total;
  j["dropped_total"] = l.dropped_total;
  j["last_request_id"] = l.last_request_id;
  j["last_request_rejected"] = !l.rejection_reason.empty();
  j["reject_reason"] = l.rejection_reason;
  j["recent_fit"] = l.recent_fit ? recent_fit_json(*l.recent_fit) : json(nullptr);
  if (!l.topic.empty()) j["topic"] = l.topic;  // a link of netkf relay
  return j;
}

// A fitted loss model's keys: a link's without the delay (a fit knows only drops).
json fitted_link_json(const LinkModel& model) {
  json j = link_json(LinkSpec(model));
  for (const char* delay_key : {"delay_ms", "jitter_ms", "delay_distribution"}) j.erase(delay_key);
  return j;
}

json recent_fit_json(const fit::RecentLossFit& f) {
  return json{{"family", fit::to_string(f.family)},
              {"samples", f.samples},
              {"dropped", f.dropped},
              {"loss", number_or_null(f.loss())},
              {"mean_burst", number_or_null(f.mean_burst())},
              {"link", fitted_link_json(f.link)},
              {"aic_gain", optional_number(f.aic_gain)}};
}

json link_status_message(const LinkView& l) {
  json j = link_status_json(l);
  j["late_total"] = l.late_total;
  j["late_fraction"] = l.delivered_total > 0 ? json(static_cast<double>(l.late_total) / static_cast<double>(l.delivered_total))
                                             : json(nullptr);
  // The window needs the reports before this one: the live model's, not one report's.
  j["observed_arrival_rate_window"] = optional_number(l.observed_rate_window);
  j["observed_window_samples"] = l.observed_window_samples;
  return j;
}

json delivered_message(const DeliveredMeasurement& d) {
  json y = json::array();
  for (double v : d.y) y.push_back(number_or_null(v));
  return json{{"sensor_id", d.sensor_id}, {"k", d.k}, {"stamp", number_or_null(d.stamp)}, {"y", std::move(y)}};
}

json link_change_message(const LinkChange& c) {
  json j = link_json(c.link);
  j["sensor_id"] = c.sensor_id;
  j["at_period"] = c.at_period;
  j["origin"] = to_string(c.origin);
  j["request_id"] = c.request_id;
  if (!c.topic.empty()) j["topic"] = c.topic;
  return j;
}

json log_message(const LiveEvent& event, std::uint64_t time_ns) {
  int level = 2;  // foxglove.LogLevel: INFO 2, WARNING 3, ERROR 4
  if (event.level == LiveEvent::Level::warning) level = 3;
  if (event.level == LiveEvent::Level::error) level = 4;
  return json{{"timestamp", {{"sec", time_ns / 1000000000ULL}, {"nsec", time_ns % 1000000000ULL}}},
              {"level", level},
              {"message", event.text},
              {"name", "netkf"},
              {"file", ""},
              {"line", 0}};
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
              // late_policy fuse_within: the final estimates' verdict and bounds (null with drop).
              {"final_estimate", t.final_estimate ? assessment_json(*t.final_estimate) : json(nullptr)},
              // The theory's observed operating point: which link-status rate it assesses.
              {"observed_rates_from", "observed_arrival_rate_since_change"},
              {"region", std::move(region)}};
}

json network_message(const LiveSnapshot& s) {
  json processes = json::array();
  for (const auto& p : s.processes)
    processes.push_back(
        {{"name", p.name}, {"pid", p.pid}, {"running", p.running}, {"restarts", p.restarts}, {"host", p.host}});
  return json{{"k", s.period ? json(s.period->estimate.k) : json(nullptr)},
              {"estimates", s.estimates},
              {"rms_error", optional_number(s.rms_error)},
              {"mean_trace_P", number_or_null(s.mean_trace_P)},
              {"mean_trace_P_pred", number_or_null(s.mean_trace_P_pred)},
              {"late_total", s.late_total},
              {"rejected_total", s.rejected_total},
              {"invalid_samples", s.invalid_samples},
              {"estimator_restarts", s.estimator_restarts},
              {"restart_gap_periods", s.restart_gap_periods},
              {"mean_cost", optional_number(s.mean_cost)},
              {"periods_costed", s.periods_costed},
              {"processes", std::move(processes)}};
}

}  // namespace netkf::cli::catalogue
