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

CLI::Validator seconds_in(double min, double max, bool above_min) {
  return CLI::Validator(
      [=](std::string& v) -> std::string {
        double s = std::nan("");
        try {
          std::size_t used = 0;
          s = std::stod(v, &used);
          if (used != v.size()) s = std::nan("");
        } catch (const std::exception&) {  // not a number, or out of double's range (1e999)
        }
        const std::string problem = seconds_problem(s, min, max, above_min);
        return problem.empty() ? problem : problem + ", got '" + v + "'";
      },
      "SECONDS");
}

CLI::Validator timeout_seconds() { return seconds_in(0.0, 3600.0, /*above_min=*/true); }

CLI::Validator duration_seconds() { return seconds_in(0.0, kMaxDurationSeconds); }

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
