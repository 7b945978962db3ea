#pragma once
// The channel emulator's links (docs/architecture.md, "channel_emulator"): one seeded loss process per
// sensor, tunable at runtime. A change applies from the next sample on.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "netkf/loss_model.hpp"
#include "netkf/scenario.hpp"

namespace netkf::nodes {

/// What one link is and did (since its current model was set).
struct LinkReport {
  int sensor_id = 0;
  LinkModel model;
  LinkStatistics stats;     // since the current model was set
  LinkStatistics lifetime;  // since the channel started (not reset by a change)
  std::uint64_t last_request_id = 0;
  bool last_request_rejected = false;
  std::string reject_reason;
};

/// The answer to one change request.
struct LinkChangeResult {
  std::uint64_t request_id = 0;
  int sensor_id = 0;
  bool applied = false;
  std::string reason;  // empty when applied
};

class ChannelLinks {
 public:
  enum class Verdict { delivered, dropped, unknown_sensor };

  /// One link per scenario sensor; link i draws from derive_seed(seed, "link", i).
  explicit ChannelLinks(const Scenario& scenario);

  /// Decide the fate of the next sample of `sensor_id` (advances that link's process).
  Verdict on_sample(int sensor_id);

  /// Replace a link's model from the next sample on; statistics restart so they describe
  /// the new model. Invalid models / unknown sensors change nothing and are rejected.
  LinkChangeResult apply(std::uint64_t request_id, int sensor_id, const LinkModel& model);
  /// Record a request that could not even be decoded (e.g. unknown model name).
  LinkChangeResult reject(std::uint64_t request_id, int sensor_id, const std::string& reason);

  std::vector<LinkReport> reports() const;
  const LinkReport* report(int sensor_id) const;
  std::uint64_t unknown_sensor_samples() const { return unknown_sensor_samples_; }

 private:
  struct Link {
    LinkLossProcess process;
    LinkReport report;
  };
  std::map<int, Link> links_;
  std::uint64_t unknown_sensor_samples_ = 0;
};

}  // namespace netkf::nodes
