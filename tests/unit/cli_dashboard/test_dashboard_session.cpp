// The dashboard without sockets: the HTTP request policy (which path serves what, methods,
// token, Origin, the WebSocket handshake) and one client's Foxglove session state
// (subscriptions, parameter updates, refusals), checked against docs/dashboard.md and the
// Foxglove WebSocket protocol spec (foxglove/ws-protocol, docs/spec.md).
#include <gtest/gtest.h>

#include <array>
#include <cstdint>

#include "foxglove_session.hpp"
#include "netkf/cli/dashboard/request_policy.hpp"
#include "netkf/cli/live/live_model.hpp"
#include "netkf/links/link_keys.hpp"

namespace netkf::cli::dashboard {
namespace {

using nlohmann::json;
using Action = RequestDecision::Action;

// ---------------------------------------------------------------- request policy

const std::array<Asset, 2> kPage{{{"/index.html", "text/html; charset=utf-8", "<html></html>"},
                                   {"/app.js", "text/javascript; charset=utf-8", "run();"}}};

const Asset* find_page_file(std::string_view path) {
  for (const auto& a : kPage)
    if (a.path == path) return &a;
  return nullptr;
}

const std::set<std::string> kOrigins = own_origins("127.0.0.1", false, false, 8470, {"https://app.foxglove.dev"});

RequestPolicy policy(std::string token = "") { return RequestPolicy(std::move(token), kOrigins, find_page_file); }

RequestFacts get(std::string_view target, std::string_view method = "GET") {
  RequestFacts r;
  r.method = method;
  r.target = target;
  return r;
}

RequestFacts handshake(std::string_view origin = "", std::string_view protocols = kSubprotocol,
                       std::string_view target = "/") {
  RequestFacts r = get(target);
  r.websocket_upgrade = true;
  r.origin = origin;
  r.websocket_protocols = protocols;
  r.websocket_key = "dGhlIHNhbXBsZSBub25jZQ==";  // RFC 6455's example: "the sample nonce"
  return r;
}

std::string field(const RequestDecision& d, const std::string& name) {
  for (const auto& [n, v] : d.fields)
    if (n == name) return v;
  return "<absent>";
}

TEST(RequestPolicy, ServesThePageItsAssetsAndMetricsAndNothingElse) {
  const auto page = policy().decide(get("/"));
  EXPECT_EQ(page.action, Action::reply);
  EXPECT_EQ(page.status, 200u);
  EXPECT_EQ(page.body, "<html></html>");
  EXPECT_EQ(field(page, "Content-Type"), "text/html; charset=utf-8");
  EXPECT_EQ(field(page, "X-Frame-Options"), "DENY");  // it has link controls: never framed
  EXPECT_EQ(field(page, "X-Content-Type-Options"), "nosniff");
  EXPECT_EQ(policy().decide(get("/app.js?x=1")).body, "run();");

  const auto metrics = policy().decide(get("/metrics"));
  EXPECT_EQ(metrics.action, Action::metrics);
  EXPECT_EQ(metrics.status, 200u);
  EXPECT_EQ(field(metrics, "Content-Type"), "text/plain; version=0.0.4; charset=utf-8");  // Prometheus text

  for (const char* unknown : {"/nope", "/index.htm", "/../index.html", "/metrics/x"}) {
    const auto d = policy().decide(get(unknown));
    EXPECT_EQ(d.status, 404u) << unknown;
    EXPECT_EQ(d.action, Action::reply) << unknown;
    EXPECT_EQ(field(d, "Content-Type"), "text/plain; charset=utf-8") << unknown;
  }
}

TEST(RequestPolicy, OnlyGetAndHeadAreServed) {
  for (const char* method : {"POST", "PUT", "DELETE", "get"}) {
    const auto d = policy().decide(get("/", method));
    EXPECT_EQ(d.status, 405u) << method;
    EXPECT_EQ(field(d, "Allow"), "GET, HEAD") << method;
  }
  const auto head = policy().decide(get("/", "HEAD"));
  EXPECT_EQ(head.status, 200u);
  EXPECT_TRUE(head.head);                  // the length of the body, not the body
  EXPECT_EQ(head.body, "<html></html>");  // (the length is taken from it)
  EXPECT_FALSE(policy().decide(get("/")).head);
}

TEST(RequestPolicy, KeepsTheConnectionAsTheClientAsked) {
  auto r = get("/");
  EXPECT_TRUE(policy().decide(r).keep_alive);
  r.keep_alive = false;
  EXPECT_FALSE(policy().decide(r).keep_alive);
}

TEST(RequestPolicy, WithATokenEveryRequestMustCarryIt) {
  const auto p = policy("s3cret");
  EXPECT_EQ(p.decide(get("/")).status, 401u);
  EXPECT_EQ(p.decide(get("/metrics?token=wrong")).status, 401u);
  EXPECT_EQ(p.decide(get("/metrics?token=s3cre")).status, 401u);
  EXPECT_EQ(p.decide(get("/?token=s3cret")).status, 200u);
  EXPECT_EQ(p.decide(get("/metrics?a=1&token=s3cret")).action, Action::metrics);
  auto bearer = get("/metrics");
  bearer.authorization = "Bearer s3cret";
  EXPECT_EQ(p.decide(bearer).action, Action::metrics);
  // Before the method: a request without the token learns nothing else.
  EXPECT_EQ(p.decide(get("/", "POST")).status, 401u);
  EXPECT_EQ(p.decide(handshake()).status, 401u);
  EXPECT_EQ(p.decide(handshake("", kSubprotocol, "/?token=s3cret")).action, Action::websocket);
}

TEST(RequestPolicy, AcceptsTheFoxgloveHandshakeAndSelectsItsSubprotocol) {
  // The spec: the client offers subprotocols, the server must select one it speaks.
  for (const char* offered : {"foxglove.websocket.v1", "other.v2, foxglove.websocket.v1", " foxglove.websocket.v1 ,x"}) {
    const auto d = policy().decide(handshake("", offered));
    EXPECT_EQ(d.action, Action::websocket) << offered;
    EXPECT_EQ(field(d, "Sec-WebSocket-Protocol"), "foxglove.websocket.v1") << offered;
  }
  for (const char* offered : {"", "foxglove.websocket.v2", "foxglove.websocket.v1x", "other"}) {
    const auto d = policy().decide(handshake("", offered));
    EXPECT_EQ(d.action, Action::reply) << offered;
    EXPECT_EQ(d.status, 400u) << offered;
    EXPECT_NE(d.body.find("foxglove.websocket.v1"), std::string::npos) << d.body;
    EXPECT_FALSE(d.keep_alive);  // a refused handshake closes the connection
  }
}

TEST(RequestPolicy, TheWebSocketIsOnItsDocumentedPathOnly) {
  EXPECT_EQ(policy().decide(handshake("", kSubprotocol, "/")).action, Action::websocket);
  EXPECT_EQ(policy().decide(handshake("", kSubprotocol, "/?x=1")).action, Action::websocket);
  for (const char* elsewhere : {"/metrics", "/index.html", "/ws", "//", "/app.js?x=/"}) {
    const auto d = policy().decide(handshake("", kSubprotocol, elsewhere));
    EXPECT_EQ(d.action, Action::reply) << elsewhere;
    EXPECT_EQ(d.status, 404u) << elsewhere;
    EXPECT_FALSE(d.keep_alive) << elsewhere;
  }
}

TEST(RequestPolicy, AnInvalidWebSocketKeyIsRefused) {
  // RFC 6455, 4.1: the base64 of 16 random bytes. Python's base64 of b"0123456789abcdef" is the
  // second good one; the bad ones: empty, 15 and 17 bytes, not base64, no padding.
  for (const char* good : {"dGhlIHNhbXBsZSBub25jZQ==", "MDEyMzQ1Njc4OWFiY2RlZg=="}) {
    auto r = handshake();
    r.websocket_key = good;
    EXPECT_EQ(policy().decide(r).action, Action::websocket) << good;
  }
  for (const char* bad : {"", "x", "MDEyMzQ1Njc4OWFiY2Rl", "MDEyMzQ1Njc4OWFiY2RlZmc=", "MDEyMzQ1Njc4OWFiY2RlZg",
                          "MDEyMzQ1Njc4OWFi*2RlZg==", "MDEyMzQ1Njc4OWFiY2RlZg==MDEy", "!!!!!!!!!!!!!!!!!!!!!!=="}) {
    auto r = handshake();
    r.websocket_key = bad;
    const auto d = policy().decide(r);
    EXPECT_EQ(d.status, 400u) << bad;
    EXPECT_NE(d.body.find("Sec-WebSocket-Key"), std::string::npos) << d.body;
  }
}

TEST(RequestPolicy, OnlyTheDashboardsOwnOriginsMayOpenTheWebSocket) {
  for (const char* own : {"http://127.0.0.1:8470", "http://localhost:8470", "http://[::1]:8470",
                          "https://app.foxglove.dev", ""})  // no Origin: a desktop app or a script
    EXPECT_EQ(policy().decide(handshake(own)).action, Action::websocket) << own;
  for (const char* foreign : {"http://evil.example", "http://127.0.0.1:1", "null", "http://localhost:8470/"}) {
    const auto d = policy().decide(handshake(foreign));
    EXPECT_EQ(d.status, 403u) << foreign;
    EXPECT_NE(d.body.find("--dashboard-allow-origin"), std::string::npos) << d.body;
  }
  // Plain GETs carry no Origin rule: the page's own assets are fetched by the browser.
  auto asset = get("/app.js");
  asset.origin = "http://evil.example";
  EXPECT_EQ(policy().decide(asset).status, 200u);
}

TEST(RequestPolicy, OwnOriginsNameTheBoundAddressUnlessAWildcard) {
  const auto v4 = own_origins("192.0.2.7", false, false, 9000, {});
  EXPECT_EQ(v4, (std::set<std::string>{"http://127.0.0.1:9000", "http://localhost:9000", "http://[::1]:9000",
                                       "http://192.0.2.7:9000"}));
  EXPECT_TRUE(own_origins("fd00::7", true, false, 9000, {}).count("http://[fd00::7]:9000"));
  EXPECT_EQ(own_origins("0.0.0.0", false, true, 9000, {}).size(), 3u);
}

TEST(RequestPolicy, AnUnreadableRequestIsAnsweredOnceAndClosed) {
  const auto big = unreadable_request(true, "header limit exceeded");
  EXPECT_EQ(big.status, 413u);
  EXPECT_EQ(big.body, "bad request: header limit exceeded\n");
  EXPECT_FALSE(big.keep_alive);
  EXPECT_EQ(unreadable_request(false, "bad method").status, 400u);
}

// ---------------------------------------------------------------- Foxglove session

constexpr std::uint32_t kEstimate = static_cast<std::uint32_t>(catalogue::ChannelId::estimate);
constexpr std::uint32_t kLinkStatus = static_cast<std::uint32_t>(catalogue::ChannelId::link_status);

std::string subscribe(std::uint32_t id, std::uint32_t channel) {
  return json{{"op", "subscribe"}, {"subscriptions", {{{"id", id}, {"channelId", channel}}}}}.dump();
}

std::uint32_t subscription_of(const std::string& frame) {
  EXPECT_GE(frame.size(), 13u);
  EXPECT_EQ(frame[0], '\x01');  // Message Data
  std::uint32_t id = 0;
  for (int i = 0; i < 4; ++i) id |= static_cast<std::uint32_t>(static_cast<unsigned char>(frame[1 + i])) << (8 * i);
  return id;
}

void expect_error_status(const SessionActions& a, const std::string& reason_part) {
  ASSERT_EQ(a.send.size(), 1u);
  EXPECT_FALSE(a.send[0].binary);
  EXPECT_EQ(a.send[0].message["op"], "status");
  EXPECT_EQ(a.send[0].message["level"], 2);  // error
  EXPECT_NE(a.send[0].message["message"].get<std::string>().find(reason_part), std::string::npos)
      << a.send[0].message["message"];
}

TEST(FoxgloveSession, AChannelMessageGoesToItsSubscriptionsUntilUnsubscribed) {
  FoxgloveSession s;
  const auto a = s.on_text(subscribe(7, kEstimate), {});
  EXPECT_TRUE(a.send.empty());
  EXPECT_EQ(s.subscriptions(), (std::map<std::uint32_t, std::uint32_t>{{7, kEstimate}}));
  auto frames = s.message_frames(kEstimate, 42, R"({"k":1})");
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0], message_data_frame(7, 42, R"({"k":1})"));
  EXPECT_EQ(subscription_of(frames[0]), 7u);
  EXPECT_TRUE(s.message_frames(kLinkStatus, 42, "{}").empty());  // not subscribed

