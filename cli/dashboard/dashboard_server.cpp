#include "netkf/cli/dashboard/dashboard_server.hpp"

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <algorithm>
#include <deque>
#include <list>
#include <optional>
#include <stdexcept>
#include <string_view>

#include "netkf/cli/dashboard/assets.hpp"
#include "foxglove_session.hpp"
#include "netkf/cli/dashboard/request_policy.hpp"

namespace netkf::cli {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using error_code = boost::system::error_code;

namespace {

struct Frame {
  std::string data;
  bool binary = false;
  bool keep = false;  // a latched state frame sent on subscribe: never dropped for a slow client
};

std::string_view view(beast::string_view s) { return {s.data(), s.size()}; }

dashboard::RequestFacts request_facts(const http::request<http::string_body>& req) {
  return {view(req.method_string()),
          view(req.target()),
          view(req[http::field::authorization]),
          view(req[http::field::origin]),
          view(req[http::field::sec_websocket_protocol]),
          view(req[http::field::sec_websocket_key]),
          websocket::is_upgrade(req),
          req.keep_alive()};
}

http::response<http::string_body> make_response(const dashboard::RequestDecision& decision, unsigned version,
                                                std::string body) {
  http::response<http::string_body> res{static_cast<http::status>(decision.status), version};
  for (const auto& [name, value] : decision.fields) res.set(name, value);
  res.keep_alive(decision.keep_alive);
  res.body() = std::move(body);
  if (decision.head) {
    res.content_length(res.body().size());
    res.body().clear();
  }
  return res;
}

// The embedded files one page may serve: each page its own files and the shared style, so the
// launch does not serve the relay's page nor the relay the launch's. The policy asks for
// /index.html on GET /: the relay answers with relay.html.
dashboard::RequestPolicy::FindAsset page_assets(DashboardPage page) {
  using dashboard::Asset;
  switch (page) {
    case DashboardPage::launch:
      return [](std::string_view path) -> const Asset* {
        return path == "/relay.html" || path == "/relay.js" ? nullptr : dashboard::find_asset(path);
      };
    case DashboardPage::relay:
      return [](std::string_view path) -> const Asset* {
        if (path == "/index.html") path = "/relay.html";
        const bool relays = path == "/relay.html" || path == "/relay.js" || path == "/link_models.js" ||
                            path == "/style.css" || path == "/uPlot.iife.min.js" || path == "/uPlot.min.css";
        return relays ? dashboard::find_asset(path) : nullptr;
      };
    case DashboardPage::none: break;
  }
  return [](std::string_view) -> const Asset* { return nullptr; };
}

}  // namespace

class WsSession;
class HttpSession;

/// One open connection, counted against the cap while it lives (moved from the HTTP session to
/// the WebSocket one on an upgrade); release() when its socket is closed.
class ConnectionSlot {
 public:
  explicit ConnectionSlot(std::weak_ptr<DashboardServer::Impl> server);
  ConnectionSlot(ConnectionSlot&& other) noexcept : server_(std::exchange(other.server_, {})) {}
  ConnectionSlot& operator=(ConnectionSlot&&) = delete;
  ConnectionSlot(const ConnectionSlot&) = delete;
  ~ConnectionSlot() { release(); }
  void release();

 private:
  std::weak_ptr<DashboardServer::Impl> server_;
};

struct DashboardServer::Impl : std::enable_shared_from_this<DashboardServer::Impl> {
  Impl(net::io_context& io_, DashboardOptions o, nlohmann::json info, Hooks h)
      : io(io_),
        options(std::move(o)),
        server_info(std::move(info)),
        hooks(std::move(h)),
        acceptor(io_),
        accept_timer(io_),
        flush_timer(io_) {}

  void listen();
  void accept_next();
  void on_accept(error_code ec, tcp::socket socket);
  /// Close the HTTP connection idle the longest (no request begun) for a new one; false: none.
  bool evict_idle();
  void schedule_flush();
  void flush();
  void refused(const std::string& what) {
    if (hooks.refused) hooks.refused(what);
  }

  void upgrade(beast::tcp_stream stream, ConnectionSlot slot, http::request<http::string_body> req,
               const dashboard::RequestDecision& decision);
  /// Do what the client's message asked (FoxgloveSession decided it).
  void apply(WsSession& session, dashboard::SessionActions actions);
  std::vector<std::shared_ptr<WsSession>> live_sessions();

