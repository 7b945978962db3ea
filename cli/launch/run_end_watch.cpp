#include "netkf/cli/launch/run_end_watch.hpp"

namespace netkf::cli {

void RunEndWatch::look(const std::vector<dds::PresenceRecord>& processes, Clock::time_point now) {
  if (why_) return;
  bool running = false;
  const dds::PresenceRecord* gone = nullptr;  // a plant of the run that ended or left
  for (const auto& p : processes) {
    if (p.role != dds::presence_role::plant || (run_ != 0 && p.run != run_)) continue;
    if (p.running()) running = true;
    else gone = &p;
  }
  plant_seen_ = plant_seen_ || running;
  if (!plant_seen_ || running || gone == nullptr) return;
  const std::string plant = "the plant (pid " + std::to_string(gone->pid) + " on " + gone->host + ")";
  why_ = gone->ended ? plant + " ended the run" + (gone->detail.empty() ? "" : ": " + gone->detail)
                     : plant + " left the network";
  end_at_ = now + linger_;
}

}  // namespace netkf::cli
