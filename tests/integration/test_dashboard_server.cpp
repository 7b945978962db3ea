// The dashboard's HTTP + WebSocket server over real sockets on 127.0.0.1 (inside the test's
// network namespace): the page and /metrics, the Foxglove handshake, subscriptions, the
// safety rules (Origin, token, message size) and malformed client messages.
#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <gtest/gtest.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <future>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "netkf/cli/dashboard/dashboard_server.hpp"

namespace netkf::cli {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;

/// A server on its own io thread, as in the launch.
class ServerFixture {
 public:
  explicit ServerFixture(DashboardOptions options = {}) : work_(net::make_work_guard(io_)) {
    options.port = 0;
    DashboardServer::Hooks hooks;
    hooks.metrics = [] { return std::string("# TYPE test_metric gauge\ntest_metric 1\n"); };
    hooks.get_parameters = [](const dashboard::GetParameters& g) {
      return json{{"op", "parameterValues"}, {"parameters", json::array({{{"name", "link.2.loss"}, {"value", 0.1}}})},
                  {"id", g.id.value_or("")}};
    };
    hooks.set_parameters = [this](DashboardServer::ClientId, const dashboard::SetParameters& s) {
      last_set_ = s;
      set_promise_.set_value();
    };
    hooks.refused = [this](const std::string& what) { refused_.push_back(what); };
    server_ = std::make_unique<DashboardServer>(io_, options, dashboard::server_info("t", default_scenario()), hooks);
    thread_ = std::thread([this] { io_.run(); });
  }
  ~ServerFixture() {
    run([this] { server_->stop(); });
    work_.reset();
    io_.stop();
    thread_.join();
  }
  unsigned short port() const { return server_->port(); }
  void run(std::function<void()> f) {
    std::promise<void> done;
    net::post(io_, [&] {
      f();
      done.set_value();
    });
    done.get_future().wait();
  }
  DashboardServer& server() { return *server_; }
  DashboardStats stats() {
    DashboardStats st;
    run([&] { st = server_->stats(); });
    return st;
  }
  /// What the server reported refused, so far (read on its thread).
  std::vector<std::string> refused() {
    std::vector<std::string> r;
    run([&] { r = refused_; });
    return r;
  }
  std::future<void> set_called() { return set_promise_.get_future(); }
  dashboard::SetParameters last_set_;

 private:
  net::io_context io_;
  net::executor_work_guard<net::io_context::executor_type> work_;
  std::unique_ptr<DashboardServer> server_;
  std::thread thread_;
  std::promise<void> set_promise_;
  std::vector<std::string> refused_;
};

/// A plain TCP connection (POSIX socket) to the server, reads bounded by 20 s.
class RawConnection {
 public:
  explicit RawConnection(unsigned short port) : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    timeval t{20, 0};
    setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &t, sizeof t);
  }
  ~RawConnection() { ::close(fd_); }
  RawConnection(const RawConnection&) = delete;
  bool send(const std::string& data) { return ::send(fd_, data.data(), data.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(data.size()); }
  /// Everything the server sends until it closes (true) or 20 s pass (false).
  bool read_until_closed(std::string* got = nullptr) {
    char buf[4096];
    for (;;) {
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n == 0 || (n < 0 && errno == ECONNRESET)) return true;
      if (n < 0) return false;  // the timeout
      if (got) got->append(buf, static_cast<std::size_t>(n));
    }
  }

 private:
  int fd_;
};

http::response<http::string_body> get(unsigned short port, const std::string& target,
                                      http::verb verb = http::verb::get) {
  net::io_context io;
  beast::tcp_stream stream(io);
  stream.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
  http::request<http::string_body> req{verb, target, 11};
  req.set(http::field::host, "127.0.0.1");
  http::write(stream, req);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(16 * 1024 * 1024);
  http::read(stream, buffer, parser);
  return parser.release();
}

/// A synchronous Foxglove client.
struct Client {
  net::io_context io;
  websocket::stream<tcp::socket> ws{io};
  beast::flat_buffer buffer;

