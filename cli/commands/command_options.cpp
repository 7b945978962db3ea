#include "command_options.hpp"

#include <cmath>
#include <iostream>

#include "exit_code.hpp"

namespace netkf::cli {

void add_network_options(CLI::App* cmd, NetworkSettings& network) {
  cmd->add_option("--domain", network.domain, "DDS domain id (default: $NETKF_DOMAIN, else 0)")->check(CLI::Range(0, 232));
  cmd->add_option("--dds-profile", network.profile,
                  "Fast DDS XML profile (default: $NETKF_DDS_PROFILE, else built-in localhost-only)");
  cmd->add_option("--secure", network.secure,
                  "DDS Security: the directory made by `netkf security init` (default: $NETKF_SECURE, else none)");
  cmd->add_option("--discovery-server", network.discovery_server,
                  "Discover the network through the Fast DDS Discovery Server at ADDR:PORT, e.g. on another host "
                  "(default: $NETKF_DISCOVERY_SERVER, else the localhost-only profile; deploy/README.md)");
}

CLI::Validator timeout_seconds() {
  return CLI::Validator(
      [](std::string& v) -> std::string {
        try {
          std::size_t used = 0;
          const double s = std::stod(v, &used);
          if (used == v.size() && std::isfinite(s) && s > 0.0 && s <= 3600.0) return {};
        } catch (const std::exception&) {
        }
        return "must be a number of seconds in (0, 3600], got '" + v + "'";
      },
      "SECONDS");
}

void run_command(const std::function<int()>& body) {
  int rc = 0;
  try {
    rc = body();
  } catch (const CommandError& e) {
    std::cerr << "netkf: error: " << e.what() << "\n";
    throw CLI::RuntimeError(e.exit_status());
  }
  if (rc != 0) throw CLI::RuntimeError(rc);
}

}  // namespace netkf::cli
