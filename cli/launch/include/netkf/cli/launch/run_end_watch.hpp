#pragma once
// The end of the run for a process that does not run the plant (a launch of part of the
// network, a recorder), read from presence: once the plant of `run` (0: any) was seen
// running, its presence saying it ended — or its leaving — ends this process `linger`
// later, when the last periods' samples and estimates have arrived.
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "netkf/dds/presence.hpp"

namespace netkf::cli {

class RunEndWatch {
 public:
  using Clock = std::chrono::steady_clock;
  RunEndWatch(std::uint64_t run, Clock::duration linger) : run_(run), linger_(linger) {}

  void look(const std::vector<dds::PresenceRecord>& processes, Clock::time_point now);
  bool over(Clock::time_point now) const { return now >= end_at_; }
  /// Why the run ended (nullopt while it runs).
  const std::optional<std::string>& why() const { return why_; }

 private:
  std::uint64_t run_;
  Clock::duration linger_;
  bool plant_seen_ = false;
  std::optional<std::string> why_;
  Clock::time_point end_at_ = Clock::time_point::max();
};

}  // namespace netkf::cli
