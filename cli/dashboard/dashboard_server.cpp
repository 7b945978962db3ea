#include "dashboard_server.hpp"

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

#include "dashboard__assets.hpp"

namespace netkf::cli {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using error_code = boost::system::error_code;

namespace {

constexpr std::size_t kHttpLimit = 8 * 1024;  // header and body of a plain HTTP request
constexpr auto kHttpTimeout = std::chrono::seconds(30);

struct Target {
  std::string path;
  std::map<std::string, std::string> query;
};

Target split_target(beast::string_view target) {
  Target t;
  const std::string s(target);
  const auto q = s.find('?');
  t.path = s.substr(0, q);
  if (q == std::string::npos) return t;
  std::string rest = s.substr(q + 1);
  std::size_t start = 0;
  while (start <= rest.size()) {
    const auto amp = rest.find('&', start);
    const std::string pair = rest.substr(start, amp == std::string::npos ? std::string::npos : amp - start);
    const auto eq = pair.find('=');
    if (!pair.empty()) t.query[pair.substr(0, eq)] = eq == std::string::npos ? "" : pair.substr(eq + 1);
    if (amp == std::string::npos) break;
    start = amp + 1;
  }
  return t;
}

/// Comparison whose time does not depend on where the strings differ.
bool same_secret(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

bool offers_subprotocol(beast::string_view header, const std::string& wanted) {
  std::string list(header);
  std::size_t start = 0;
  while (start < list.size()) {
    auto comma = list.find(',', start);
    if (comma == std::string::npos) comma = list.size();
    std::string item = list.substr(start, comma - start);
    const auto b = item.find_first_not_of(" \t");
    const auto e = item.find_last_not_of(" \t");
    if (b != std::string::npos && item.substr(b, e - b + 1) == wanted) return true;
    start = comma + 1;
  }
  return false;
}

struct Frame {
  std::string data;
  bool binary = false;
};

}  // namespace

class WsSession;
class HttpSession;

struct DashboardServer::Impl : std::enable_shared_from_this<DashboardServer::Impl> {
  Impl(net::io_context& io_, DashboardOptions o, nlohmann::json info, Hooks h)
      : io(io_), options(std::move(o)), server_info(std::move(info)), hooks(std::move(h)), acceptor(io_), flush_timer(io_) {}

  void listen();
  void accept_next();
  void schedule_flush();
  void flush();

  /// nullopt: the request may proceed; else the status and reason to refuse it with.
  std::optional<std::pair<http::status, std::string>> check_request(const http::request<http::string_body>& req,
                                                                    bool websocket_upgrade) const;
  http::response<http::string_body> respond(const http::request<http::string_body>& req);
  void upgrade(beast::tcp_stream stream, http::request<http::string_body> req);
  void handle_client_message(WsSession& session, const std::string& text);
  std::vector<std::shared_ptr<WsSession>> live_sessions();

  net::io_context& io;
  DashboardOptions options;
  nlohmann::json server_info;
  Hooks hooks;
  tcp::acceptor acceptor;
  net::steady_timer flush_timer;
  std::vector<std::weak_ptr<WsSession>> sessions;
  std::map<std::pair<std::uint32_t, int>, std::pair<std::string, std::uint64_t>> latched;  // payload, timestamp
  std::set<std::string> own_origins;
  ClientId next_client = 1;
  std::uint64_t dropped = 0;
  bool stopped = false;
};

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(beast::tcp_stream&& stream, std::weak_ptr<DashboardServer::Impl> server, DashboardServer::ClientId id,
            std::size_t max_message, std::size_t max_queued)
      : ws_(std::move(stream)), server_(std::move(server)), id_(id), max_queued_(max_queued) {
    ws_.read_message_max(max_message);
  }

  DashboardServer::ClientId id() const { return id_; }
  bool open() const { return open_; }

  void accept(http::request<http::string_body> req) {
    beast::get_lowest_layer(ws_).expires_never();
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator([](websocket::response_type& res) {
      res.set(http::field::sec_websocket_protocol, dashboard::kSubprotocol);
      res.set(http::field::server, "netkf");
    }));
    ws_.async_accept(req, [self = shared_from_this()](error_code ec) {
      if (ec) return;
      self->open_ = true;
      if (auto srv = self->server_.lock()) {
        self->send_json(srv->server_info);
        self->send_json(dashboard::advertise());
      }
      self->read();
    });
  }

