// A process killed with kill -9 and started again must hear the writers that outlived it.
// Fast DDS 2.9's shared-memory transport breaks that when the new process takes the killed
// one's port (dds/include/netkf/dds/participant_slot.hpp): netkf's participants therefore
// claim ids through markers that a killed process leaves behind.
//
// The processes are this test binary started again (posix_spawn of /proc/self/exe) with a
// gtest filter for one of the DISABLED_ child cases below: a fresh process, never a fork of
// one that already runs Fast DDS threads. Runs inside scripts/in-netns.sh.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "netkf/dds/dds.hpp"
#include "netkf/dds/participant_slot.hpp"

extern char** environ;

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

int test_domain() { return 1 + static_cast<int>(::getpid() % 200); }

/// A temporary directory for marker files (not /dev/shm: these tests must not touch the
/// markers of real participants).
struct TempDir {
  fs::path path;
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "netkf-slot-XXXXXX").string();
    path = ::mkdtemp(pattern.data());
  }
  ~TempDir() { fs::remove_all(path); }
};

/// This test binary again, running one child case, with `env` added to the environment.
pid_t spawn_child(const std::string& test, const std::vector<std::string>& env) {
  const std::string filter = "--gtest_filter=" + test;
  std::vector<std::string> args = {"/proc/self/exe", filter, "--gtest_also_run_disabled_tests"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> envs(env);
  for (char** e = environ; *e; ++e) envs.emplace_back(*e);
  std::vector<char*> envp;
  for (auto& e : envs) envp.push_back(e.data());
  envp.push_back(nullptr);
  pid_t pid = -1;
  if (::posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, argv.data(), envp.data()) != 0) return -1;
  return pid;
}

/// Wait up to `timeout` for `pid`; its exit code, or nullopt (still running: then killed).
std::optional<int> wait_exit(pid_t pid, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  int status = 0;
  while (std::chrono::steady_clock::now() < end) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    std::this_thread::sleep_for(20ms);
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return std::nullopt;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

bool wait_for_file(const fs::path& p, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (fs::exists(p)) return true;
    std::this_thread::sleep_for(20ms);
  }
  return false;
}

bool marker_is_held(const fs::path& marker) {
  const int fd = ::open(marker.c_str(), O_RDWR);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0;
  ::close(fd);
  return held;
}

const char* env_or(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v ? v : fallback;
}

}  // namespace

// ---- child cases (run only when spawned by the tests below) -----------------------------

// Claims a slot in $NETKF_TEST_SLOT_DIR, reports its id, then dies by SIGKILL (no clean-up).
TEST(RestartChild, DISABLED_ClaimSlotAndDie) {
  auto slot = netkf::dds::ParticipantSlot::claim(std::atoi(env_or("NETKF_TEST_DOMAIN", "0")), env_or("NETKF_TEST_SLOT_DIR", ""));
  ASSERT_TRUE(slot.has_value());
  std::ofstream(env_or("NETKF_TEST_REPORT", "/dev/null")) << slot->id() << "\n";
  ::kill(::getpid(), SIGKILL);
}

// A reader of netkf/measurement/raw on $NETKF_TEST_DOMAIN. Once it has received
// $NETKF_TEST_WANT samples it writes "<participant id> <ms from creation to the first sample>
// <k of every sample received...>" to $NETKF_TEST_REPORT and then, with NETKF_TEST_LINGER=1,
// waits to be killed; otherwise it passes (exit 0). Fails (exit 1) after 20 s without them.
TEST(RestartChild, DISABLED_ReadSamples) {
  netkf::dds::ParticipantOptions o;
  o.domain = std::atoi(env_or("NETKF_TEST_DOMAIN", "0"));
  o.name = "restart-reader";
  netkf::dds::Participant participant(o);
  const auto want = static_cast<std::size_t>(std::atoi(env_or("NETKF_TEST_WANT", "20")));
  const auto created = std::chrono::steady_clock::now();
  std::mutex mutex;
  std::vector<std::uint64_t> ks;
  long long first_ms = -1;
  netkf::dds::Reader<netkf::wire::Measurement> reader(
      participant, netkf::dds::topics::raw_measurement, [&](netkf::wire::Measurement&& m) {
        const std::lock_guard lock(mutex);
        if (ks.empty())
          first_ms =
              std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - created).count();
        ks.push_back(m.k());
      });
  const auto end = created + 20s;
  while (reader.received() < want && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(10ms);
  ASSERT_GE(reader.received(), want) << "no " << want << " samples within 20 s";
  {
    const std::lock_guard lock(mutex);
    const std::string report = env_or("NETKF_TEST_REPORT", "/dev/null");
    {
      std::ofstream out(report + ".tmp");
      out << participant.participant_id() << " " << first_ms;
      for (const auto k : ks) out << " " << k;
      out << "\n";
    }
    fs::rename(report + ".tmp", report);
  }
  if (std::string(env_or("NETKF_TEST_LINGER", "0")) == "1") {
    for (;;) std::this_thread::sleep_for(1s);
  }
  // Returning leaves the domain cleanly (the participant removes its marker); gtest exits 0.
}

