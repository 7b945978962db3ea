#pragma once
// Presence: every process of a run (plant, sensor processes, channel, estimator, each launch,
// each recorder) announces itself on netkf/presence — role, sensor ids, host, pid, the hash of
// the scenario it loaded, its run id, running or ended. It replaces counting processes by hand
// across hosts: the plant starts when the whole scenario is present (assess_readiness), a
// process with another scenario is named, and a launch that does not run the plant ends when
// the plant's presence says the run has ended (docs/architecture.md, "Several hosts").
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <fastdds/dds/subscriber/DataReader.hpp>

#include "netkf/dds/endpoints.hpp"
#include "netkf/dds/participant.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::dds {

/// What every process of a run publishes its presence as.
namespace presence_role {
inline constexpr const char* plant = "plant";
inline constexpr const char* sensors = "sensors";
inline constexpr const char* channel = "channel";
inline constexpr const char* estimator = "estimator";
inline constexpr const char* launch = "launch";
inline constexpr const char* record = "record";
}  // namespace presence_role

/// How the plant's ended presence begins when a closed loop left plant.state_bound: the launches
/// of the run (on any host) read it as a diverged run (PresenceRecord::diverged).
inline constexpr const char* kPlantDiverged = "the closed loop diverged";

/// One process of the network as its presence describes it.
struct PresenceRecord {
  std::string host;
  int pid = 0;
  std::string role;
  std::vector<int> sensor_ids;
  std::uint64_t scenario_hash = 0;
  std::uint64_t run = 0;
  bool ended = false;   // it said the run is over for it
  bool alive = true;    // false once its writer left (the process ended, was killed or lost)
  std::string detail;
  /// "channel (pid 42 on host-b)", "sensors 1,3 (pid 7 on host-a)".
  std::string who() const;
  /// Taking part in the run now: alive and not ended.
  bool running() const { return alive && !ended; }
  /// The plant said the closed loop left plant.state_bound (kPlantDiverged).
  bool diverged() const { return ended && role == presence_role::plant && detail.rfind(kPlantDiverged, 0) == 0; }
  /// "loaded another scenario (hash 1a2b…; this launch's 3c4d…)": `ours` names whose hash
  /// `our_hash` is ("this launch", "this process").
  std::string other_scenario_text(std::uint64_t our_hash, const std::string& ours) const;
};

/// FNV-1a (64 bit) of the scenario as loaded, written out canonically (scenario_to_yaml): the
/// same scenario gives the same hash whatever the file's layout, comments or name on disk.
std::uint64_t scenario_hash(const Scenario& scenario);
/// This host's name (gethostname), as presence carries it.
std::string this_host();

/// Publishes this process's presence (transient-local: a process that joins later still sees
/// it) until destroyed; its writer leaving tells the others it is gone.
class PresenceAnnouncer {
 public:
  /// Throws DdsError when the writer cannot be created (e.g. DDS Security permissions made
  /// before the presence topic existed: `netkf security init` again).
  PresenceAnnouncer(Participant& participant, std::string role, std::vector<int> sensor_ids,
                    std::uint64_t scenario_hash, std::string detail = {});
  /// Say that this process has ended its part of the run (the plant: the run is over).
  void end(const std::string& why);

 private:
  Writer<wire::Presence> writer_;
  wire::Presence sample_;
};

/// The presence of every process seen on the domain (any run). Thread-safe.
class PresenceWatcher {
 public:
  explicit PresenceWatcher(Participant& participant);
  ~PresenceWatcher();
  PresenceWatcher(const PresenceWatcher&) = delete;
  PresenceWatcher& operator=(const PresenceWatcher&) = delete;

  /// Every process seen so far (gone ones stay, with alive false). Read from the reader's
  /// history each time (one sample per process is kept), so the instance state is current: a
  /// process whose writer left — it ended, was killed, or its host was lost (after the DDS lease)
  /// — reads as not alive.
  std::vector<PresenceRecord> processes() const;
  /// Presence writers (announcing processes) currently matched: once processes() holds a live
  /// record for each, every process discovered so far has been heard.
  int announcers() const;

 private:
  Participant& participant_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  mutable std::mutex mutex_;  // DataReader::read is thread-safe; this keeps the loans simple
};

/// Whether the processes a run needs are present (DDS-free; the plant polls it before period 0).
struct Readiness {
  bool ready = false;
  /// What is not there yet: "sensor 3", "the channel emulator", "the estimator".
  std::vector<std::string> missing;
  /// A process of this run that loaded another scenario: why the run must not start.
  std::optional<std::string> conflict;
  /// Present processes that read the truth (sensor processes, launches, recorders): the truth
  /// writer waits until it has matched that many readers.
  int truth_readers = 0;
};
/// `processes`: what a PresenceWatcher saw. A process belongs to this run when its run id equals
/// `run`, or when either is 0 (a process started by hand). Needed: every sensor of
/// `sensor_ids`, a channel and an estimator, running.
Readiness assess_readiness(const std::vector<PresenceRecord>& processes, const std::vector<int>& sensor_ids,
                           std::uint64_t run, std::uint64_t scenario_hash);

/// Processes of another run on the domain (another network, or a host that loaded another
/// scenario and so derived another run id), running now; empty when there are none.
std::vector<PresenceRecord> other_runs(const std::vector<PresenceRecord>& processes, std::uint64_t run);

}  // namespace netkf::dds