  /// Control messages go out at once.
  void send_json(const nlohmann::json& j) {
    queue_.push_back({j.dump(), false});
    bound_queue();
    pump();
  }
  /// Data frames wait for the next batch (flush()).
  void queue_data(std::string frame) {
    queue_.push_back({std::move(frame), true});
    bound_queue();
  }
  void pump() {
    if (writing_ || queue_.empty() || !open_) return;
    writing_ = true;
    ws_.binary(queue_.front().binary);
    ws_.async_write(net::buffer(queue_.front().data), [self = shared_from_this()](error_code ec, std::size_t) {
      self->writing_ = false;
      if (ec) {
        self->open_ = false;
        return;
      }
      self->queue_.pop_front();
      self->pump();
    });
  }
  void close() {
    if (!open_) return;
    open_ = false;
    ws_.async_close(websocket::close_code::going_away, [self = shared_from_this()](error_code) {});
  }

  // Subscriptions: subscription id -> channel id.
  std::map<std::uint32_t, std::uint32_t> subscriptions;
  std::set<std::string> parameter_subscriptions;
  bool all_parameters = false;

 private:
  void bound_queue() {
    // A slow client must not grow the launch's memory: drop its oldest data frames (not
    // the one being written, and never control messages).
    while (queue_.size() > max_queued_) {
      auto it = queue_.begin();
      if (writing_) ++it;
      while (it != queue_.end() && !it->binary) ++it;
      if (it == queue_.end()) break;
      queue_.erase(it);
      if (auto srv = server_.lock()) ++srv->dropped;
    }
  }

  void read() {
    ws_.async_read(buffer_, [self = shared_from_this()](error_code ec, std::size_t) {
      if (ec) {
        // Closed, or a message over the size limit (beast closes with "message too big").
        self->open_ = false;
        return;
      }
      const bool text = self->ws_.got_text();
      std::string message = beast::buffers_to_string(self->buffer_.data());
      self->buffer_.consume(self->buffer_.size());
      if (auto srv = self->server_.lock()) {
        if (text) {
          srv->handle_client_message(*self, message);
        } else {
          self->send_json(dashboard::status_message(LiveEvent::Level::error,
                                                    "binary client messages are not supported by this server"));
        }
      }
      self->read();
    });
  }

  websocket::stream<beast::tcp_stream> ws_;
  std::weak_ptr<DashboardServer::Impl> server_;
  DashboardServer::ClientId id_;
  std::size_t max_queued_;
  beast::flat_buffer buffer_;
  std::deque<Frame> queue_;
  bool writing_ = false;
  bool open_ = false;
};

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, std::weak_ptr<DashboardServer::Impl> server)
      : stream_(std::move(socket)), server_(std::move(server)) {}

  void read() {
    parser_.emplace();
    parser_->header_limit(kHttpLimit);
    parser_->body_limit(kHttpLimit);
    stream_.expires_after(kHttpTimeout);
    http::async_read(stream_, buffer_, *parser_, [self = shared_from_this()](error_code ec, std::size_t) {
      self->on_read(ec);
    });
  }

 private:
  void on_read(error_code ec) {
    if (ec == http::error::end_of_stream || ec == beast::error::timeout || ec == net::error::operation_aborted) {
      return close();
    }
    auto srv = server_.lock();
    if (!srv) return;
    if (ec) {
      // Oversized or malformed request: answer once, then close.
      http::response<http::string_body> res{ec == http::error::header_limit || ec == http::error::body_limit
                                                ? http::status::payload_too_large
                                                : http::status::bad_request,
                                            11};
      res.set(http::field::content_type, "text/plain; charset=utf-8");
      res.body() = "bad request: " + ec.message() + "\n";
      res.keep_alive(false);
      return write(std::move(res));
    }
    auto req = parser_->release();
    if (websocket::is_upgrade(req)) {
      if (auto refusal = srv->check_request(req, true)) {
        http::response<http::string_body> res{refusal->first, req.version()};
        res.set(http::field::content_type, "text/plain; charset=utf-8");
        res.body() = refusal->second + "\n";
        res.keep_alive(false);
        return write(std::move(res));
      }
      srv->upgrade(std::move(stream_), std::move(req));
      return;
    }
    write(srv->respond(req));
  }

  void write(http::response<http::string_body> response) {
    response.prepare_payload();
    auto res = std::make_shared<http::response<http::string_body>>(std::move(response));
    stream_.expires_after(kHttpTimeout);
    http::async_write(stream_, *res, [self = shared_from_this(), res](error_code ec, std::size_t) {
      if (ec || !res->keep_alive()) return self->close();
      self->read();
    });
  }

  void close() {
    error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.socket().close(ignored);
  }

  beast::tcp_stream stream_;
  std::weak_ptr<DashboardServer::Impl> server_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
};

