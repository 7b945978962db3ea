// The dashboard's Foxglove WebSocket protocol messages and the link parameters
// (docs/dashboard.md), without sockets.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "netkf/cli/dashboard/dashboard_protocol.hpp"
#include "netkf/cli/live/live_model.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/relay/relay_links.hpp"

namespace netkf::cli::dashboard {
namespace {

using nlohmann::json;

std::vector<LinkView> three_links() {
  LiveModel model(default_scenario());  // links 1, 2 Bernoulli; 3 Gilbert-Elliott
  return model.snapshot().links;
}

SetParameters set(std::vector<std::pair<std::string, json>> params) { return SetParameters{std::move(params), "r1"}; }

TEST(DashboardProtocol, AdvertisesEveryChannelWithAJsonSchema) {
  const json a = advertise();
  EXPECT_EQ(a["op"], "advertise");
  std::vector<std::string> topics;
  for (const auto& c : a["channels"]) {
    topics.push_back(c["topic"]);
    EXPECT_EQ(c["encoding"], "json");
    EXPECT_EQ(c["schemaEncoding"], "jsonschema");
    const json schema = json::parse(c["schema"].get<std::string>());  // the schema is itself JSON text
    EXPECT_EQ(schema["type"], "object");
  }
  EXPECT_EQ(topics, (std::vector<std::string>{"netkf/scenario", "netkf/estimate", "netkf/truth", "netkf/link/status",
                                              "netkf/theory", "netkf/network"}));
  const json info = server_info("s1", default_scenario());
  EXPECT_EQ(info["op"], "serverInfo");
  EXPECT_EQ(info["capabilities"], json({"parameters", "parametersSubscribe"}));
}

// The pages build their model select, rows and texts from this (docs/dashboard.md): every
// model of core with its label and parameter keys in order, and a valid example of each.
TEST(DashboardProtocol, AdvertisesEachLinkModelWithItsLabelAndKeys) {
  const json expected = json::parse(R"([
    {"name": "bernoulli", "label": "Bernoulli", "keys": ["loss"], "example": {"loss": 0.5}},
    {"name": "gilbert_elliott", "label": "Gilbert-Elliott", "keys": ["p", "r", "loss_good", "loss_bad"],
     "example": {"p": 0.1, "r": 0.5, "loss_good": 0.0, "loss_bad": 1.0}}])");
  std::map<std::string, json> schemas;
  const json advertised = advertise();  // held: a range-for over a temporary's member would dangle
  for (const auto& c : advertised["channels"])
    schemas[c["topic"].get<std::string>()] = json::parse(c["schema"].get<std::string>());
  const json& status_model = schemas.at("netkf/link/status")["properties"]["model"];
  EXPECT_EQ(status_model["x-netkf-models"], expected);
  EXPECT_EQ(status_model["enum"], json({"bernoulli", "gilbert_elliott"}));
  const json& scenario_link = schemas.at("netkf/scenario")["properties"]["sensors"]["items"]["properties"]["link"];
  EXPECT_EQ(scenario_link["properties"]["model"]["x-netkf-models"], expected);
  // Each example is a link the server accepts as it is.
  for (const auto& m : expected) {
    LinkKeys keys{{"model", m["name"].get<std::string>()}};
    for (const auto& key : m["keys"]) keys.push_back({key.get<std::string>(), m["example"][key.get<std::string>()].get<double>()});
    EXPECT_NO_THROW((void)link_from_keys(keys)) << m["name"];
  }
}

TEST(DashboardProtocol, MessageDataFrameIsLittleEndianAsTheSpecSays) {
  const std::string f = message_data_frame(0x01020304u, 0x1122334455667788ULL, "{}");
  ASSERT_EQ(f.size(), 1u + 4u + 8u + 2u);
  const unsigned char expected[] = {0x01, 0x04, 0x03, 0x02, 0x01, 0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11, '{', '}'};
  for (std::size_t i = 0; i < f.size(); ++i) EXPECT_EQ(static_cast<unsigned char>(f[i]), expected[i]) << i;
}

TEST(DashboardProtocol, EstimateKeepsTheIdlFieldNamesAndNeverSendsNaN) {
  Estimate e;
  e.k = 5;
  e.t = 0.05;
  e.x_hat = Vector{{1.0, 2.0}};
  e.P = Matrix{{1.0, 0.5}, {0.25, 1.0}};  // asymmetric: the message is row-major
  e.trace_P_pred = 3.0;
  e.fused = {1, 3};
  e.late_total = 4;
  const json j = catalogue::estimate_message(e);
  for (const char* key : {"k", "t", "x_hat", "P", "fused", "late", "late_total", "rejected_total", "state", "trace_P",
                          "trace_P_pred"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["fused"], json({1, 3}));
  EXPECT_EQ(j["P"], json({1.0, 0.5, 0.25, 1.0}));
  EXPECT_EQ(j["trace_P"], 2.0);
  EXPECT_EQ(j["state"], "ok");
  // A link that never delivers has an infinite mean burst: null, not an invalid JSON token.
  LinkView l = three_links()[0];
  l.link = BernoulliLink{1.0};
  l.mean_burst_length = std::numeric_limits<double>::infinity();
  const json s = catalogue::link_status_message(l);
  EXPECT_TRUE(s["mean_burst_length"].is_null());
  EXPECT_EQ(s["loss"], 1.0);
  EXPECT_NE(s.dump().find("\"observed_arrival_rate_since_change\":null"), std::string::npos);
  EXPECT_NE(s.dump().find("\"observed_arrival_rate_window\":null"), std::string::npos);
}

TEST(DashboardProtocol, ParsesTheClientMessagesItSupports) {
  auto sub = std::get<Subscribe>(parse_client_message(R"({"op":"subscribe","subscriptions":[{"id":0,"channelId":2}]})"));
  ASSERT_EQ(sub.subscriptions.size(), 1u);
  EXPECT_EQ(sub.subscriptions[0], (std::pair<std::uint32_t, std::uint32_t>{0, 2}));
  auto unsub = std::get<Unsubscribe>(parse_client_message(R"({"op":"unsubscribe","subscriptionIds":[0,7]})"));
  EXPECT_EQ(unsub.subscription_ids, (std::vector<std::uint32_t>{0, 7}));
  auto get = std::get<GetParameters>(parse_client_message(R"({"op":"getParameters","parameterNames":[],"id":"a"})"));
  EXPECT_TRUE(get.names.empty());
  EXPECT_EQ(get.id, "a");
  auto s = std::get<SetParameters>(
      parse_client_message(R"({"op":"setParameters","parameters":[{"name":"link.2.loss","value":0.5}]})"));
  ASSERT_EQ(s.parameters.size(), 1u);
  EXPECT_FALSE(s.id);
  auto up = std::get<ParameterUpdates>(parse_client_message(R"({"op":"unsubscribeParameterUpdates","parameterNames":["x"]})"));
  EXPECT_FALSE(up.subscribe);
}

TEST(DashboardProtocol, RefusesMalformedMessagesWithTheReason) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"not json", "not valid JSON"},
      {"[1,2]", "JSON object"},
      {R"({"x":1})", "missing field 'op'"},
      {R"({"op":5})", "'op' must be a string"},
      {R"({"op":"advertise","channels":[]})", "unsupported op 'advertise'"},
      {R"({"op":"subscribe"})", "missing field 'subscriptions'"},
      {R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":2}]})", "out of range"},
      {R"({"op":"subscribe","subscriptions":[{"id":1.5,"channelId":2}]})", "must be an integer"},
      {R"({"op":"getParameters","parameterNames":[1]})", "array of strings"},
      {R"({"op":"setParameters","parameters":[{"value":1}]})", "missing field 'name'"},
      {R"({"op":"setParameters","parameters":[],"id":7})", "'id' must be a string"},
  };
  for (const auto& [text, reason] : cases) {
    try {
      parse_client_message(text);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const ProtocolError& e) {
      EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << text << " -> " << e.what();
    }
  }
}