  s.on_text(R"({"op":"unsubscribe","subscriptionIds":[7]})", {});
  EXPECT_TRUE(s.subscriptions().empty());
  EXPECT_TRUE(s.message_frames(kEstimate, 43, "{}").empty());
  EXPECT_EQ(s.refused(), 0u);
  // The spec: after unsubscribing, the client may reuse the id.
  EXPECT_TRUE(s.on_text(subscribe(7, kLinkStatus), {}).send.empty());
  EXPECT_EQ(subscription_of(s.message_frames(kLinkStatus, 44, "{}").at(0)), 7u);
}

TEST(FoxgloveSession, ANewSubscriberGetsTheChannelsLatestMessagesAtOnce) {
  LatchedMessages latched;
  latched[{kLinkStatus, 1}] = {R"({"sensor_id":1})", 10};
  latched[{kLinkStatus, 2}] = {R"({"sensor_id":2})", 11};
  latched[{kEstimate, 0}] = {R"({"k":3})", 12};
  FoxgloveSession s;
  const auto a = s.on_text(subscribe(5, kLinkStatus), latched);
  ASSERT_EQ(a.send.size(), 2u);  // one per link, not the estimate
  EXPECT_TRUE(a.send[0].binary);
  EXPECT_EQ(a.send[0].frame, message_data_frame(5, 10, R"({"sensor_id":1})"));
  EXPECT_EQ(a.send[1].frame, message_data_frame(5, 11, R"({"sensor_id":2})"));
  EXPECT_TRUE(a.send[0].keep && a.send[1].keep);  // the state: not dropped for a slow client
  EXPECT_TRUE(a.send_data_now);
}

