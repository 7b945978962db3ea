#include "domain_guard.hpp"

#include <chrono>
#include <thread>

#include "netkf/cli/common/exit_code.hpp"
#include "netkf/cli/common/text.hpp"

namespace netkf::cli {
namespace {

/// "sensors 1,3 (pid 12 on host-a) scenario 1a2b..." for messages about another run.
std::string describe_other_run(const dds::PresenceRecord& p, std::uint64_t our_hash) {
  if (p.scenario_hash != our_hash) return p.who() + " " + p.other_scenario_text(our_hash, "this launch");
  return p.who() + " belongs to run " + hex_id(p.run);
}

}  // namespace

void guard_domain(const LiveBus& bus, const DomainGuard& g) {
  if (g.seconds <= 0) return;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(g.seconds);
  std::vector<std::pair<std::string, int>> writers;
  std::vector<dds::PresenceRecord> others;
  while (std::chrono::steady_clock::now() < until) {
    others = dds::other_runs(bus.processes(), g.run_id);
    if (g.whole_network) writers = bus.network_writers();
    if (!others.empty() || !writers.empty()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  const std::string domain = "DDS domain " + std::to_string(g.domain);
  if (!others.empty()) {
    const bool other_scenario = others.front().scenario_hash != g.scenario_hash;
    fail(ExitCode::bad_usage,
         domain + " already carries a netkf network of another run: " + describe_other_run(others.front(), g.scenario_hash) +
             (other_scenario ? "; every host of a network must run the same scenario file"
                             : "; give this run its own domain with --domain N (or NETKF_DOMAIN), or stop the "
                               "other one (hosts of one network: the same --run-id, or none)"));
  }
  if (!writers.empty()) {
    std::string found;
    for (const auto& [topic, n] : writers) found += (found.empty() ? "" : ", ") + topic + " (" + std::to_string(n) + ")";
    fail(ExitCode::bad_usage, domain + " already carries a netkf network (writers on " + found +
                                  "), e.g. another `netkf launch`: give this run its own domain with --domain N (or "
                                  "NETKF_DOMAIN), or stop the other one");
  }
}

}  // namespace netkf::cli