// ---- the tests --------------------------------------------------------------------------

TEST(ParticipantSlot, ClaimsTheLowestFreeIdAndSkipsTheOneAKilledProcessLeft) {
  TempDir dir;
  const int domain = 7;
  std::optional<netkf::dds::ParticipantSlot> a = netkf::dds::ParticipantSlot::claim(domain, dir.path);
  std::optional<netkf::dds::ParticipantSlot> b = netkf::dds::ParticipantSlot::claim(domain, dir.path);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->id(), 0);
  EXPECT_EQ(b->id(), 1);
  EXPECT_EQ(netkf::dds::ParticipantSlot::claim(domain + 1, dir.path)->id(), 0) << "another domain has its own ids";
  a.reset();  // left cleanly: its marker is gone and its id is free again
  EXPECT_FALSE(fs::exists(dir.path / "netkf_participant_d7_id0"));

  // A process that claims id 0 and is killed leaves its marker, unlocked.
  const fs::path report = dir.path / "child-id";
  const pid_t child = spawn_child("RestartChild.DISABLED_ClaimSlotAndDie",
                                  {"NETKF_TEST_DOMAIN=7", "NETKF_TEST_SLOT_DIR=" + dir.path.string(),
                                   "NETKF_TEST_REPORT=" + report.string()});
  ASSERT_GT(child, 0);
  const auto rc = wait_exit(child, 30s);
  ASSERT_TRUE(rc.has_value());
  EXPECT_EQ(*rc, 128 + SIGKILL);
  EXPECT_EQ(std::stoi(read_file(report)), 0);
  const fs::path stale = dir.path / "netkf_participant_d7_id0";
  ASSERT_TRUE(fs::exists(stale));
  EXPECT_FALSE(marker_is_held(stale));
  EXPECT_TRUE(marker_is_held(dir.path / "netkf_participant_d7_id1")) << "a live claim holds its marker";

  // Its id is not handed out again until the stale marker is removed...
  auto c = netkf::dds::ParticipantSlot::claim(domain, dir.path);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->id(), 2);
  // ...which removes only markers nobody holds.
  EXPECT_EQ(netkf::dds::remove_stale_participant_slots(domain, dir.path), 1);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(dir.path / "netkf_participant_d7_id1"));
  EXPECT_EQ(netkf::dds::ParticipantSlot::claim(domain, dir.path)->id(), 0);
}

TEST(ParticipantSlot, AllTakenOrNoDirectoryLetsFastDdsChoose) {
  TempDir dir;
  std::vector<netkf::dds::ParticipantSlot> all;
  for (int i = 0; i < netkf::dds::kParticipantSlots; ++i) all.push_back(*netkf::dds::ParticipantSlot::claim(3, dir.path));
  EXPECT_EQ(all.back().id(), netkf::dds::kParticipantSlots - 1);
  EXPECT_FALSE(netkf::dds::ParticipantSlot::claim(3, dir.path).has_value());
  EXPECT_FALSE(netkf::dds::ParticipantSlot::claim(3, dir.path / "missing").has_value());
}

struct ReaderReport {
  int participant_id = -1;
  long long first_sample_ms = -1;
  std::set<std::uint64_t> periods;
};

ReaderReport read_report(const fs::path& p) {
  ReaderReport r;
  std::istringstream in(read_file(p));
  in >> r.participant_id >> r.first_sample_ms;
  for (std::uint64_t k; in >> k;) r.periods.insert(k);
  return r;
}

