// The launch's process supervision (launch_supervisor.hpp): restarts, warm spares, critical
// children, signals, descriptors and nice values. Real child processes (/bin/sh), no DDS.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <signal.h>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>

#include <cerrno>
#include <chrono>
#include <fstream>
#include <cstdlib>
#include <sstream>
#include <thread>

#include "launch_supervisor.hpp"

namespace netkf::cli {
namespace {

using namespace std::chrono_literals;

ChildSpec shell(const std::string& name, const std::string& script, bool critical = false) {
  return ChildSpec{name, "/bin/sh", {"-c", script}, critical};
}

/// Poll until `pred` or 10 s; collects the events seen.
template <class Pred>
std::vector<SupervisorEvent> poll_until(Supervisor& s, Pred pred) {
  std::vector<SupervisorEvent> all;
  const auto until = std::chrono::steady_clock::now() + 10s;
  while (!pred() && std::chrono::steady_clock::now() < until) {
    auto ev = s.poll();
    all.insert(all.end(), ev.begin(), ev.end());
    std::this_thread::sleep_for(5ms);
  }
  return all;
}

/// A process's command line (its arguments, each ended by '\0'); "" once it is gone.
std::string command_line_of(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/cmdline");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

int count(const std::vector<SupervisorEvent>& ev, SupervisorEvent::Kind kind) {
  int n = 0;
  for (const auto& e : ev) n += e.kind == kind;
  return n;
}

TEST(Supervisor, RestartsADyingChildThenGivesUp) {
  SupervisorOptions o;
  o.max_restarts = 2;
  o.first_backoff = 10ms;
  Supervisor s(o);
  EXPECT_EQ(s.start(shell("sensor", "exit 3")).kind, SupervisorEvent::Kind::started);
  auto ev = poll_until(s, [&] { return s.failed(); });
  ASSERT_TRUE(s.failed());
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::exited), 3);  // first run + 2 restarts
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::restart_scheduled), 2);
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::started), 2);
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::gave_up), 1);
  EXPECT_NE(s.failure_reason().find("exited with status 3"), std::string::npos) << s.failure_reason();
}

// A warm spare: started beside the child with `--spare` (here $0 of the script), it waits for
// SIGUSR1; when the child dies the spare is activated at once (no backoff) and becomes the
// child, and a new spare is started. The script shows what it got: activated, it execs `sleep`.
TEST(Supervisor, AWarmSpareTakesOverAtOnceAndIsReplaced) {
  SupervisorOptions o;
  o.first_backoff = 5s;  // a restart without the spare would take this long
  Supervisor s(o);
  auto spec = shell("estimator", "if [ \"$0\" = --spare ]; then trap 'exec sleep 31' USR1; "
                                 "while :; do sleep 0.01; done; else exec sleep 30; fi");
  spec.warm_spare = true;
  s.start(spec);
  auto spare_of = [&]() -> std::optional<pid_t> { return s.pid_of("estimator (spare)"); };
  auto ev = poll_until(s, [&] { return spare_of().has_value(); });
  ASSERT_TRUE(spare_of());
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::spare_started), 1);
  const pid_t first = *s.pid_of("estimator"), spare = *spare_of();
  kill(first, SIGKILL);
  ev = poll_until(s, [&] { return s.pid_of("estimator") && *s.pid_of("estimator") != first && spare_of(); });
  EXPECT_EQ(s.pid_of("estimator"), spare);  // the spare is the child now
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::spare_activated), 1);
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::restart_scheduled), 0);
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::spare_started), 1);  // its successor
  EXPECT_NE(spare_of(), spare);
  // The activated spare got SIGUSR1: it went on to be the node (here: exec sleep 31).
  std::string cmdline;
  for (int i = 0; i < 200 && cmdline.find(std::string("sleep\0" "31", 8)) == std::string::npos; ++i) {
    std::this_thread::sleep_for(10ms);
    cmdline = command_line_of(spare);
  }
  EXPECT_NE(cmdline.find(std::string("sleep\0" "31", 8)), std::string::npos);
  EXPECT_FALSE(s.failed());
  const auto children = s.children();
  EXPECT_EQ(children.size(), 2u);  // the child and its spare
  s.stop_all();
  EXPECT_EQ(s.running_count(), 0u);
  EXPECT_FALSE(spare_of());
}

TEST(Supervisor, AWarmSpareRunsItsOwnArgs) {
  Supervisor s;
  auto spec = shell("estimator", "exec sleep 30");
  spec.warm_spare = true;
  spec.spare_args = {"-c", "if [ \"$0\" = --spare ]; then exec sleep 33; fi; exit 7"};
  s.start(spec);
  auto ev = poll_until(s, [&] { return s.pid_of("estimator (spare)").has_value(); });
  const auto spare = s.pid_of("estimator (spare)");
  ASSERT_TRUE(spare);
  std::string cmdline;
  for (int i = 0; i < 200 && cmdline.find(std::string("sleep\0" "33", 8)) == std::string::npos; ++i) {
    std::this_thread::sleep_for(10ms);
    cmdline = command_line_of(*spare);
  }
  EXPECT_NE(cmdline.find(std::string("sleep\0" "33", 8)), std::string::npos);  // spare_args, then --spare
  const std::string child_cmdline = command_line_of(*s.pid_of("estimator"));
  EXPECT_NE(child_cmdline.find(std::string("sleep\0" "30", 8)), std::string::npos);  // the child: args
  s.stop_all();
}