TEST(DashboardProtocol, ParameterValuesAreTheCurrentModelsOfEveryLink) {
  const json all = parameter_values(three_links(), {}, "q");
  EXPECT_EQ(all["id"], "q");
  std::map<std::string, json> values;
  for (const auto& p : all["parameters"]) values[p["name"]] = p["value"];
  const auto ge = std::get<GilbertElliottLink>(default_scenario().sensors[2].link.loss);
  EXPECT_EQ(values["link.1.model"], "bernoulli");
  EXPECT_EQ(values["link.1.loss"], std::get<BernoulliLink>(default_scenario().sensors[0].link.loss).loss);
  EXPECT_EQ(values["link.3.model"], "gilbert_elliott");
  EXPECT_EQ(values["link.3.p"], ge.p);
  EXPECT_EQ(values["link.3.loss_bad"], ge.loss_bad);
  EXPECT_FALSE(values.count("link.1.p"));  // only the current model's parameters
  // A Gilbert-Elliott link also in the user's form: its stationary loss and mean burst.
  EXPECT_DOUBLE_EQ(values["link.3.loss"], ge.p / (ge.p + ge.r) * ge.loss_bad + ge.r / (ge.p + ge.r) * ge.loss_good);
  EXPECT_TRUE(values.count("link.3.mean_burst"));
  EXPECT_EQ(values["link.2.delay_ms"], 0.0);
  EXPECT_EQ(values["link.2.delay_distribution"], "uniform");
  const json some = parameter_values(three_links(), {"link.2.loss", "link.9.loss"}, std::nullopt);
  ASSERT_EQ(some["parameters"].size(), 1u);
  EXPECT_EQ(some["parameters"][0]["name"], "link.2.loss");
  EXPECT_EQ(some["parameters"][0]["type"], "float64");
}

