// Participant ids that avoid the shared-memory ports of killed processes (participant_slot.hpp).
#include "netkf/dds/participant_slot.hpp"

#include <cerrno>
#include <string>
#include <system_error>
#include <utility>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

namespace netkf::dds {

namespace {

std::string marker_prefix(int domain) { return "netkf_participant_d" + std::to_string(domain) + "_id"; }

std::filesystem::path marker_path(const std::filesystem::path& dir, int domain, int id) {
  return dir / (marker_prefix(domain) + std::to_string(id));
}

}  // namespace

std::optional<ParticipantSlot> ParticipantSlot::claim(int domain, const std::filesystem::path& dir,
                                                      const std::set<int>& skip) {
  for (int id = 0; id < kParticipantSlots; ++id) {
    if (skip.contains(id)) continue;
    auto marker = marker_path(dir, domain, id);
    // O_EXCL: of two processes claiming at once, exactly one creates the marker.
    const int fd = ::open(marker.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) {
      if (errno == EEXIST) continue;  // held, or left by a killed process: either way not ours
      return std::nullopt;            // the directory is not usable: Fast DDS chooses
    }
    // Held for the participant's life; the kernel drops it when the process dies, which is
    // what tells a later launch that the marker is stale.
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd);
      ::unlink(marker.c_str());
      continue;
    }
    return ParticipantSlot(id, fd, std::move(marker));
  }
  return std::nullopt;
}

ParticipantSlot::ParticipantSlot(ParticipantSlot&& other) noexcept
    : id_(std::exchange(other.id_, -1)), fd_(std::exchange(other.fd_, -1)), marker_(std::move(other.marker_)) {}

ParticipantSlot& ParticipantSlot::operator=(ParticipantSlot&& other) noexcept {
  if (this != &other) {
    release();
    id_ = std::exchange(other.id_, -1);
    fd_ = std::exchange(other.fd_, -1);
    marker_ = std::move(other.marker_);
  }
  return *this;
}

ParticipantSlot::~ParticipantSlot() { release(); }

void ParticipantSlot::release() noexcept {
  if (fd_ < 0) return;
  // Unlink while still locked: nobody can mistake the marker for a stale one meanwhile.
  ::unlink(marker_.c_str());
  ::close(fd_);
  fd_ = -1;
}

int remove_stale_participant_slots(int domain, const std::filesystem::path& dir) {
  int removed = 0;
  const std::string prefix = marker_prefix(domain);
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const int fd = ::open(entry.path().c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0) continue;
    // Lockable = no live holder. (A marker created an instant ago and not yet locked may be
    // removed too: its owner keeps its id, and a clash only makes Fast DDS move one port up.)
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) {
      if (::unlink(entry.path().c_str()) == 0) ++removed;
    }
    ::close(fd);
  }
  return removed;
}

}  // namespace netkf::dds