  /// Throws beast::system_error when the handshake is refused (the HTTP status in `refusal`).
  Client(unsigned short port, const std::string& origin = "", const std::string& target = "/",
         const std::string& subprotocol = dashboard::kSubprotocol) {
    ws.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
    ws.set_option(websocket::stream_base::decorator([&](websocket::request_type& req) {
      if (!subprotocol.empty()) req.set(http::field::sec_websocket_protocol, subprotocol);
      if (!origin.empty()) req.set(http::field::origin, origin);
    }));
    websocket::response_type res;
    try {
      ws.handshake(res, "127.0.0.1:" + std::to_string(port), target);
    } catch (...) {
      refusal = res.result_int();
      throw;
    }
    accepted_subprotocol = std::string(res[http::field::sec_websocket_protocol]);
  }
  std::string read() {
    buffer.consume(buffer.size());
    ws.read(buffer);
    return beast::buffers_to_string(buffer.data());
  }
  json read_json() {
    const auto text = read();
    EXPECT_TRUE(ws.got_text());
    return json::parse(text);
  }
  void send(const std::string& text) {
    ws.text(true);
    ws.write(net::buffer(text));
  }
  unsigned refusal = 0;
  std::string accepted_subprotocol;
};

TEST(DashboardServer, ServesThePageItsAssetsAndMetrics) {
  ServerFixture f;
  auto page = get(f.port(), "/");
  EXPECT_EQ(page.result(), http::status::ok);
  EXPECT_NE(page.body().find("<html"), std::string::npos);
  EXPECT_EQ(page[http::field::content_type], "text/html; charset=utf-8");
  EXPECT_EQ(page["X-Frame-Options"], "DENY");
  auto uplot = get(f.port(), "/uPlot.iife.min.js");
  EXPECT_EQ(uplot.result(), http::status::ok);
  EXPECT_NE(uplot.body().find("uPlot"), std::string::npos);
  EXPECT_EQ(get(f.port(), "/app.js").result(), http::status::ok);
  EXPECT_EQ(get(f.port(), "/../etc/passwd").result(), http::status::not_found);
  EXPECT_EQ(get(f.port(), "/", http::verb::post).result(), http::status::method_not_allowed);
  auto metrics = get(f.port(), "/metrics");
  EXPECT_EQ(metrics.body(), "# TYPE test_metric gauge\ntest_metric 1\n");
  EXPECT_EQ(metrics[http::field::content_type], "text/plain; version=0.0.4; charset=utf-8");
}

TEST(DashboardServer, EachPageServesItsOwnFilesOnly) {
  // The launch's dashboard does not serve the relay's page; the relay's serves relay.html at /
  // and none of the launch's own files (uPlot, the style and the link models' reader are shared); --dashboard without a page serves only /metrics.
  ServerFixture launch;
  EXPECT_EQ(get(launch.port(), "/relay.html").result(), http::status::not_found);
  EXPECT_EQ(get(launch.port(), "/relay.js").result(), http::status::not_found);
  DashboardOptions relay_options;
  relay_options.page = DashboardPage::relay;
  ServerFixture relay(relay_options);
  auto page = get(relay.port(), "/");
  EXPECT_EQ(page.result(), http::status::ok);
  EXPECT_NE(page.body().find("/relay.js"), std::string::npos);
  EXPECT_EQ(page.body().find("/app.js"), std::string::npos);
  EXPECT_EQ(get(relay.port(), "/relay.js").result(), http::status::ok);
  EXPECT_EQ(get(relay.port(), "/style.css").result(), http::status::ok);
  // The relay's page plots with the same uPlot and reads the link models as the launch's does.
  EXPECT_EQ(get(relay.port(), "/link_models.js").result(), http::status::ok);
  EXPECT_EQ(get(launch.port(), "/link_models.js").result(), http::status::ok);
  EXPECT_EQ(get(relay.port(), "/uPlot.iife.min.js").result(), http::status::ok);
  EXPECT_EQ(get(relay.port(), "/uPlot.min.css").result(), http::status::ok);
  for (const char* path : {"/index.html", "/app.js"}) {
    auto res = get(relay.port(), path);
    if (std::string(path) == "/index.html") {
      EXPECT_EQ(res.body(), page.body()) << "the policy's name for GET /";
    } else {
      EXPECT_EQ(res.result(), http::status::not_found) << path;
    }
  }
  DashboardOptions none_options;
  none_options.page = DashboardPage::none;
  ServerFixture none(none_options);
  EXPECT_EQ(get(none.port(), "/").result(), http::status::not_found);
  EXPECT_EQ(get(none.port(), "/metrics").result(), http::status::ok);
}

