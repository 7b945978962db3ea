// Fuzzes the dashboard's parser of client messages (cli/dashboard/dashboard_protocol.cpp) on
// arbitrary text, as a WebSocket client can send: it must return a message or throw
// ProtocolError. A setParameters it accepts is then judged against two links as the
// server does (link_changes), which must refuse or yield a valid link, never throw.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>
#include <variant>

#include "netkf/cli/dashboard/dashboard_protocol.hpp"
#include "netkf/links/link.hpp"

namespace {

namespace dashboard = netkf::cli::dashboard;

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz_dashboard_message: %s\n", what);
  std::abort();
}

std::vector<netkf::cli::LinkView> links() {
  std::vector<netkf::cli::LinkView> out(2);
  out[0].sensor_id = 1;
  out[0].link = netkf::LinkSpec(netkf::BernoulliLink{0.1});
  out[1].sensor_id = 2;
  out[1].link = netkf::LinkSpec(netkf::GilbertElliottLink{0.05, 0.4, 0.0, 1.0}, {3.0, 1.0, netkf::DelayDistribution::normal});
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  dashboard::ClientMessage message;
  try {
    message = dashboard::parse_client_message(text);
  } catch (const dashboard::ProtocolError&) {
    return 0;
  }
  static const std::vector<netkf::cli::LinkView> current = links();
  if (const auto* set = std::get_if<dashboard::SetParameters>(&message)) {
    for (const auto& change : dashboard::link_changes(*set, current)) {
      if (change.keys.has_value() == !change.refusal.empty()) finding("a link change is both refused and applied, or neither");
      if (change.keys) {
        try {
          netkf::validate_link(change.link);
        } catch (const netkf::LinkError&) {
          finding("an accepted link change yields an invalid link");
        }
      }
    }
  } else if (const auto* get = std::get_if<dashboard::GetParameters>(&message)) {
    (void)dashboard::parameter_values(current, get->names, get->id).dump();
  }
  return 0;
}
