#pragma once
// The dashboard's HTTP + WebSocket server (Boost.Beast) on one port: GET / serves the page
// and its assets (embedded at build time), GET /metrics the Prometheus text, and a
// WebSocket upgrade speaks foxglove.websocket.v1 (dashboard_protocol.hpp). Runs on the
// caller's io_context (one thread: no locks); nothing here blocks. docs/dashboard.md
// describes what users see; the safety rules (bind, token, Origin, sizes) are enforced here,
// as request_policy.hpp decides them; each client's protocol state is a FoxgloveSession.
#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/io_context.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "netkf/cli/dashboard/dashboard_protocol.hpp"
#include "netkf/cli/live/live_metrics.hpp"
#include "netkf/cli/dashboard/request_policy.hpp"

namespace netkf::cli {

/// Connections the dashboard holds at once by default (HTTP and WebSocket together).
inline constexpr std::size_t kDefaultMaxConnections = 256;

/// Which page GET / serves: `netkf launch`'s (index.html: a scenario's sensors), `netkf relay`'s
/// (relay.html: a card per relayed topic), or none (only /metrics and the WebSocket).
enum class DashboardPage { launch, relay, none };

struct DashboardOptions {
  DashboardPage page = DashboardPage::launch;
  std::string bind = "127.0.0.1";
  unsigned short port = 8470;                 // 0: any free port (tests)
  std::vector<std::string> allowed_origins;   // besides the dashboard's own
  std::string token;                          // required on every request when not empty
  std::size_t max_message_bytes = 64 * 1024;  // a larger client message closes the connection
  std::size_t max_queued_frames = 4096;       // per client; older data frames are dropped beyond it
  std::chrono::milliseconds flush_interval{50};  // data frames go out in batches (20 a second)
  // At the cap a new connection takes the place of the longest idle HTTP one (no request begun),
  // or is refused at once (503) when none is idle: the launch's descriptors stay its own.
  std::size_t max_connections = kDefaultMaxConnections;
  std::chrono::milliseconds request_timeout = dashboard::kHttpRequestTimeout;  // first byte to last
  std::chrono::milliseconds idle_timeout = dashboard::kHttpIdleTimeout;        // no request begun
};

/// The connection cap of a dashboard in a process that may open `open_files` descriptors:
/// `wanted`, but at most half of them, so the launch keeps the rest (DDS sockets, its children's
/// pipes, the recording).
std::size_t connection_cap(std::size_t wanted, std::uint64_t open_files);

class DashboardServer {
 public:
  using ClientId = std::uint64_t;
  struct Hooks {
    /// A client's setParameters (the caller applies it through the link-control path).
    std::function<void(ClientId, const dashboard::SetParameters&)> set_parameters;
    /// The answer to getParameters.
    std::function<nlohmann::json(const dashboard::GetParameters&)> get_parameters;
    /// GET /metrics body.
    std::function<std::string()> metrics;
    /// Refused traffic in words (a request, a handshake, a client message, a bad frame, a
    /// connection over the cap); the caller logs it at a throttled rate.
    std::function<void(const std::string&)> refused;
  };

  /// Binds and listens at once. Throws std::runtime_error with a clear message when the
  /// address cannot be used (e.g. the port is taken).
  DashboardServer(boost::asio::io_context& io, DashboardOptions options, nlohmann::json server_info, Hooks hooks);
  ~DashboardServer();
  DashboardServer(const DashboardServer&) = delete;
  DashboardServer& operator=(const DashboardServer&) = delete;

  unsigned short port() const;
  /// The page's URL (with the token when one is required).
  std::string url() const;

  /// Send a channel message to its subscribers (in the next batch) and keep it as the
  /// channel's latest value for new subscribers; `latch_key` separates values kept side by
  /// side on one channel (the link id on netkf/link/status).
  void publish(catalogue::ChannelId channel, const nlohmann::json& message, std::uint64_t timestamp_ns,
               int latch_key = 0);
  /// A status message to every client (sent at once).
  void broadcast_status(LiveEvent::Level level, const std::string& message);
  /// A JSON message to one client (sent at once); ignored when it has gone.
  void send_to(ClientId client, const nlohmann::json& message);
  /// New parameter values to every client subscribed to any of them.
  void broadcast_parameter_values(const nlohmann::json& parameter_values);

  std::size_t client_count() const;
  std::uint64_t dropped_frames() const;
  DashboardStats stats() const;
  /// Close every connection and stop listening.
  void stop();

  struct Impl;

 private:
  std::shared_ptr<Impl> impl_;
};

}  // namespace netkf::cli