TEST(FoxgloveSession, AnUnknownChannelIsRefusedAndCounted) {
  FoxgloveSession s;
  // 99 was never advertised; 7 (delivered) is a recording's channel, not offered here.
  const auto channel = static_cast<std::uint32_t>(catalogue::ChannelId::delivered);
  for (std::uint32_t unknown : {99u, channel}) {
    const auto a = s.on_text(subscribe(1, unknown), {});
    expect_error_status(a, "unknown channel " + std::to_string(unknown));
  }
  EXPECT_TRUE(s.subscriptions().empty());
  EXPECT_EQ(s.refused(), 2u);
  // In one message, the good subscriptions still count.
  const auto a = s.on_text(
      R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":99},{"id":2,"channelId":2}]})", {});
  expect_error_status(a, "unknown channel 99");
  EXPECT_EQ(s.subscriptions(), (std::map<std::uint32_t, std::uint32_t>{{2, kEstimate}}));
  EXPECT_EQ(s.refused(), 3u);
}

TEST(FoxgloveSession, AReusedSubscriptionIdIsIgnoredWithAnErrorStatus) {
  FoxgloveSession s;
  s.on_text(subscribe(3, kEstimate), {});
  // The spec: the server may ignore a subscription that reuses an id, and send an error status.
  const auto a = s.on_text(subscribe(3, kLinkStatus), {});
  expect_error_status(a, "subscription id 3 is already in use");
  EXPECT_EQ(s.subscriptions(), (std::map<std::uint32_t, std::uint32_t>{{3, kEstimate}}));
  EXPECT_EQ(s.refused(), 1u);
  EXPECT_EQ(s.message_frames(kEstimate, 1, "{}").size(), 1u);
  EXPECT_TRUE(s.message_frames(kLinkStatus, 1, "{}").empty());
}