TEST(DashboardServer, SpeaksFoxgloveAndStreamsSubscribedChannels) {
  ServerFixture f;
  Client c(f.port());  // no Origin: a desktop app or a script
  EXPECT_EQ(c.accepted_subprotocol, dashboard::kSubprotocol);
  EXPECT_EQ(c.read_json()["op"], "serverInfo");
  const json adv = c.read_json();
  EXPECT_EQ(adv["op"], "advertise");
  EXPECT_EQ(adv["channels"].size(), catalogue::channels().size());
  // A value published before the subscription is sent at once (latched) ...
  f.run([&] { f.server().publish(catalogue::ChannelId::theory, json{{"k", 1}}, 5); });
  c.send(R"({"op":"subscribe","subscriptions":[{"id":7,"channelId":2},{"id":8,"channelId":5}]})");
  std::string frame = c.read();
  ASSERT_FALSE(c.ws.got_text());
  ASSERT_EQ(frame.substr(13), R"({"k":1})");
  EXPECT_EQ(frame[1], 8);  // subscription id 8, little-endian
  // ... and later ones in the next batch.
  f.run([&] { f.server().publish(catalogue::ChannelId::estimate, json{{"k", 42}}, 123456789); });
  frame = c.read();
  ASSERT_EQ(frame.size(), 13u + std::string(R"({"k":42})").size());
  EXPECT_EQ(static_cast<unsigned char>(frame[0]), 0x01);
  EXPECT_EQ(frame[1], 7);
  std::uint64_t ts = 0;
  for (int i = 0; i < 8; ++i) ts |= static_cast<std::uint64_t>(static_cast<unsigned char>(frame[5 + i])) << (8 * i);
  EXPECT_EQ(ts, 123456789u);
  EXPECT_EQ(json::parse(frame.substr(13))["k"], 42);
  // Status messages reach every client.
  f.run([&] { f.server().broadcast_status(LiveEvent::Level::warning, "careful"); });
  const json st = c.read_json();
  EXPECT_EQ(st["op"], "status");
  EXPECT_EQ(st["level"], 1);
  EXPECT_EQ(st["message"], "careful");
}

TEST(DashboardServer, ASubscriptionsLatchedStateIsNeverDroppedForASlowClient) {
  // More latched link statuses than a client's queue holds (a page of a 4096-link run): the
  // queue dropped its oldest data frames first, and that page never got the scenario.
  DashboardOptions options;
  options.max_queued_frames = 8;
  ServerFixture f(options);
  Client c(f.port());
  c.read_json();  // serverInfo
  c.read_json();  // advertise
  constexpr int kLinks = 40;
  f.run([&] {
    f.server().publish(catalogue::ChannelId::scenario, json{{"name", "many"}}, 1);
    for (int id = 1; id <= kLinks; ++id)
      f.server().publish(catalogue::ChannelId::link_status, json{{"sensor_id", id}}, 2, id);
    // The latched estimate, subscribed last, comes last and ends the reading below (a frame
    // published after the subscription could be dropped behind the kept state: not a sentinel).
    f.server().publish(catalogue::ChannelId::estimate, json{{"k", 1}}, 3);
  });
  c.send(R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":1},{"id":2,"channelId":4},{"id":3,"channelId":2}]})");
  bool scenario = false;
  std::set<int> links;
  for (;;) {
    const std::string frame = c.read();
    ASSERT_FALSE(c.ws.got_text());
    const json payload = json::parse(frame.substr(13));
    if (frame[1] == 3) break;
    if (frame[1] == 1) scenario = payload["name"] == "many";
    else links.insert(payload["sensor_id"].get<int>());
  }
  EXPECT_TRUE(scenario);
  EXPECT_EQ(links.size(), static_cast<std::size_t>(kLinks));
  std::uint64_t dropped = 1;
  f.run([&] { dropped = f.server().dropped_frames(); });
  EXPECT_EQ(dropped, 0u);
}

