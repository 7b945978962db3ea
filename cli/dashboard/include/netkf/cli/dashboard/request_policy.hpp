#pragma once
// What the dashboard's server answers to an HTTP request, decided from the request's facts
// alone (no socket): which path serves the page, its assets or /metrics, which methods are
// served, the token and Origin rules and the WebSocket handshake (foxglove.websocket.v1).
// dashboard_server.cpp reads the request, asks the policy, and writes what it decided.
// docs/dashboard.md ("Safety") describes the rules for users.
#include <chrono>
#include <cstddef>
#include <functional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace netkf::cli::dashboard {

/// A plain HTTP request (header and body) may not be larger.
inline constexpr std::size_t kHttpRequestLimit = 8 * 1024;
/// A request must arrive in full this long after its first byte (a client trickling its
/// header, "slowloris", is closed then), and a connection with no request begun (a new one, or
/// a kept-alive one after its answer) is closed after kHttpIdleTimeout.
inline constexpr std::chrono::seconds kHttpRequestTimeout{10};
inline constexpr std::chrono::seconds kHttpIdleTimeout{5};
/// The WebSocket's path (docs/dashboard.md): an upgrade on any other path is refused (404).
inline constexpr std::string_view kWebSocketPath = "/";

/// One file of the dashboard page (assets.hpp embeds them).
struct Asset {
  std::string_view path;  // URL path, e.g. "/index.html"
  std::string_view content_type;
  std::string_view body;
};

/// What the policy needs to know of a request: its line and the header fields it judges.
struct RequestFacts {
  std::string_view method;               // as sent: "GET", "HEAD", "POST", ...
  std::string_view target;               // path and query, e.g. "/metrics?token=..."
  std::string_view authorization;        // the Authorization field ("" when absent)
  std::string_view origin;               // the Origin field
  std::string_view websocket_protocols;  // Sec-WebSocket-Protocol: the subprotocols offered
  std::string_view websocket_key;        // Sec-WebSocket-Key
  bool websocket_upgrade = false;        // a WebSocket handshake (the HTTP library's reading)
  bool keep_alive = true;                // what the client asked for its connection
};

/// What to do with a request. `reply`: answer with status, fields and body; `metrics`: the
/// same with the metrics text as body; `websocket`: accept the handshake, with the fields.
struct RequestDecision {
  enum class Action { reply, metrics, websocket };
  Action action = Action::reply;
  unsigned status = 200;
  std::vector<std::pair<std::string, std::string>> fields;  // header fields, in order
  std::string body;
  bool head = false;  // HEAD: send the body's length, not the body
  bool keep_alive = false;
};

class RequestPolicy {
 public:
  using FindAsset = std::function<const Asset*(std::string_view path)>;

  /// `token`: required on every request when not empty; `origins`: those allowed to open
  /// the WebSocket (own_origins); `find_asset`: the page's files by path (nullptr: none).
  RequestPolicy(std::string token, std::set<std::string> origins, FindAsset find_asset);

  RequestDecision decide(const RequestFacts& request) const;

 private:
  /// The status and reason to refuse the request with; status 0: it may proceed.
  std::pair<unsigned, std::string> refusal(const RequestFacts& request) const;
  RequestDecision respond(const RequestFacts& request) const;

  std::string token_;
  std::set<std::string> origins_;
  FindAsset find_asset_;
};

/// The origins a browser shows for the dashboard's own page: the loopback names of `port`,
/// the bound address's (unless a wildcard), and the ones allowed on the command line.
std::set<std::string> own_origins(const std::string& bind, bool bind_is_v6, bool bind_is_wildcard, unsigned short port,
                                  const std::vector<std::string>& allowed);

/// RFC 6455, 4.1: a Sec-WebSocket-Key is the base64 of 16 bytes (24 characters, "==" last).
bool valid_websocket_key(std::string_view key);

/// A refusal worth logging (throttled: docs/dashboard.md, "Safety"): a wrong token, a foreign
/// origin, a bad handshake or request. Not a plain 404 (a browser asks for /favicon.ico).
bool worth_logging(const RequestFacts& request, const RequestDecision& decision);

/// The answer to a request that could not be read (`too_large`: over kHttpRequestLimit);
/// `reason` is the reading error's. The connection closes after it.
RequestDecision unreadable_request(bool too_large, std::string_view reason);

}  // namespace netkf::cli::dashboard