TEST(FoxgloveSession, SetParametersOnALinkBecomesALinkChangeRequest) {
  FoxgloveSession s;
  const auto a = s.on_text(R"({"op":"setParameters","parameters":[{"name":"link.2.loss","value":0.3}],"id":"r7"})", {});
  EXPECT_TRUE(a.send.empty());  // the link-control path answers, once the channel acknowledges
  ASSERT_TRUE(a.set_parameters);
  EXPECT_EQ(a.set_parameters->id, "r7");
  ASSERT_EQ(a.set_parameters->parameters.size(), 1u);
  EXPECT_EQ(a.set_parameters->parameters[0].first, "link.2.loss");
  EXPECT_EQ(a.set_parameters->parameters[0].second, 0.3);
  // ...which the caller turns into the change of link 2.
  LiveModel model(default_scenario());
  const auto changes = link_changes(*a.set_parameters, model.snapshot().links);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].sensor_id, 2);
  ASSERT_TRUE(changes[0].keys) << changes[0].refusal;
  EXPECT_EQ(*changes[0].keys, (LinkKeys{{"loss", 0.3}}));
  EXPECT_EQ(s.refused(), 0u);
}

TEST(FoxgloveSession, GetParametersIsPassedOnWithItsId) {
  FoxgloveSession s;
  const auto a = s.on_text(R"({"op":"getParameters","parameterNames":["link.1.loss"],"id":"q"})", {});
  EXPECT_TRUE(a.send.empty());
  ASSERT_TRUE(a.get_parameters);
  EXPECT_EQ(a.get_parameters->names, (std::vector<std::string>{"link.1.loss"}));
  EXPECT_EQ(a.get_parameters->id, "q");
  EXPECT_FALSE(a.set_parameters);
}