// ---------------------------------------------------------------- Impl

void DashboardServer::Impl::listen() {
  error_code ec;
  const auto address = net::ip::make_address(options.bind, ec);
  if (ec) throw std::runtime_error("dashboard: '" + options.bind + "' is not an IP address (--dashboard-bind)");
  const tcp::endpoint endpoint(address, options.port);
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec)
    throw std::runtime_error("dashboard: cannot listen on " + options.bind + ":" + std::to_string(options.port) + ": " +
                             ec.message() +
                             (ec == net::error::address_in_use
                                  ? " (another program uses the port: choose one with --dashboard PORT, or "
                                    "--dashboard off)"
                                  : ""));
  const auto port = std::to_string(acceptor.local_endpoint().port());
  own_origins = {"http://127.0.0.1:" + port, "http://localhost:" + port, "http://[::1]:" + port};
  if (!address.is_unspecified()) {
    const std::string host = address.is_v6() ? "[" + options.bind + "]" : options.bind;
    own_origins.insert("http://" + host + ":" + port);
  }
  for (const auto& o : options.allowed_origins) own_origins.insert(o);
  accept_next();
  schedule_flush();
}

void DashboardServer::Impl::accept_next() {
  acceptor.async_accept([weak = weak_from_this()](error_code ec, tcp::socket socket) {
    auto self = weak.lock();
    if (!self || self->stopped) return;
    if (!ec) std::make_shared<HttpSession>(std::move(socket), weak)->read();
    self->accept_next();
  });
}

void DashboardServer::Impl::schedule_flush() {
  flush_timer.expires_after(options.flush_interval);
  flush_timer.async_wait([weak = weak_from_this()](error_code ec) {
    auto self = weak.lock();
    if (ec || !self || self->stopped) return;
    self->flush();
    self->schedule_flush();
  });
}

void DashboardServer::Impl::flush() {
  for (auto& s : live_sessions()) s->pump();
}

std::vector<std::shared_ptr<WsSession>> DashboardServer::Impl::live_sessions() {
  std::vector<std::shared_ptr<WsSession>> out;
  std::vector<std::weak_ptr<WsSession>> keep;
  for (auto& w : sessions) {
    if (auto s = w.lock(); s && s->open()) {
      out.push_back(s);
      keep.push_back(w);
    } else if (s) {
      keep.push_back(w);  // accepting: not open yet
    }
  }
  sessions = std::move(keep);
  return out;
}

