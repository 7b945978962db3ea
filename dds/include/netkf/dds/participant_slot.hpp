#pragma once
// Which Fast DDS participant id a new participant of this host takes.
//
// Why netkf picks it instead of Fast DDS: Fast DDS 2.9's shared-memory transport gives the
// participant with id N the port 7411 + 250·domain + 2N (the RTPS well-known user unicast
// port). A process killed with its port open leaves the port behind with a listener that
// never answers. The next participant to open that port (a restarted node, which Fast DDS's
// automatic id walks to once the lower ports are taken) waits for the port's health check
// (1 s), removes it and makes a new one, while the writers that outlived the killed process
// keep sending into the removed one: the restarted node hears nothing for seconds, sometimes
// for the rest of the run (upstream eProsima/Fast-DDS#5053; the fix, #4728, is not in 2.9).
// docs/dds-notes.md, "A restarted process and shared memory".
//
// So every participant holds a marker file per (domain, id), locked while it lives and
// removed when it leaves cleanly. A marker that exists but is not locked was left by a killed
// process: its id is skipped until a launch removes such markers, at its start and its end,
// together with Fast DDS's own stale files (`fastdds shm clean`).
#include <filesystem>
#include <optional>
#include <set>

namespace netkf::dds {

/// Where the markers live: beside Fast DDS's own shared-memory files, so they are exactly as
/// shared (network namespaces do not separate them) and gone after a reboot.
inline const std::filesystem::path kParticipantSlotDir = "/dev/shm";

/// Participant ids netkf hands out: those whose ports the localhost profile's initial peers
/// cover (UDPv4 maxInitialPeersRange 128).
inline constexpr int kParticipantSlots = 128;

/// A claimed participant id, held (file lock) until destroyed; destruction removes the marker.
class ParticipantSlot {
 public:
  /// The lowest id of `domain` without a marker (neither held nor left by a killed process);
  /// nullopt when all kParticipantSlots are taken or the directory is not writable (the caller
  /// then lets Fast DDS choose).
  /// `skip`: ids not to take (Fast DDS wants an id unique in the process, whatever the domain:
  /// those of this process's other participants).
  static std::optional<ParticipantSlot> claim(int domain, const std::filesystem::path& dir = kParticipantSlotDir,
                                              const std::set<int>& skip = {});

  ParticipantSlot(ParticipantSlot&& other) noexcept;
  ParticipantSlot& operator=(ParticipantSlot&& other) noexcept;
  ParticipantSlot(const ParticipantSlot&) = delete;
  ParticipantSlot& operator=(const ParticipantSlot&) = delete;
  ~ParticipantSlot();

  int id() const { return id_; }

 private:
  ParticipantSlot(int id, int fd, std::filesystem::path marker) : id_(id), fd_(fd), marker_(std::move(marker)) {}
  void release() noexcept;

  int id_ = -1;
  int fd_ = -1;
  std::filesystem::path marker_;
};

/// Remove the markers of `domain` that no live process holds (left by killed processes);
/// returns how many. Call it only where no writer of this host can still hold the killed
/// process's port open (the start and the end of a launch).
int remove_stale_participant_slots(int domain, const std::filesystem::path& dir = kParticipantSlotDir);

}  // namespace netkf::dds