TEST(FoxgloveSession, ParameterUpdatesGoToTheirSubscribersOnly) {
  const json values{{"op", "parameterValues"},
                    {"parameters", {{{"name", "link.1.loss"}, {"value", 0.2}}, {{"name", "link.2.loss"}, {"value", 0.9}}}}};
  FoxgloveSession s;
  EXPECT_FALSE(s.parameter_update(values));
  s.on_text(R"({"op":"subscribeParameterUpdates","parameterNames":["link.2.loss"]})", {});
  auto update = s.parameter_update(values);
  ASSERT_TRUE(update);
  EXPECT_EQ((*update)["op"], "parameterValues");
  ASSERT_EQ((*update)["parameters"].size(), 1u);
  EXPECT_EQ((*update)["parameters"][0]["name"], "link.2.loss");
  EXPECT_FALSE(update->contains("id"));  // the spec: id only answers a get/setParameters
  // The spec: subscribing again appends.
  s.on_text(R"({"op":"subscribeParameterUpdates","parameterNames":["link.1.loss"]})", {});
  EXPECT_EQ((*s.parameter_update(values))["parameters"].size(), 2u);
  s.on_text(R"({"op":"unsubscribeParameterUpdates","parameterNames":["link.1.loss"]})", {});
  EXPECT_EQ((*s.parameter_update(values))["parameters"].size(), 1u);
  // Empty names: all of them, then none.
  s.on_text(R"({"op":"unsubscribeParameterUpdates","parameterNames":[]})", {});
  EXPECT_FALSE(s.parameter_update(values));
  s.on_text(R"({"op":"subscribeParameterUpdates","parameterNames":[]})", {});
  EXPECT_EQ((*s.parameter_update(values))["parameters"].size(), 2u);
  s.on_text(R"({"op":"unsubscribeParameterUpdates"})", {});
  EXPECT_FALSE(s.parameter_update(values));
}

TEST(FoxgloveSession, MalformedMessagesAreRefusedWithTheReasonAndCounted) {
  FoxgloveSession s;
  s.on_text(subscribe(1, kEstimate), {});
  const std::vector<std::pair<std::string, std::string>> bad{
      {"{", "not valid JSON"},
      {"[]", "JSON object"},
      {R"({"subscriptions":[]})", "'op'"},
      {R"({"op":"nope"})", "unsupported op 'nope'"},
      {R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":2}]})", "out of range"},
      {R"({"op":"unsubscribe","subscriptionIds":"1"})", "must be an array"}};
  std::uint64_t count = 0;
  for (const auto& [text, reason] : bad) {
    const auto a = s.on_text(text, {});
    expect_error_status(a, "message refused: ");
    expect_error_status(a, reason);
    EXPECT_FALSE(a.set_parameters || a.get_parameters) << text;
    EXPECT_EQ(s.refused(), ++count) << text;
  }
  // This server offers no clientPublish: a binary message is refused the same way.
  expect_error_status(s.on_binary(), "binary client messages are not supported");
  EXPECT_EQ(s.refused(), count + 1);
  // Nothing else changed: the subscription still delivers.
  EXPECT_EQ(s.message_frames(kEstimate, 1, "{}").size(), 1u);
}

}  // namespace
}  // namespace netkf::cli::dashboard