TEST(DashboardProtocol, ALinksParametersBecomeOneChange) {
  auto changes = link_changes(set({{"link.2.loss", 0.97}}), three_links());
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].sensor_id, 2);
  EXPECT_EQ(changes[0].link, LinkSpec(BernoulliLink{0.97}));
  EXPECT_EQ(*changes[0].keys, (LinkKeys{{"loss", 0.97}}));  // only what changes travels
  // Switching model: Gilbert-Elliott needs p and r; loss_good / loss_bad default to 0 / 1.
  changes = link_changes(set({{"link.1.model", "gilbert_elliott"}, {"link.1.p", 0.1}, {"link.1.r", 0.4}}), three_links());
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].link, LinkSpec(GilbertElliottLink{0.1, 0.4, 0.0, 1.0}));
  // Same model: given parameters replace the current ones, the others stay.
  const auto ge = std::get<GilbertElliottLink>(default_scenario().sensors[2].link.loss);
  changes = link_changes(set({{"link.3.loss_good", 0.05}}), three_links());
  ASSERT_TRUE(changes[0].keys);
  EXPECT_EQ(changes[0].link, LinkSpec(GilbertElliottLink{ge.p, ge.r, 0.05, ge.loss_bad}));
  // A delay keeps the loss model; the user's form of Gilbert-Elliott sets p and r.
  changes = link_changes(set({{"link.3.delay_ms", 6.0}, {"link.3.jitter_ms", 4.0}}), three_links());
  ASSERT_TRUE(changes[0].keys) << changes[0].refusal;
  EXPECT_EQ(changes[0].link.loss, LinkModel(ge));
  EXPECT_EQ(changes[0].link.delay.delay_ms, 6.0);
  changes = link_changes(set({{"link.2.model", "gilbert_elliott"}, {"link.2.loss", 0.2}, {"link.2.mean_burst", 5.0}}),
                         three_links());
  ASSERT_TRUE(changes[0].keys) << changes[0].refusal;
  // r = 1/mean_burst, p = r·loss/(1 − loss): 0.2 and 0.05 (to rounding).
  const auto& g = std::get<GilbertElliottLink>(changes[0].link.loss);
  EXPECT_DOUBLE_EQ(g.r, 0.2);
  EXPECT_DOUBLE_EQ(g.p, 0.05);
  EXPECT_EQ(g.loss_good, 0.0);
  EXPECT_EQ(g.loss_bad, 1.0);
  // Two links in one request: two independent changes.
  changes = link_changes(set({{"link.1.loss", 0.3}, {"link.2.loss", 2.0}}), three_links());
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_TRUE(changes[0].keys);
  EXPECT_FALSE(changes[1].keys);
}

