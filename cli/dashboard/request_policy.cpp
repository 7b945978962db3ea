#include "netkf/cli/dashboard/request_policy.hpp"

#include <map>

#include "netkf/cli/dashboard/dashboard_protocol.hpp"

namespace netkf::cli::dashboard {

namespace {

constexpr const char* kPlainText = "text/plain; charset=utf-8";

struct Target {
  std::string path;
  std::map<std::string, std::string> query;
};

Target split_target(std::string_view target) {
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

bool offers_subprotocol(std::string_view header, const std::string& wanted) {
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

void plain_text(RequestDecision& d, unsigned status, std::string body) {
  d.status = status;
  d.fields.emplace_back("Content-Type", kPlainText);
  d.body = std::move(body);
}

}  // namespace

RequestPolicy::RequestPolicy(std::string token, std::set<std::string> origins, FindAsset find_asset)
    : token_(std::move(token)), origins_(std::move(origins)), find_asset_(std::move(find_asset)) {}

std::pair<unsigned, std::string> RequestPolicy::refusal(const RequestFacts& request) const {
  if (!token_.empty()) {
    const auto target = split_target(request.target);
    std::string given;
    if (auto it = target.query.find("token"); it != target.query.end()) given = it->second;
    const std::string auth(request.authorization);
    if (given.empty() && auth.rfind("Bearer ", 0) == 0) given = auth.substr(7);
    if (!same_secret(given, token_))
      return {401, "this dashboard needs the token printed by netkf launch (?token=... in the URL)"};
  }
  if (request.websocket_upgrade) {
    // A web page of another site open in the same browser must not retune links: only
    // the dashboard's own origin (and those allowed on the command line) may connect.
    // Clients that send no Origin (desktop apps, scripts) are served.
    const std::string origin(request.origin);
    if (!origin.empty() && !origins_.count(origin))
      return {403, "origin '" + origin.substr(0, 200) +
                       "' is not allowed (netkf launch --dashboard-allow-origin ORIGIN allows it)"};
    if (split_target(request.target).path != kWebSocketPath)
      return {404, "the WebSocket is at " + std::string(kWebSocketPath)};
    if (!offers_subprotocol(request.websocket_protocols, kSubprotocol))
      return {400, std::string("this WebSocket speaks the subprotocol ") + kSubprotocol};
    if (!valid_websocket_key(request.websocket_key))
      return {400, "the Sec-WebSocket-Key is not the base64 of 16 bytes (RFC 6455)"};
  }
  return {0, {}};
}

RequestDecision RequestPolicy::decide(const RequestFacts& request) const {
  if (!request.websocket_upgrade) return respond(request);
  RequestDecision d;
  if (auto [status, reason] = refusal(request); status != 0) {
    // A refused handshake is answered plainly and the connection closed.
    plain_text(d, status, reason + "\n");
    return d;
  }
  d.action = RequestDecision::Action::websocket;
  d.status = 101;
  d.fields = {{"Sec-WebSocket-Protocol", kSubprotocol}, {"Server", "netkf"}};
  d.keep_alive = true;
  return d;
}

RequestDecision RequestPolicy::respond(const RequestFacts& request) const {
  RequestDecision d;
  d.fields = {{"Server", "netkf"}, {"X-Content-Type-Options", "nosniff"}};
  d.keep_alive = request.keep_alive;
  if (auto [status, reason] = refusal(request); status != 0) {
    plain_text(d, status, reason + "\n");
    return d;
  }
  if (request.method != "GET" && request.method != "HEAD") {
    plain_text(d, 405, "only GET is served here\n");
    d.fields.emplace_back("Allow", "GET, HEAD");
    return d;
  }
  d.head = request.method == "HEAD";
  const auto target = split_target(request.target);
  const Asset* asset = nullptr;
  if (target.path == "/metrics") {
    d.action = RequestDecision::Action::metrics;
    d.fields.emplace_back("Content-Type", "text/plain; version=0.0.4; charset=utf-8");
  } else if (find_asset_ && (asset = find_asset_(target.path == "/" ? "/index.html" : target.path))) {
    d.fields.emplace_back("Content-Type", std::string(asset->content_type));
    // The page must not be framed by another site (it has link controls).
    d.fields.emplace_back("X-Frame-Options", "DENY");
    d.fields.emplace_back("Cache-Control", "no-cache");
    d.body = std::string(asset->body);
  } else {
    plain_text(d, 404, "not found\n");
  }
  return d;
}

std::set<std::string> own_origins(const std::string& bind, bool bind_is_v6, bool bind_is_wildcard, unsigned short port,
                                  const std::vector<std::string>& allowed) {
  const auto p = std::to_string(port);
  std::set<std::string> origins{"http://127.0.0.1:" + p, "http://localhost:" + p, "http://[::1]:" + p};
  if (!bind_is_wildcard) origins.insert("http://" + (bind_is_v6 ? "[" + bind + "]" : bind) + ":" + p);
  origins.insert(allowed.begin(), allowed.end());
  return origins;
}

bool valid_websocket_key(std::string_view key) {
  // 16 bytes: 5 groups of 4 characters, then 2 characters and "==".
  if (key.size() != 24 || key.substr(22) != "==") return false;
  auto base64 = [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '/';
  };
  for (std::size_t i = 0; i < 22; ++i)
    if (!base64(key[i])) return false;
  return true;
}

bool worth_logging(const RequestFacts& request, const RequestDecision& decision) {
  return decision.status >= 400 && (decision.status != 404 || request.websocket_upgrade);
}

RequestDecision unreadable_request(bool too_large, std::string_view reason) {
  RequestDecision d;
  plain_text(d, too_large ? 413 : 400, "bad request: " + std::string(reason) + "\n");
  return d;
}

}  // namespace netkf::cli::dashboard