  net::io_context& io;
  DashboardOptions options;
  nlohmann::json server_info;
  Hooks hooks;
  tcp::acceptor acceptor;
  net::steady_timer accept_timer;  // after an accept error (out of descriptors): a pause, not a spin
  net::steady_timer flush_timer;
  std::optional<dashboard::RequestPolicy> policy;  // once listening (the origins name the port)
  std::vector<std::weak_ptr<WsSession>> sessions;
  std::list<std::weak_ptr<HttpSession>> idle;  // HTTP connections with no request begun, oldest first
  dashboard::LatchedMessages latched;
  ClientId next_client = 1;
  std::uint64_t dropped = 0;
  DashboardStats stats;
  bool stopped = false;
};

ConnectionSlot::ConnectionSlot(std::weak_ptr<DashboardServer::Impl> server) : server_(std::move(server)) {
  if (auto s = server_.lock()) ++s->stats.connections;
}

void ConnectionSlot::release() {
  if (auto s = server_.lock()) --s->stats.connections;
  server_.reset();
}

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(beast::tcp_stream&& stream, ConnectionSlot slot, std::weak_ptr<DashboardServer::Impl> server,
            DashboardServer::ClientId id, std::size_t max_message, std::size_t max_queued)
      : ws_(std::move(stream)), slot_(std::move(slot)), server_(std::move(server)), id_(id), max_queued_(max_queued) {
    ws_.read_message_max(max_message);
  }

  DashboardServer::ClientId id() const { return id_; }
  bool open() const { return open_; }