TEST(DashboardServer, AnswersParametersAndPassesChangesOn) {
  ServerFixture f;
  Client c(f.port());
  c.read_json();
  c.read_json();
  c.send(R"({"op":"getParameters","parameterNames":[],"id":"g1"})");
  const json values = c.read_json();
  EXPECT_EQ(values["op"], "parameterValues");
  EXPECT_EQ(values["id"], "g1");
  auto called = f.set_called();
  c.send(R"({"op":"setParameters","parameters":[{"name":"link.2.loss","value":1.0}],"id":"s1"})");
  ASSERT_EQ(called.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  EXPECT_EQ(f.last_set_.id, "s1");
  ASSERT_EQ(f.last_set_.parameters.size(), 1u);
  EXPECT_EQ(f.last_set_.parameters[0].first, "link.2.loss");
  // Updates go to subscribed clients only, filtered by name.
  c.send(R"({"op":"subscribeParameterUpdates","parameterNames":["link.2.loss"]})");
  c.send(R"({"op":"getParameters","parameterNames":[],"id":"sync"})");  // ordered after the subscription
  EXPECT_EQ(c.read_json()["id"], "sync");
  f.run([&] {
    f.server().broadcast_parameter_values(json{{"op", "parameterValues"},
                                               {"parameters", {{{"name", "link.1.loss"}, {"value", 0.2}},
                                                               {{"name", "link.2.loss"}, {"value", 0.9}}}}});
  });
  const json update = c.read_json();
  ASSERT_EQ(update["parameters"].size(), 1u);
  EXPECT_EQ(update["parameters"][0]["name"], "link.2.loss");
}

TEST(DashboardServer, MalformedMessagesGetAnErrorStatusAndTheConnectionLives) {
  ServerFixture f;
  Client c(f.port());
  c.read_json();
  c.read_json();
  for (const std::string bad : {"{", "[]", R"({"op":"nope"})", R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":99}]})"}) {
    c.send(bad);
    const json st = c.read_json();
    EXPECT_EQ(st["op"], "status") << bad;
    EXPECT_EQ(st["level"], 2) << bad;
  }
  c.ws.binary(true);
  c.ws.write(net::buffer(std::string("\x02\x00", 2)));
  EXPECT_EQ(c.read_json()["level"], 2);
  c.send(R"({"op":"getParameters","parameterNames":[],"id":"still-here"})");
  EXPECT_EQ(c.read_json()["id"], "still-here");
}

TEST(DashboardServer, AMessageOverTheLimitClosesTheConnection) {
  ServerFixture f;
  Client c(f.port());
  c.read_json();
  c.read_json();
  beast::error_code ec;
  c.ws.text(true);
  c.ws.write(net::buffer(std::string(70 * 1024, ' ')), ec);  // may already fail: the server closes mid-message
  // Else read until the close: on a loaded machine the server may send many updates first.
  for (int i = 0; i < 1000 && !ec; ++i) {
    c.ws.read(c.buffer, ec);
    c.buffer.consume(c.buffer.size());
  }
  // However the close reaches the client: a close frame, EOF, a reset, or (seen under ASan) the
  // socket already shut down when its write or read ran.
  EXPECT_TRUE(ec == websocket::error::closed || ec == net::error::eof || ec == net::error::connection_reset ||
              ec == net::error::broken_pipe || ec == net::error::not_connected)
      << ec.message();
  // The server is still there for others.
  Client other(f.port());
  EXPECT_EQ(other.read_json()["op"], "serverInfo");
}

TEST(DashboardServer, RefusesForeignOriginsAndClientsWithoutTheSubprotocol) {
  DashboardOptions o;
  o.allowed_origins = {"https://app.foxglove.dev"};
  ServerFixture f(o);
  const std::string own = "http://127.0.0.1:" + std::to_string(f.port());
  EXPECT_NO_THROW(Client(f.port(), own));
  EXPECT_NO_THROW(Client(f.port(), "http://localhost:" + std::to_string(f.port())));
  EXPECT_NO_THROW(Client(f.port(), "https://app.foxglove.dev"));
  for (const std::string foreign : {"http://evil.example", "http://127.0.0.1:1", "null"}) {
    try {
      Client c(f.port(), foreign);
      ADD_FAILURE() << "accepted origin " << foreign;
    } catch (const beast::system_error&) {
    }
  }
  // The refusal is a 403 with the reason (seen by a raw request).
  net::io_context io;
  beast::tcp_stream stream(io);
  stream.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), f.port()));
  http::request<http::string_body> req{http::verb::get, "/", 11};
  req.set(http::field::host, "127.0.0.1");
  req.set(http::field::upgrade, "websocket");
  req.set(http::field::connection, "Upgrade");
  req.set(http::field::sec_websocket_key, "dGhlIHNhbXBsZSBub25jZQ==");
  req.set(http::field::sec_websocket_version, "13");
  req.set(http::field::sec_websocket_protocol, dashboard::kSubprotocol);
  req.set(http::field::origin, "http://evil.example");
  http::write(stream, req);
  beast::flat_buffer buffer;
  http::response<http::string_body> res;
  http::read(stream, buffer, res);
  EXPECT_EQ(res.result(), http::status::forbidden);
  EXPECT_NE(res.body().find("--dashboard-allow-origin"), std::string::npos);
  EXPECT_THROW(Client(f.port(), "", "/", ""), beast::system_error);  // no subprotocol offered
}

