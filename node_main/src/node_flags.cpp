// The common part of every node's main (run_node.hpp): flags, logging, participant options.
#include "netkf/node_main/run_node.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace netkf::node_main {

void add_common_node_flags(CLI::App& app, CommonNodeFlags& flags) {
  app.add_option("--scenario", flags.scenario, "Scenario YAML file")->required()->check(CLI::ExistingFile);
  app.add_option("--domain", flags.domain, "DDS domain id (default: $NETKF_DOMAIN, else 0)")
      ->check(CLI::Range(0, 232));
  app.add_option("--dds-profile", flags.dds_profile,
                 "Fast DDS XML profile file (default: $NETKF_DDS_PROFILE, else the built-in localhost-only profile)");
  app.add_option("--secure", flags.secure,
                 "DDS Security directory made by `netkf security init` (default: $NETKF_SECURE, else no security)");
  app.add_option("--run-id", flags.run_id,
                 "Run id given by `netkf launch`: samples of another run on the domain are dropped (0: none)");
  app.add_option("--discovery-server", flags.discovery_server,
                 "Discover the others through the Fast DDS Discovery Server at ADDR:PORT (default: "
                 "$NETKF_DISCOVERY_SERVER, else the localhost-only profile)");
  app.add_option("--naming", flags.naming,
                 "Topic and type names: netkf, or ros2 (rt/netkf/..., netkf_msgs; docs/ros2.md) (default: "
                 "$NETKF_NAMING, else the scenario's naming, else netkf)")
      ->check(CLI::IsMember({"netkf", "ros2"}));
  app.add_flag("--spare", flags.spare,
               "Join the DDS network, then wait for SIGUSR1 before running (a warm spare `netkf launch` activates "
               "when the running one dies)");
  app.add_option("--log-level", flags.log_level, "Log level")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
}

void setup_node_logging(const std::string& node_name, const std::string& level) {
  auto logger = spdlog::stderr_color_mt(node_name);
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e [%n] %^%l%$ %v");
  logger->set_level(spdlog::level::from_str(level));
  logger->flush_on(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

dds::ParticipantOptions node_participant_options(const CommonNodeFlags& flags, const Scenario& scenario,
                                                 const std::string& participant_name, dds::Role role) {
  dds::ParticipantOptions o;
  o.naming = dds::resolve_naming(flags.naming, scenario.naming);
  o.domain = dds::resolve_domain(flags.domain);
  o.profile_file = dds::resolve_profile(flags.dds_profile);
  o.name = participant_name;
  o.run = flags.run_id;
  o.discovery_server = dds::resolve_discovery_server(flags.discovery_server);
  if (auto dir = dds::resolve_secure(flags.secure)) o.security = dds::ParticipantOptions::Security{*dir, role};
  return o;
}

}  // namespace netkf::node_main