TEST(Supervisor, ReportsTheKillingSignal) {
  SupervisorOptions o;
  o.policy = RestartPolicy::fail;
  Supervisor s(o);
  s.start(shell("sensor", "exec sleep 30"));
  const auto pid = s.pid_of("sensor");
  ASSERT_TRUE(pid);
  kill(*pid, SIGKILL);
  auto ev = poll_until(s, [&] { return s.failed(); });
  ASSERT_TRUE(s.failed());
  EXPECT_NE(s.failure_reason().find("killed by signal 9"), std::string::npos) << s.failure_reason();
  EXPECT_EQ(s.running_count(), 0u);
}

TEST(Supervisor, CriticalChildIsNotRestarted) {
  SupervisorOptions o;
  o.first_backoff = 10ms;
  Supervisor s(o);
  s.start(shell("estimator", "exit 1", true));
  poll_until(s, [&] { return s.failed(); });
  EXPECT_TRUE(s.failed());
  EXPECT_NE(s.failure_reason().find("critical"), std::string::npos);
}

// The plant is the run's physical world: killed from outside, the run ends cleanly; a crash
// of it fails the run.
TEST(Supervisor, CriticalChildKilledFromOutsideEndsTheRunCrashFailsIt) {
  for (const char* how : {"kill -9 $$", "kill -11 $$"}) {
    SupervisorOptions o;
    o.first_backoff = 10ms;
    Supervisor s(o);
    s.start(shell("plant", how, true));
    poll_until(s, [&] { return s.finished() || s.failed(); });
    if (std::string(how) == "kill -9 $$") {
      EXPECT_TRUE(s.finished()) << s.failure_reason();
      EXPECT_FALSE(s.failed());
      EXPECT_NE(s.finished_reason().find("killed by signal 9"), std::string::npos) << s.finished_reason();
    } else {
      EXPECT_TRUE(s.failed());
      EXPECT_NE(s.failure_reason().find("signal 11"), std::string::npos) << s.failure_reason();
    }
  }
}

TEST(Supervisor, ChildRunsAtItsNiceValue) {
  // The nice value as the kernel reports it (field 19 of /proc/PID/stat), read by the child
  // itself; a critical child ending with 0 finishes the run, anything else fails it.
  // nice 0 leaves the child at the launch's own nice value (e.g. a test run under `nice -n 5`).
  errno = 0;
  const int own = getpriority(PRIO_PROCESS, 0);
  ASSERT_EQ(errno, 0);
  for (int nice : {0, 7, 19}) {
    Supervisor s;
    const int expected = nice == 0 ? own : nice;
    ChildSpec spec = shell("sensor", "[ \"$(cut -d' ' -f19 /proc/$$/stat)\" = " + std::to_string(expected) +
                                         " ] && exit 0 || exit 3", true);
    spec.nice = nice;
    s.start(spec);
    poll_until(s, [&] { return s.finished() || s.failed(); });
    EXPECT_TRUE(s.finished()) << "nice " << nice << ": " << s.failure_reason();
  }
}

TEST(Supervisor, CriticalChildEndingCleanlyFinishesTheRun) {
  Supervisor s;
  s.start(shell("plant", "exit 0", true));
  s.start(shell("sensor", "exec sleep 30"));
  poll_until(s, [&] { return s.finished(); });
  EXPECT_TRUE(s.finished());
  EXPECT_FALSE(s.failed());
  s.stop_all();
  EXPECT_EQ(s.running_count(), 0u);
}

TEST(Supervisor, ChildInheritsNoDescriptorButStdio) {
  // E.g. the dashboard's listening socket: a node holding it would keep the port open.
  const int fd = dup(1);  // no close-on-exec
  ASSERT_GE(fd, 3);
  Supervisor s;
  s.start(shell("plant", "test -e /proc/self/fd/" + std::to_string(fd) + " && exit 3; exit 0", true));
  poll_until(s, [&] { return s.finished() || s.failed(); });
  close(fd);
  EXPECT_TRUE(s.finished()) << s.failure_reason();
}

TEST(Supervisor, StopAllKillsAChildIgnoringSigterm) {
  SupervisorOptions o;
  o.stop_timeout = 300ms;
  Supervisor s(o);
  s.start(shell("stubborn", "trap '' TERM; while true; do sleep 0.05; done"));
  s.start(shell("polite", "exec sleep 30"));
  std::this_thread::sleep_for(100ms);  // let the shell install its trap
  auto ev = s.stop_all();
  EXPECT_EQ(s.running_count(), 0u);
  bool stubborn_killed = false;
  for (const auto& e : ev) stubborn_killed |= e.child.find("stubborn") != std::string::npos && e.exit.signal == SIGKILL;
  EXPECT_TRUE(stubborn_killed);
  EXPECT_FALSE(s.failed());  // stopping is not a failure
}