TEST(DashboardServer, WithATokenEveryRequestMustCarryIt) {
  DashboardOptions o;
  o.token = "s3cret";
  ServerFixture f(o);
  EXPECT_EQ(get(f.port(), "/").result(), http::status::unauthorized);
  EXPECT_EQ(get(f.port(), "/metrics?token=wrong").result(), http::status::unauthorized);
  EXPECT_EQ(get(f.port(), "/?token=s3cret").result(), http::status::ok);
  EXPECT_EQ(get(f.port(), "/metrics?token=s3cret").result(), http::status::ok);
  EXPECT_THROW(Client(f.port()), beast::system_error);
  Client c(f.port(), "", "/?token=s3cret");
  EXPECT_EQ(c.read_json()["op"], "serverInfo");
  EXPECT_NE(f.server().url().find("?token=s3cret"), std::string::npos);
}

// The page's ES modules: the entry app.js imports the others by relative name, which the browser
// requests without the page's token; index.html's import map adds it, so it must list every
// module the entry reaches, and each is served (as JavaScript) only with the token.
TEST(DashboardServer, ThePageListsEveryModuleItImportsAndEachNeedsTheToken) {
  DashboardOptions o;
  o.token = "s3cret";
  ServerFixture f(o);
  const std::string page = get(f.port(), "/?token=s3cret").body();
  const auto begin = page.find("var modules = [");
  const auto end = page.find("];", begin);
  ASSERT_NE(begin, std::string::npos);
  ASSERT_NE(end, std::string::npos);
  std::set<std::string> listed;
  const std::regex quoted(R"('(/[a-z_]+\.js)')");
  const std::string list = page.substr(begin, end - begin);
  for (std::sregex_iterator it(list.begin(), list.end(), quoted), last; it != last; ++it) listed.insert((*it)[1]);
  ASSERT_TRUE(listed.count("/app.js"));
  // Every module reachable from the entry, by its `from './NAME.js'` (or `import './NAME.js'`) imports.
  const std::regex imported(R"((?:from|import) ['"]\.(/[a-z_]+\.js)['"])");
  std::set<std::string> reached{"/app.js"};
  std::vector<std::string> todo{"/app.js"};
  while (!todo.empty()) {
    const std::string path = todo.back();
    todo.pop_back();
    auto res = get(f.port(), path + "?token=s3cret");
    EXPECT_EQ(res.result(), http::status::ok) << path;
    EXPECT_EQ(res[http::field::content_type], "text/javascript; charset=utf-8") << path;
    EXPECT_EQ(get(f.port(), path).result(), http::status::unauthorized) << path;
    const std::string body = res.body();
    for (std::sregex_iterator it(body.begin(), body.end(), imported), last; it != last; ++it) {
      if (reached.insert((*it)[1]).second) todo.push_back((*it)[1]);
    }
  }
  EXPECT_GT(reached.size(), 1u) << "app.js imports the page's other modules";
  EXPECT_EQ(listed, reached) << "index.html's import map lists exactly the modules app.js reaches";
  // The relay's page serves none of them but what relay.js imports, which its page's import map
  // lists (with the token) likewise.
  DashboardOptions relay_options;
  relay_options.page = DashboardPage::relay;
  relay_options.token = "s3cret";
  ServerFixture relay(relay_options);
  const std::string relay_page = get(relay.port(), "/?token=s3cret").body();
  const std::string relay_js = get(relay.port(), "/relay.js?token=s3cret").body();
  std::set<std::string> relay_imports;
  for (std::sregex_iterator it(relay_js.begin(), relay_js.end(), imported), last; it != last; ++it)
    relay_imports.insert((*it)[1]);
  std::set<std::string> relay_listed;
  const std::regex mapped(R"('(/[a-z_]+\.js)': ')");
  for (std::sregex_iterator it(relay_page.begin(), relay_page.end(), mapped), last; it != last; ++it)
    relay_listed.insert((*it)[1]);
  EXPECT_FALSE(relay_imports.empty());
  EXPECT_EQ(relay_listed, relay_imports) << "relay.html's import map lists exactly the modules relay.js imports";
  for (const auto& path : reached) {
    const auto want = relay_imports.count(path) ? http::status::ok : http::status::not_found;
    EXPECT_EQ(get(relay.port(), path + "?token=s3cret").result(), want) << path;
  }
}

TEST(DashboardServer, AtTheCapANewConnectionIsRefusedWhenNoneIsIdle) {
  DashboardOptions o;
  o.max_connections = 3;
  ServerFixture f(o);
  std::vector<std::unique_ptr<Client>> clients;
  for (int i = 0; i < 3; ++i) {
    clients.push_back(std::make_unique<Client>(f.port()));
    EXPECT_EQ(clients.back()->read_json()["op"], "serverInfo");
  }
  RawConnection fourth(f.port());
  std::string said;
  EXPECT_TRUE(fourth.read_until_closed(&said));
  EXPECT_EQ(said.rfind("HTTP/1.1 503 Service Unavailable\r\n", 0), 0u) << said;
  const auto st = f.stats();
  EXPECT_EQ(st.connections, 3u);
  EXPECT_EQ(st.max_connections, 3u);
  EXPECT_EQ(st.refused_connections, 1u);
  ASSERT_FALSE(f.refused().empty());
  EXPECT_NE(f.refused().back().find("--dashboard-max-connections"), std::string::npos) << f.refused().back();
  // A client leaving frees its slot.
  clients.pop_back();
  for (int i = 0; i < 100 && f.stats().connections > 2; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(get(f.port(), "/metrics").result(), http::status::ok);
}

TEST(DashboardServer, AtTheCapTheLongestIdleConnectionGivesWay) {
  DashboardOptions o;
  o.max_connections = 3;
  ServerFixture f(o);
  RawConnection first(f.port());
  RawConnection second(f.port());
  RawConnection third(f.port());
  for (int i = 0; i < 100 && f.stats().connections < 3; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  // Three idle connections hold the cap: a request still gets through, and the oldest goes.
  EXPECT_EQ(get(f.port(), "/metrics").result(), http::status::ok);
  EXPECT_TRUE(first.read_until_closed());
  const auto st = f.stats();
  EXPECT_EQ(st.evicted_connections, 1u);
  EXPECT_EQ(st.refused_connections, 0u);
  EXPECT_LE(st.connections, 3u);
}

TEST(DashboardServer, IdleAndTrickledConnectionsAreClosed) {
  DashboardOptions o;
  o.idle_timeout = std::chrono::milliseconds(200);
  o.request_timeout = std::chrono::milliseconds(500);
  ServerFixture f(o);
  RawConnection idle(f.port());
  EXPECT_TRUE(idle.read_until_closed());
  // A kept-alive connection after its answer is idle too.
  RawConnection kept(f.port());
  ASSERT_TRUE(kept.send("GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n"));
  std::string said;
  EXPECT_TRUE(kept.read_until_closed(&said));
  EXPECT_EQ(said.rfind("HTTP/1.1 200", 0), 0u) << said;
  // A header trickled a byte at a time does not extend its deadline (slowloris).
  RawConnection slow(f.port());
  ASSERT_TRUE(slow.send("GET / HTTP/1.1\r\nHost: x\r\n"));
  bool cut = false;
  for (int i = 0; i < 400 && !cut; ++i) {  // 20 s of trickling at most
    cut = !slow.send("X");
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (f.stats().request_timeouts > 0) cut = true;
  }
  EXPECT_TRUE(cut);
  EXPECT_TRUE(slow.read_until_closed());
  const auto st = f.stats();
  EXPECT_EQ(st.idle_timeouts, 2u);
  EXPECT_EQ(st.request_timeouts, 1u);
  for (int i = 0; i < 100 && f.stats().connections > 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(f.stats().connections, 0u);
}

TEST(DashboardServer, TheWebSocketIsOnlyOnItsPathWithAValidKey) {
  ServerFixture f;
  auto handshake = [&](const std::string& target, const std::string& key) {
    RawConnection c(f.port());
    EXPECT_TRUE(c.send("GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                       "Sec-WebSocket-Key: " + key + "\r\nSec-WebSocket-Version: 13\r\n"
                       "Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n"));
    std::string said;
    c.read_until_closed(&said);
    return said.substr(0, said.find("\r\n"));
  };
  EXPECT_EQ(handshake("/metrics", "dGhlIHNhbXBsZSBub25jZQ=="), "HTTP/1.1 404 Not Found");
  EXPECT_EQ(handshake("/anything", "dGhlIHNhbXBsZSBub25jZQ=="), "HTTP/1.1 404 Not Found");
  EXPECT_EQ(handshake("/", "not-a-key"), "HTTP/1.1 400 Bad Request");
  EXPECT_EQ(handshake("/", "MDEyMzQ1Njc4OWFiY2Rl"), "HTTP/1.1 400 Bad Request");
  EXPECT_THROW(Client(f.port(), "", "/other"), beast::system_error);
  EXPECT_NO_THROW(Client(f.port(), "", "/"));
  const auto refused = f.refused();
  EXPECT_EQ(f.stats().refused_requests, 5u);
  ASSERT_EQ(refused.size(), 5u);
  EXPECT_NE(refused[2].find("Sec-WebSocket-Key"), std::string::npos) << refused[2];
}

TEST(DashboardServer, RefusedMessagesAndBadFramesAreCountedAndReported) {
  ServerFixture f;
  Client c(f.port());
  c.read_json();
  c.read_json();
  c.send("{");
  EXPECT_EQ(c.read_json()["level"], 2);
  EXPECT_EQ(f.stats().refused_messages, 1u);
  ASSERT_EQ(f.refused().size(), 1u);
  EXPECT_NE(f.refused()[0].find("not valid JSON"), std::string::npos) << f.refused()[0];
  // Over the size limit: beast closes the connection; a bad frame, counted and reported.
  beast::error_code ec;
  c.ws.write(net::buffer(std::string(70 * 1024, ' ')), ec);
  for (int i = 0; i < 1000 && !ec; ++i) {  // until the close (the client answers the server's close frame)
    c.ws.read(c.buffer, ec);
    c.buffer.consume(c.buffer.size());
  }
  for (int i = 0; i < 100 && f.stats().refused_messages < 2; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(f.stats().refused_messages, 2u);
  EXPECT_NE(f.refused().back().find("closed WebSocket client"), std::string::npos) << f.refused().back();
}

TEST(DashboardServer, ATakenPortIsAClearError) {
  ServerFixture first;
  DashboardOptions o;
  o.port = first.port();
  net::io_context io;
  try {
    DashboardServer second(io, o, json::object(), {});
    FAIL() << "bound a taken port";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("--dashboard PORT"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace netkf::cli
