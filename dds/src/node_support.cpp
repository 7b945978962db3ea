#include "netkf/dds/node_support.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <csignal>
#include <cstdlib>

namespace netkf::dds {

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

ParticipantOptions node_participant_options(const CommonNodeFlags& flags, const Scenario& scenario,
                                            const std::string& participant_name, Role role) {
  ParticipantOptions o;
  o.naming = resolve_naming(flags.naming, scenario.naming);
  o.domain = resolve_domain(flags.domain);
  o.profile_file = resolve_profile(flags.dds_profile);
  o.name = participant_name;
  o.run = flags.run_id;
  o.discovery_server = resolve_discovery_server(flags.discovery_server);
  if (auto dir = resolve_secure(flags.secure)) o.security = ParticipantOptions::Security{*dir, role};
  return o;
}

std::optional<DiscoveryServerAddress> resolve_discovery_server(const std::optional<std::string>& flag) {
  if (flag && !flag->empty()) return parse_discovery_server(*flag);
  if (const char* env = std::getenv(kDiscoveryServerEnv); env != nullptr && *env != '\0')
    return parse_discovery_server(env);
  return std::nullopt;
}

namespace {
sigset_t spare_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGUSR1);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}
}  // namespace

SpareGate::SpareGate(bool spare) : spare_(spare) {
  if (!spare_) return;
  const sigset_t set = spare_signals();
  pthread_sigmask(SIG_BLOCK, &set, &previous_);
}

SpareGate::~SpareGate() {
  if (spare_ && !restored_) pthread_sigmask(SIG_SETMASK, &previous_, nullptr);
}

bool SpareGate::wait_until_needed() {
  if (!spare_) return true;
  const sigset_t set = spare_signals();
  int sig = 0;
  while (sigwait(&set, &sig) != 0) {
  }
  // The threads started meanwhile (DDS) keep the signals blocked: SIGINT/SIGTERM reach this
  // thread from now on, where the node's signal handling (StopOnSignal) takes them.
  pthread_sigmask(SIG_SETMASK, &previous_, nullptr);
  restored_ = true;
  if (sig == SIGUSR1) {
    spdlog::info("spare: activated, taking over");
    return true;
  }
  spdlog::info("spare: signal {} before it was needed; leaving", sig);
  return false;
}

StopOnSignal::StopOnSignal(boost::asio::io_context& io, std::function<void(int)> on_stop)
    : signals_(io, SIGINT, SIGTERM) {
  signals_.async_wait([&io, on_stop = std::move(on_stop)](const boost::system::error_code& ec, int sig) {
    if (ec) return;
    spdlog::info("signal {}: stopping", sig);
    if (on_stop) on_stop(sig);
    io.stop();
  });
}

WhenMatched::WhenMatched(boost::asio::io_context& io, std::function<bool()> matched, std::chrono::milliseconds limit,
                         std::function<void(bool)> then)
    : timer_(io),
      matched_(std::move(matched)),
      then_(std::move(then)),
      started_(std::chrono::steady_clock::now()),
      deadline_(started_ + limit) {
  schedule(std::chrono::milliseconds(0));
}

std::chrono::milliseconds WhenMatched::waited() const {
  return std::chrono::duration_cast<std::chrono::milliseconds>(ended_.value_or(std::chrono::steady_clock::now()) -
                                                               started_);
}

// The timer, not a post: destroying it cancels the next poll.
void WhenMatched::schedule(std::chrono::milliseconds after) {
  timer_.expires_after(after);
  timer_.async_wait([this](const boost::system::error_code& ec) {
    if (!ec) poll();
  });
}

void WhenMatched::poll() {
  if (ended_) return;
  const bool matched = matched_();
  if (!matched && std::chrono::steady_clock::now() < deadline_) {
    schedule(std::chrono::milliseconds(2));
    return;
  }
  ended_ = std::chrono::steady_clock::now();
  then_(matched);
}

}  // namespace netkf::dds
