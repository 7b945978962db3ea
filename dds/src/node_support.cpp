#include "netkf/dds/node_support.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <csignal>
#include <cstdlib>

namespace netkf::dds {

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