std::optional<std::pair<http::status, std::string>> DashboardServer::Impl::check_request(
    const http::request<http::string_body>& req, bool websocket_upgrade) const {
  if (!options.token.empty()) {
    const auto target = split_target(req.target());
    std::string given;
    if (auto it = target.query.find("token"); it != target.query.end()) given = it->second;
    const std::string auth(req[http::field::authorization]);
    if (given.empty() && auth.rfind("Bearer ", 0) == 0) given = auth.substr(7);
    if (!same_secret(given, options.token))
      return std::make_pair(http::status::unauthorized,
                            "this dashboard needs the token printed by netkf launch (?token=... in the URL)");
  }
  if (websocket_upgrade) {
    // A web page of another site open in the same browser must not retune links: only
    // the dashboard's own origin (and those allowed on the command line) may connect.
    // Clients that send no Origin (desktop apps, scripts) are served.
    const std::string origin(req[http::field::origin]);
    if (!origin.empty() && !own_origins.count(origin))
      return std::make_pair(http::status::forbidden,
                            "origin '" + origin.substr(0, 200) +
                                "' is not allowed (netkf launch --dashboard-allow-origin ORIGIN allows it)");
    if (!offers_subprotocol(req[http::field::sec_websocket_protocol], dashboard::kSubprotocol))
      return std::make_pair(http::status::bad_request,
                            std::string("this WebSocket speaks the subprotocol ") + dashboard::kSubprotocol);
  }
  return std::nullopt;
}

http::response<http::string_body> DashboardServer::Impl::respond(const http::request<http::string_body>& req) {
  http::response<http::string_body> res{http::status::ok, req.version()};
  res.set(http::field::server, "netkf");
  res.set("X-Content-Type-Options", "nosniff");
  res.keep_alive(req.keep_alive());
  auto text = [&](http::status status, std::string body) {
    res.result(status);
    res.set(http::field::content_type, "text/plain; charset=utf-8");
    res.body() = std::move(body);
  };
  if (auto refusal = check_request(req, false)) {
    text(refusal->first, refusal->second + "\n");
    return res;
  }
  if (req.method() != http::verb::get && req.method() != http::verb::head) {
    text(http::status::method_not_allowed, "only GET is served here\n");
    res.set(http::field::allow, "GET, HEAD");
    return res;
  }
  const auto target = split_target(req.target());
  if (target.path == "/metrics") {
    res.set(http::field::content_type, "text/plain; version=0.0.4; charset=utf-8");
    res.body() = hooks.metrics ? hooks.metrics() : std::string();
  } else if (const auto* asset = dashboard::find_asset(target.path == "/" ? "/index.html" : target.path)) {
    res.set(http::field::content_type, std::string(asset->content_type));
    // The page must not be framed by another site (it has link controls).
    res.set("X-Frame-Options", "DENY");
    res.set(http::field::cache_control, "no-cache");
    res.body() = std::string(asset->body);
  } else {
    text(http::status::not_found, "not found\n");
  }
  if (req.method() == http::verb::head) {
    res.content_length(res.body().size());
    res.body().clear();
  }
  return res;
}

void DashboardServer::Impl::upgrade(beast::tcp_stream stream, http::request<http::string_body> req) {
  auto session = std::make_shared<WsSession>(std::move(stream), weak_from_this(), next_client++,
                                             options.max_message_bytes, options.max_queued_frames);
  sessions.push_back(session);
  session->accept(std::move(req));
}

void DashboardServer::Impl::handle_client_message(WsSession& session, const std::string& text) {
  using namespace dashboard;
  auto refuse = [&](const std::string& why) { session.send_json(status_message(LiveEvent::Level::error, why)); };
  ClientMessage message;
  try {
    message = parse_client_message(text);
  } catch (const ProtocolError& e) {
    return refuse(std::string("message refused: ") + e.what());
  }
  if (auto* sub = std::get_if<Subscribe>(&message)) {
    for (const auto& [subscription, channel] : sub->subscriptions) {
      if (!catalogue::find_channel(channel)) {
        refuse("subscribe: unknown channel " + std::to_string(channel));
        continue;
      }
      if (session.subscriptions.count(subscription)) {
        refuse("subscribe: subscription id " + std::to_string(subscription) + " is already in use");
        continue;
      }
      session.subscriptions[subscription] = channel;
      // The channel's latest values at once, so a page opened mid-run shows the state.
      for (const auto& [key, value] : latched)
        if (key.first == channel) session.queue_data(message_data_frame(subscription, value.second, value.first));
    }
    session.pump();
  } else if (auto* unsub = std::get_if<Unsubscribe>(&message)) {
    for (auto id : unsub->subscription_ids) session.subscriptions.erase(id);
  } else if (auto* get = std::get_if<GetParameters>(&message)) {
    session.send_json(hooks.get_parameters ? hooks.get_parameters(*get) : parameter_values({}, {}, get->id));
  } else if (auto* set = std::get_if<SetParameters>(&message)) {
    if (hooks.set_parameters) hooks.set_parameters(session.id(), *set);
  } else if (auto* updates = std::get_if<ParameterUpdates>(&message)) {
    if (updates->subscribe) {
      if (updates->names.empty()) session.all_parameters = true;
      session.parameter_subscriptions.insert(updates->names.begin(), updates->names.end());
    } else if (updates->names.empty()) {
      session.all_parameters = false;
      session.parameter_subscriptions.clear();
    } else {
      for (const auto& n : updates->names) session.parameter_subscriptions.erase(n);
    }
  }
}