/// Holds every free descriptor of this process (dups of stdin, under a soft limit of 256) until
/// release(): a restart then cannot open the pipe it starts a child with (EMFILE), as when
/// idle dashboard connections took all of a launch's descriptors.
class DescriptorExhaustion {
 public:
  DescriptorExhaustion() {
    getrlimit(RLIMIT_NOFILE, &saved_);
    rlimit low = saved_;
    if (low.rlim_cur > 256) low.rlim_cur = 256;
    setrlimit(RLIMIT_NOFILE, &low);
    for (int fd; (fd = dup(0)) >= 0;) held_.push_back(fd);
  }
  ~DescriptorExhaustion() { release(); }
  void release() {
    for (int fd : held_) close(fd);
    held_.clear();
    setrlimit(RLIMIT_NOFILE, &saved_);
  }
  bool exhausted() const { return !held_.empty() && errno == EMFILE; }

 private:
  rlimit saved_{};
  std::vector<int> held_;
};

TEST(Supervisor, ARestartThatCannotStartIsRetriedUnderThePolicy) {
  SupervisorOptions o;
  o.max_restarts = 3;
  o.first_backoff = 10ms;
  Supervisor s(o);
  s.start(shell("sensor", "exec sleep 30"));
  const auto pid = s.pid_of("sensor");
  ASSERT_TRUE(pid);
  std::vector<SupervisorEvent> ev;
  {
    DescriptorExhaustion full;
    ASSERT_TRUE(full.exhausted());
    kill(*pid, SIGKILL);
    // The restart fails to start: it is one more restart, scheduled after a longer backoff.
    const auto until = std::chrono::steady_clock::now() + 10s;
    while (count(ev, SupervisorEvent::Kind::start_failed) == 0 && !s.failed() &&
           std::chrono::steady_clock::now() < until) {
      auto more = s.poll();
      ev.insert(ev.end(), more.begin(), more.end());
      std::this_thread::sleep_for(2ms);
    }
  }
  // Descriptors free again: the next restart starts the sensor.
  auto after = poll_until(s, [&] { return s.pid_of("sensor").has_value() || s.failed(); });
  ev.insert(ev.end(), after.begin(), after.end());
  EXPECT_FALSE(s.failed()) << s.failure_reason();
  EXPECT_TRUE(s.pid_of("sensor").has_value());
  ASSERT_GE(count(ev, SupervisorEvent::Kind::start_failed), 1);
  for (const auto& e : ev) {
    if (e.kind == SupervisorEvent::Kind::start_failed) {
      EXPECT_NE(e.message().find("Too many open files"), std::string::npos) << e.message();
    }
  }
  // Each failed start counted against max_restarts: the death, then every failed attempt.
  EXPECT_EQ(s.children().front().restarts, 1 + count(ev, SupervisorEvent::Kind::start_failed));
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::restart_scheduled), s.children().front().restarts);
  s.stop_all();
}

TEST(Supervisor, ARestartThatNeverStartsFailsTheRun) {
  SupervisorOptions o;
  o.max_restarts = 2;
  o.first_backoff = 10ms;
  Supervisor s(o);
  s.start(shell("sensor", "exec sleep 30"));
  const auto pid = s.pid_of("sensor");
  ASSERT_TRUE(pid);
  std::vector<SupervisorEvent> ev;
  std::string reason;
  {
    DescriptorExhaustion full;
    ASSERT_TRUE(full.exhausted());
    kill(*pid, SIGKILL);
    ev = poll_until(s, [&] { return s.failed(); });
    reason = s.failure_reason();  // read before the descriptors come back (a string copy)
  }
  ASSERT_TRUE(s.failed());
  EXPECT_NE(reason.find("sensor could not be restarted"), std::string::npos) << reason;
  EXPECT_NE(reason.find("Too many open files"), std::string::npos) << reason;
  EXPECT_NE(reason.find("no restarts left"), std::string::npos) << reason;
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::start_failed), 2);  // the 2 restarts allowed
  EXPECT_EQ(count(ev, SupervisorEvent::Kind::gave_up), 1);
  EXPECT_EQ(s.running_count(), 0u);
}

TEST(Supervisor, MissingExecutableIsAClearStartFailure) {
  Supervisor s;
  auto e = s.start(ChildSpec{"ghost", "./does/not/exist", {}, false});
  EXPECT_EQ(e.kind, SupervisorEvent::Kind::start_failed);
  EXPECT_TRUE(s.failed());
  EXPECT_NE(s.failure_reason().find("does/not/exist"), std::string::npos);
}

TEST(Supervisor, NodeExecutableHonoursBinDirOverride) {
  setenv("NETKF_BIN_DIR", "/nonexistent-root", 1);
  EXPECT_EQ(node_executable("plant_node"), "/nonexistent-root/plant_node/plant_node");
  unsetenv("NETKF_BIN_DIR");
}

}  // namespace
}  // namespace netkf::cli
