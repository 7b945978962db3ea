#pragma once
// The files a launch keeps while it runs (the effective scenario its children read, the
// estimator's checkpoint), in a private directory of its own that it removes when it ends.
// A launch killed with SIGKILL cannot remove it; the next launch of the same user does:
// each directory is named after its owner's pid and start time, and one whose owner is no
// longer running is removed. Stale Fast DDS shared-memory files (left by a process killed
// with SIGKILL) are removed by Fast DDS's own tool, `fastdds shm clean`, which removes only
// segments and ports no live process holds. No DDS here, so it is testable alone.
#include <sys/types.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace netkf::cli {

/// Where the launches of this user keep their directories: $XDG_RUNTIME_DIR/netkf when that
/// is set, else <temp>/netkf-<uid>.
std::filesystem::path launch_files_base();

/// A process's start time (clock ticks since boot, /proc/PID/stat field 22); nullopt when
/// no such process runs.
std::optional<unsigned long long> process_start_time(pid_t pid);

class LaunchFiles {
 public:
  /// Create BASE/launch-<pid>-<start time> (mode 0700) after removing the directories of
  /// launches that are no longer running. Throws std::runtime_error with the reason.
  explicit LaunchFiles(const std::filesystem::path& base = launch_files_base());
  ~LaunchFiles();  // removes the directory and everything in it
  LaunchFiles(const LaunchFiles&) = delete;
  LaunchFiles& operator=(const LaunchFiles&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  std::filesystem::path file(const std::string& name) const { return dir_ / name; }
  /// Directories of dead launches removed at creation.
  const std::vector<std::filesystem::path>& removed_stale() const { return removed_stale_; }

 private:
  std::filesystem::path dir_;
  std::vector<std::filesystem::path> removed_stale_;
};

/// What `fastdds shm clean` removed.
struct SharedMemoryClean {
  bool ran = false;  // false: the tool is not installed (or could not run)
  int zombie_segments = 0;
  int zombie_ports = 0;
};
/// Run `fastdds shm clean` (Fast DDS's clean-up of shared-memory files no live process
/// holds). Never throws.
SharedMemoryClean clean_stale_shared_memory();
/// Parse the tool's report ("N zombie ports cleaned", "M zombie segments cleaned").
SharedMemoryClean parse_shm_clean_report(const std::string& text);

}  // namespace netkf::cli
