// The launch's private files (launch_files.hpp): stale directories of dead launches removed, and
// what `fastdds shm clean` reported. Real processes (fork), no DDS.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "launch_files.hpp"

namespace {

// A launch killed with SIGKILL leaves its directory; the next launch removes it, and only it:
// a directory whose owner runs (same pid, same start time) stays, and so does what is not a
// launch's. A pid reused by another process (another start time) does not keep it alive.
TEST(LaunchFiles, TheNextLaunchRemovesTheFilesOfDeadLaunchesOnly) {
  namespace fs = std::filesystem;
  const fs::path base = fs::path(::testing::TempDir()) / ("netkf-launch-files-" + std::to_string(getpid()));
  fs::remove_all(base);
  fs::create_directories(base);
  const pid_t dead = fork();
  if (dead == 0) _exit(0);
  int status = 0;
  waitpid(dead, &status, 0);  // reaped: no process has this pid now (until it is reused)
  const auto own_start = netkf::cli::process_start_time(getpid());
  ASSERT_TRUE(own_start.has_value());
  EXPECT_FALSE(netkf::cli::process_start_time(dead).has_value());
  const fs::path stale_dead = base / ("launch-" + std::to_string(dead) + "-12345");
  const fs::path stale_reused = base / ("launch-" + std::to_string(getpid()) + "-" + std::to_string(*own_start + 1));
  const fs::path live = base / ("launch-" + std::to_string(getppid()) + "-" +
                                std::to_string(netkf::cli::process_start_time(getppid()).value_or(0)));
  const fs::path other = base / "notes";
  for (const auto& d : {stale_dead, stale_reused, live, other}) {
    fs::create_directories(d);
    std::ofstream(d / "scenario.yaml") << "x";
  }
  {
    netkf::cli::LaunchFiles files(base);
    EXPECT_TRUE(fs::is_directory(files.dir()));
    EXPECT_EQ(files.dir().parent_path(), base);
    EXPECT_EQ(fs::status(files.dir()).permissions() & fs::perms::all, fs::perms::owner_all);
    EXPECT_FALSE(fs::exists(stale_dead));
    EXPECT_FALSE(fs::exists(stale_reused));
    EXPECT_TRUE(fs::exists(live / "scenario.yaml"));
    EXPECT_TRUE(fs::exists(other / "scenario.yaml"));
    EXPECT_EQ(files.removed_stale().size(), 2u);
    std::ofstream(files.file("scenario.yaml")) << "y";
    EXPECT_TRUE(fs::exists(files.file("scenario.yaml")));
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(base), fs::directory_iterator()), 2);  // live and other
  fs::remove_all(base);
}

TEST(LaunchFiles, ReadsWhatFastDdsShmCleanRemoved) {
  const auto r = netkf::cli::parse_shm_clean_report(
      "shm.clean:\n3 ports in use\n2 segments in use\n4 zombie ports cleaned\n1 zombie segments cleaned\n");
  EXPECT_TRUE(r.ran);
  EXPECT_EQ(r.zombie_ports, 4);
  EXPECT_EQ(r.zombie_segments, 1);
  EXPECT_FALSE(netkf::cli::parse_shm_clean_report("fastdds: command not found").ran);
}

}  // namespace