// ---------------------------------------------------------------- DashboardServer

DashboardServer::DashboardServer(net::io_context& io, DashboardOptions options, nlohmann::json server_info, Hooks hooks)
    : impl_(std::make_shared<Impl>(io, std::move(options), std::move(server_info), std::move(hooks))) {
  impl_->listen();
}

DashboardServer::~DashboardServer() { stop(); }

unsigned short DashboardServer::port() const {
  error_code ec;
  const auto ep = impl_->acceptor.local_endpoint(ec);
  return ec ? impl_->options.port : ep.port();
}

std::string DashboardServer::url() const {
  // Only the printed address: the server listens where options.bind says (127.0.0.1 by
  // default). A wildcard bind (--dashboard-bind 0.0.0.0) is not an address a browser can
  // open, so the URL names this machine's loopback, which the wildcard includes.
  std::string host = impl_->options.bind;
  if (host == "0.0.0.0" || host == "::") host = "127.0.0.1";
  else if (host.find(':') != std::string::npos) host = "[" + host + "]";
  std::string u = "http://" + host + ":" + std::to_string(port()) + "/";
  if (!impl_->options.token.empty()) u += "?token=" + impl_->options.token;
  return u;
}

void DashboardServer::publish(catalogue::ChannelId channel, const nlohmann::json& message, std::uint64_t timestamp_ns,
                              int latch_key) {
  if (impl_->stopped) return;
  const auto channel_id = static_cast<std::uint32_t>(channel);
  std::string payload = message.dump();
  // Called for every estimate and truth sample: no list is rebuilt here (the flush prunes).
  for (const auto& weak : impl_->sessions) {
    const auto s = weak.lock();
    if (!s || !s->open()) continue;
    for (const auto& [subscription, ch] : s->subscriptions)
      if (ch == channel_id) s->queue_data(dashboard::message_data_frame(subscription, timestamp_ns, payload));
  }
  impl_->latched[{channel_id, latch_key}] = {std::move(payload), timestamp_ns};
}

void DashboardServer::broadcast_status(LiveEvent::Level level, const std::string& message) {
  if (impl_->stopped) return;
  const auto j = dashboard::status_message(level, message);
  for (auto& s : impl_->live_sessions()) s->send_json(j);
}

void DashboardServer::send_to(ClientId client, const nlohmann::json& message) {
  for (auto& s : impl_->live_sessions())
    if (s->id() == client) s->send_json(message);
}

void DashboardServer::broadcast_parameter_values(const nlohmann::json& values) {
  for (auto& s : impl_->live_sessions()) {
    nlohmann::json mine = nlohmann::json::array();
    for (const auto& p : values["parameters"])
      if (s->all_parameters || s->parameter_subscriptions.count(p["name"].get<std::string>())) mine.push_back(p);
    if (!mine.empty()) s->send_json({{"op", "parameterValues"}, {"parameters", std::move(mine)}});
  }
}

std::size_t DashboardServer::client_count() const { return impl_->live_sessions().size(); }
std::uint64_t DashboardServer::dropped_frames() const { return impl_->dropped; }

void DashboardServer::stop() {
  if (!impl_ || impl_->stopped) return;
  impl_->stopped = true;
  error_code ignored;
  impl_->acceptor.close(ignored);
  impl_->flush_timer.cancel();
  for (auto& s : impl_->live_sessions()) s->close();
}

}  // namespace netkf::cli