TEST(DashboardProtocol, ARelayedTopicsLinkIsNamedByItsLinkIdAndItsRefusalsByItsTopic) {
  std::vector<LinkView> links(1);
  links[0].sensor_id = netkf::relay_topic_link_id("rt/scan");
  links[0].topic = "rt/scan";
  links[0].link = netkf::BernoulliLink{0.2};
  const std::string prefix = "link." + std::to_string(links[0].sensor_id) + ".";
  auto changes = link_changes(set({{prefix + "loss", 0.5}}), links);
  ASSERT_EQ(changes.size(), 1u);
  ASSERT_TRUE(changes[0].keys) << changes[0].refusal;
  EXPECT_EQ(changes[0].sensor_id, links[0].sensor_id);
  EXPECT_EQ(std::get<netkf::BernoulliLink>(changes[0].link.loss).loss, 0.5);
  changes = link_changes(set({{prefix + "loss", 1.5}}), links);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].refusal.find("link rt/scan: loss must be a probability"), std::string::npos) << changes[0].refusal;
  // An id below the int range is no link id.
  changes = link_changes(set({{"link.-9999999999.loss", 0.5}}), links);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].refusal.find("unknown parameter"), std::string::npos) << changes[0].refusal;
  const json values = link_parameter_values(links[0], std::string("r2"));
  EXPECT_EQ(values["parameters"][0]["name"].get<std::string>().rfind(prefix, 0), 0u) << values.dump();
}

TEST(DashboardProtocol, RefusedValuesChangeNothingAndSayWhy) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<std::pair<std::vector<std::pair<std::string, json>>, std::string>> cases = {
      {{{"link.2.loss", 1.5}}, "loss must be a probability"},
      {{{"link.2.loss", -0.1}}, "loss must be a probability"},
      {{{"link.2.loss", json(nan)}}, "loss must be a finite number"},
      {{{"link.2.loss", nullptr}}, "loss must be a number"},  // NaN cannot travel as JSON text: null
      {{{"link.2.loss", "0.5"}}, "loss must be a number"},
      {{{"link.9.loss", 0.5}}, "link 9: unknown link"},
      {{{"link.2.delay", 0.5}}, "unknown link key 'delay'"},
      {{{"link.2.delay_ms", -1.0}}, "delay_ms must be in [0, 60000] ms"},
      {{{"link.2.delay_distribution", "cauchy"}}, "unknown delay_distribution 'cauchy'"},
      {{{"link.3.loss", 0.9}, {"link.3.mean_burst", 2.0}}, "a mean burst of 2 allows a loss of at most 0.666667"},
      {{{"speed", 3}}, "unknown parameter 'speed'"},
      {{{"link.x.loss", 0.1}}, "unknown parameter 'link.x.loss'"},
      {{{"link.2.model", "markov"}}, "unknown link model 'markov'"},
      {{{"link.2.model", "gilbert_elliott"}, {"link.2.p", 0.1}}, "a gilbert_elliott link needs p and r"},
      {{{"link.3.model", "bernoulli"}}, "a bernoulli link needs loss"},
      {{{"link.2.p", 0.1}}, "p is a gilbert_elliott key"},
      {{{"link.3.loss", 0.1}, {"link.3.p", 0.1}}, "not both"},
      {{{"link.3.r", 1.2}}, "r must be a probability"},
      {{{"link.3.p", 0.0}, {"link.3.r", 0.0}}, "p and r cannot both be 0"},
  };
  for (const auto& [params, reason] : cases) {
    const auto changes = link_changes(set(params), three_links());
    ASSERT_EQ(changes.size(), 1u) << reason;
    EXPECT_FALSE(changes[0].keys) << reason;
    EXPECT_NE(changes[0].refusal.find(reason), std::string::npos) << changes[0].refusal;
  }
}

}  // namespace
}  // namespace netkf::cli::dashboard