  /// `fields`: the handshake's answer (the subprotocol chosen).
  void accept(http::request<http::string_body> req, std::vector<std::pair<std::string, std::string>> fields) {
    beast::get_lowest_layer(ws_).expires_never();
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator([fields = std::move(fields)](websocket::response_type& res) {
      for (const auto& [name, value] : fields) res.set(name, value);
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
    queue_.push_back({j.dump(), false, true});
    bound_queue();
    pump();
  }
  /// Data frames wait for the next batch (flush()); `keep`: a latched state frame.
  void queue_data(std::string frame, bool keep = false) {
    queue_.push_back({std::move(frame), true, keep});
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

  dashboard::FoxgloveSession foxglove;

 private:
  void bound_queue() {
    // A slow client must not grow the launch's memory: drop its oldest data frames (not
    // the one being written, never control messages, never the latched state a subscription
    // began with: the scenario, every link's last status — their number is bounded by the
    // channels and links).
    while (queue_.size() > max_queued_) {
      auto it = queue_.begin();
      if (writing_) ++it;
      while (it != queue_.end() && it->keep) ++it;
      if (it == queue_.end()) break;
      queue_.erase(it);
      if (auto srv = server_.lock()) ++srv->dropped;
    }
  }

  void read() {
    ws_.async_read(buffer_, [self = shared_from_this()](error_code ec, std::size_t) {
      if (ec) {
        // Closed, or a bad frame: a message over the size limit ("message too big"), an unmasked
        // or malformed frame; beast has closed the connection.
        self->open_ = false;
        const bool closed = ec == websocket::error::closed || ec == net::error::eof ||
                            ec == net::error::operation_aborted || ec == net::error::connection_reset ||
                            ec == beast::error::timeout;
        if (auto srv = self->server_.lock(); srv && !closed) {
          ++srv->stats.refused_messages;
          srv->refused("closed WebSocket client " + std::to_string(self->id_) + ": " + ec.message());
        }
        return;
      }
      const bool text = self->ws_.got_text();
      std::string message = beast::buffers_to_string(self->buffer_.data());
      self->buffer_.consume(self->buffer_.size());
      if (auto srv = self->server_.lock())
        srv->apply(*self, text ? self->foxglove.on_text(message, srv->latched) : self->foxglove.on_binary());
      self->read();
    });
  }

  websocket::stream<beast::tcp_stream> ws_;
  ConnectionSlot slot_;  // counted while this object (and so its socket) lives
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
  HttpSession(tcp::socket&& socket, ConnectionSlot slot, std::weak_ptr<DashboardServer::Impl> server)
      : stream_(std::move(socket)), slot_(std::move(slot)), server_(std::move(server)) {}
  ~HttpSession() { set_idle(false); }

  /// Wait for a request: idle_timeout for its first byte, then request_timeout for the rest.
  void wait_for_request() {
    auto srv = server_.lock();
    if (!srv) return close();
    if (buffer_.size() > 0) return read_request(*srv);  // pipelined: the next request is here
    set_idle(true);
    stream_.expires_after(srv->options.idle_timeout);
    stream_.async_read_some(buffer_.prepare(dashboard::kHttpRequestLimit),
                            [self = shared_from_this()](error_code ec, std::size_t n) {
                              self->set_idle(false);
                              auto server = self->server_.lock();
                              if (ec || !server) {
                                if (ec == beast::error::timeout && server) ++server->stats.idle_timeouts;
                                return self->close();
                              }
                              self->buffer_.commit(n);
                              self->read_request(*server);
                            });
  }

  bool idle() const { return idle_pos_.has_value(); }
  /// Idle and nothing arrived yet (a request that arrived but was not read yet is not idle).
  bool evictable() {
    error_code ec;
    return idle() && stream_.socket().available(ec) == 0 && !ec;
  }
  /// Closed at the cap for a newer connection (its pending read ends with operation_aborted).
  void evict() {
    set_idle(false);
    close();
  }

 private:
  void read_request(DashboardServer::Impl& srv) {
    parser_.emplace();
    parser_->header_limit(dashboard::kHttpRequestLimit);
    parser_->body_limit(dashboard::kHttpRequestLimit);
    stream_.expires_after(srv.options.request_timeout);
    http::async_read(stream_, buffer_, *parser_, [self = shared_from_this()](error_code ec, std::size_t) {
      self->on_read(ec);
    });
  }

  void on_read(error_code ec) {
    auto srv = server_.lock();
    if (!srv) return close();
    if (ec == beast::error::timeout) {
      ++srv->stats.request_timeouts;
      srv->refused("closed an HTTP connection: its request was not complete " +
                   std::to_string(srv->options.request_timeout.count()) + " ms after its first byte");
      return close();
    }
    if (ec == http::error::end_of_stream || ec == net::error::operation_aborted || ec == net::error::connection_reset)
      return close();
    if (ec) {
      // Oversized or malformed request: answer once, then close.
      const bool too_large = ec == http::error::header_limit || ec == http::error::body_limit;
      const auto decision = dashboard::unreadable_request(too_large, ec.message());
      ++srv->stats.refused_requests;
      srv->refused("refused an HTTP request (" + std::to_string(decision.status) + "): " + ec.message());
      return write(make_response(decision, 11, decision.body));
    }
    auto req = parser_->release();
    const auto facts = request_facts(req);
    const auto decision = srv->policy->decide(facts);
    if (dashboard::worth_logging(facts, decision)) {
      ++srv->stats.refused_requests;
      const std::string target(view(req.target()).substr(0, 80));
      const auto reason = decision.body.substr(0, decision.body.find('\n'));
      srv->refused("refused " + std::string(facts.websocket_upgrade ? "a WebSocket handshake" : "an HTTP request") +
                   " (" + std::to_string(decision.status) + ", " + std::string(view(req.method_string()).substr(0, 16)) +
                   " " + target.substr(0, target.find('?')) + "): " + reason);
    }
    using Action = dashboard::RequestDecision::Action;
    if (decision.action == Action::websocket)
      return srv->upgrade(std::move(stream_), std::move(slot_), std::move(req), decision);
    const bool metrics = decision.action == Action::metrics;
    write(make_response(decision, req.version(),
                        metrics ? (srv->hooks.metrics ? srv->hooks.metrics() : std::string()) : decision.body));
  }

  void write(http::response<http::string_body> response) {
    response.prepare_payload();
    auto res = std::make_shared<http::response<http::string_body>>(std::move(response));
    if (auto srv = server_.lock()) stream_.expires_after(srv->options.request_timeout);
    http::async_write(stream_, *res, [self = shared_from_this(), res](error_code ec, std::size_t) {
      if (ec || !res->keep_alive()) return self->close();
      self->wait_for_request();
    });
  }

  void close() {
    error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.socket().close(ignored);
    slot_.release();
  }

  void set_idle(bool idle) {
    auto srv = server_.lock();
    if (!srv) return;
    if (idle && !idle_pos_) idle_pos_ = srv->idle.insert(srv->idle.end(), weak_from_this());
    if (!idle && idle_pos_) {
      srv->idle.erase(*idle_pos_);
      idle_pos_.reset();
    }
  }

  beast::tcp_stream stream_;
  ConnectionSlot slot_;
  std::weak_ptr<DashboardServer::Impl> server_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::optional<std::list<std::weak_ptr<HttpSession>>::iterator> idle_pos_;
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
  policy.emplace(options.token,
                 dashboard::own_origins(options.bind, address.is_v6(), address.is_unspecified(),
                                        acceptor.local_endpoint().port(), options.allowed_origins),
                 page_assets(options.page));
  accept_next();
  schedule_flush();
}

void DashboardServer::Impl::accept_next() {
  acceptor.async_accept([weak = weak_from_this()](error_code ec, tcp::socket socket) {
    auto self = weak.lock();
    if (!self || self->stopped) return;
    self->on_accept(ec, std::move(socket));
  });
}

void DashboardServer::Impl::on_accept(error_code ec, tcp::socket socket) {
  if (ec) {
    ++stats.accept_errors;
    refused("cannot accept a connection: " + ec.message());
    // Out of descriptors (or memory): accepting again at once would spin; the pending
    // connection waits in the backlog.
    accept_timer.expires_after(std::chrono::milliseconds(100));
    accept_timer.async_wait([weak = weak_from_this()](error_code timer_ec) {
      auto self = weak.lock();
      if (!timer_ec && self && !self->stopped) self->accept_next();
    });
    return;
  }
  if (stats.connections >= options.max_connections && !evict_idle()) {
    // Every connection is busy (WebSocket clients, requests under way): refuse this one at once.
    ++stats.refused_connections;
    refused("refused a connection: " + std::to_string(stats.connections) +
            " are open, the limit (--dashboard-max-connections)");
    static const std::string body = "too many connections to this dashboard; try again later\n";
    static const std::string busy = "HTTP/1.1 503 Service Unavailable\r\nServer: netkf\r\n"
                                    "Content-Type: text/plain; charset=utf-8\r\nConnection: close\r\n"
                                    "Retry-After: 1\r\nContent-Length: " +
                                    std::to_string(body.size()) + "\r\n\r\n" + body;
    error_code ignored;
    socket.non_blocking(true, ignored);  // a fresh socket's send buffer takes it whole; never wait
    socket.write_some(net::buffer(busy), ignored);
    socket.shutdown(tcp::socket::shutdown_send, ignored);
    socket.close(ignored);
  } else {
    std::make_shared<HttpSession>(std::move(socket), ConnectionSlot(weak_from_this()), weak_from_this())
        ->wait_for_request();
  }
  accept_next();
}

bool DashboardServer::Impl::evict_idle() {
  for (auto it = idle.begin(); it != idle.end();) {
    auto session = it->lock();
    if (!session) {
      it = idle.erase(it);
      continue;
    }
    if (!session->evictable()) {  // its request is arriving
      ++it;
      continue;
    }
    session->evict();  // removes it from `idle`
    ++stats.evicted_connections;
    refused("closed the longest idle connection for a new one: " + std::to_string(options.max_connections) +
            " are open, the limit (--dashboard-max-connections)");
    return true;
  }
  return false;
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

void DashboardServer::Impl::upgrade(beast::tcp_stream stream, ConnectionSlot slot, http::request<http::string_body> req,
                                    const dashboard::RequestDecision& decision) {
  auto session = std::make_shared<WsSession>(std::move(stream), std::move(slot), weak_from_this(), next_client++,
                                             options.max_message_bytes, options.max_queued_frames);
  sessions.push_back(session);
  session->accept(std::move(req), decision.fields);
}

void DashboardServer::Impl::apply(WsSession& session, dashboard::SessionActions actions) {
  for (const auto& why : actions.refused) {
    ++stats.refused_messages;
    refused("refused a message of WebSocket client " + std::to_string(session.id()) + ": " + why.substr(0, 200));
  }
  for (auto& out : actions.send) {
    if (out.binary) {
      session.queue_data(std::move(out.frame), out.keep);
    } else {
      session.send_json(out.message);
    }
  }
  if (actions.send_data_now) session.pump();
  if (const auto& get = actions.get_parameters)
    session.send_json(hooks.get_parameters ? hooks.get_parameters(*get) : dashboard::parameter_values({}, {}, get->id));
  if (actions.set_parameters && hooks.set_parameters) hooks.set_parameters(session.id(), *actions.set_parameters);
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
    for (auto& frame : s->foxglove.message_frames(channel_id, timestamp_ns, payload)) s->queue_data(std::move(frame));
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
  for (auto& s : impl_->live_sessions())
    if (auto mine = s->foxglove.parameter_update(values)) s->send_json(*mine);
}

std::size_t DashboardServer::client_count() const { return impl_->live_sessions().size(); }
std::uint64_t DashboardServer::dropped_frames() const { return impl_->dropped; }

DashboardStats DashboardServer::stats() const {
  DashboardStats s = impl_->stats;
  s.max_connections = impl_->options.max_connections;
  return s;
}

std::size_t connection_cap(std::size_t wanted, std::uint64_t open_files) {
  return static_cast<std::size_t>(std::min<std::uint64_t>(wanted, open_files / 2));
}

void DashboardServer::stop() {
  if (!impl_ || impl_->stopped) return;
  impl_->stopped = true;
  error_code ignored;
  impl_->acceptor.close(ignored);
  impl_->accept_timer.cancel();
  impl_->flush_timer.cancel();
  for (auto& s : impl_->live_sessions()) s->close();
  const auto idle = impl_->idle;  // evict() edits the list
  for (const auto& w : idle)
    if (auto h = w.lock()) h->evict();
}

}  // namespace netkf::cli
