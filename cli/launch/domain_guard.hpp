#pragma once
// Before a launch starts anything: is its DDS domain free? Another network on the domain
// (another launch, or nodes started by hand) would mix its samples with ours.
#include <cstdint>

#include "netkf/cli/live/live_bus.hpp"

namespace netkf::cli {

struct DomainGuard {
  int domain = 0;
  std::uint64_t run_id = 0;
  std::uint64_t scenario_hash = 0;
  bool whole_network = true;  // this launch runs every role
  double seconds = 1.5;       // how long to look (0: do not)
};

/// Look for processes of another run (presence) and, for a launch of the whole network, for
/// writers of the network's topics (nothing of ours writes them yet, so any writer found is
/// someone else's; the launches of one network on several hosts share the run and write from
/// several hosts: only presence tells them apart). Throws CommandError (bad_usage) naming
/// what was found and what to do.
void guard_domain(const LiveBus& bus, const DomainGuard& guard);

}  // namespace netkf::cli