// The topic is reliable: every sample the writer publishes after it matched the restarted
// reader is owed to that reader. Before netkf chose participant ids, the restarted reader took
// the killed one's shared-memory port and the writer's samples went into the removed port for
// seconds, more than its history holds: whole stretches never arrived.
TEST(DdsRestart, AReaderRestartedAfterKill9ReceivesEverySampleWrittenAfterItMatched) {
  const int domain = test_domain();
  const std::string domain_env = "NETKF_TEST_DOMAIN=" + std::to_string(domain);
  TempDir dir;
  netkf::dds::ParticipantOptions o;
  o.domain = domain;
  o.name = "restart-writer";
  netkf::dds::Participant participant(o);
  netkf::dds::Writer<netkf::wire::Measurement> writer(participant, netkf::dds::topics::raw_measurement);
  // A fast sensor: one sample every 2 ms, so the writer's history (256) spans about 0.5 s.
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> last_written{0};
  std::thread sensor([&] {
    for (std::uint64_t k = 1; !stop.load(); ++k) {
      writer.write(netkf::dds::make_measurement(1, k, netkf::dds::steady_now_ns(), netkf::Vector{{0.5}}));
      last_written = k;
      std::this_thread::sleep_for(2ms);
    }
  });
  struct Join {
    std::atomic<bool>& stop;
    std::thread& t;
    ~Join() {
      stop = true;
      t.join();
    }
  } join{stop, sensor};

  // The first reader receives, then is killed with its shared-memory port open.
  const fs::path first_report = dir.path / "first";
  const pid_t first = spawn_child("RestartChild.DISABLED_ReadSamples",
                                  {domain_env, "NETKF_TEST_WANT=10", "NETKF_TEST_LINGER=1",
                                   "NETKF_TEST_REPORT=" + first_report.string()});
  ASSERT_GT(first, 0);
  ASSERT_TRUE(wait_for_file(first_report, 30s)) << "the first reader never received 10 samples";
  ::kill(first, SIGKILL);
  ASSERT_EQ(wait_exit(first, 10s), 128 + SIGKILL);
  // The killed reader stays matched until its lease runs out (20 s): the restarted one is the
  // second match.
  ASSERT_EQ(writer.matched(), 1);

  const fs::path second_report = dir.path / "second";
  const pid_t second =
      spawn_child("RestartChild.DISABLED_ReadSamples",
                  {domain_env, "NETKF_TEST_WANT=1500", "NETKF_TEST_REPORT=" + second_report.string()});
  ASSERT_GT(second, 0);
  ASSERT_TRUE(writer.wait_for_matched(2, 20s)) << "the restarted reader was never discovered";
  const std::uint64_t owed_from = last_written.load() + 1;  // written after the match was seen
  const auto rc = wait_exit(second, 40s);
  ASSERT_TRUE(rc.has_value());
  ASSERT_EQ(*rc, 0) << "the restarted reader did not receive 1500 samples within 20 s of starting";

  const auto before = read_report(first_report);
  const auto after = read_report(second_report);
  ASSERT_FALSE(after.periods.empty());
  std::vector<std::uint64_t> missing;
  for (std::uint64_t k = owed_from; k <= *after.periods.rbegin(); ++k)
    if (!after.periods.count(k)) missing.push_back(k);
  std::printf("first reader: participant id %d; restarted reader: id %d, first sample %lld ms after it started, "
              "samples %zu, owed from k=%llu to %llu, missing %zu\n",
              before.participant_id, after.participant_id, after.first_sample_ms, after.periods.size(),
              static_cast<unsigned long long>(owed_from), static_cast<unsigned long long>(*after.periods.rbegin()),
              missing.size());
  EXPECT_TRUE(missing.empty()) << missing.size() << " samples written after the match never arrived, from k="
                               << missing.front() << " to k=" << missing.back();
  // The mechanism: the restarted reader did not take the killed one's id (so not its port).
  EXPECT_NE(after.participant_id, before.participant_id);
  // The killed reader's marker, as a launch on this domain would remove it.
  EXPECT_EQ(netkf::dds::remove_stale_participant_slots(domain), 1);
}
