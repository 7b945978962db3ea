#include "netkf/records/link_change.hpp"

namespace netkf {

const char* to_string(LinkChange::Origin origin) {
  return origin == LinkChange::Origin::request ? "request" : "timeline";
}

std::optional<LinkChange::Origin> parse_link_change_origin(std::string_view text) {
  if (text == "request") return LinkChange::Origin::request;
  if (text == "timeline") return LinkChange::Origin::timeline;
  return std::nullopt;
}

}  // namespace netkf
