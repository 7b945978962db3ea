// The live commands' DDS-free logic: process supervision (launch), the CSV recorders, the
// output files' policy and the status view. Real child processes (/bin/sh), no DDS.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <signal.h>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <cstdlib>
#include <functional>
#include <sstream>
#include <thread>

#include "netkf/cli/common/exit_code.hpp"
#include "netkf/cli/launch/launch_files.hpp"
#include "netkf/cli/launch/launch_plan.hpp"
#include "netkf/cli/launch/launch_supervisor.hpp"
#include "netkf/cli/common/progress_bar.hpp"
#include "netkf/cli/live/live_status.hpp"
#include "netkf/cli/common/output_file.hpp"
#include "netkf/cli/recording/record_csv.hpp"

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

TEST(LaunchPlan, SensorsAreGroupedInScenarioOrder) {
  EXPECT_EQ(sensor_process_groups({4, 2, 9}, 1), (std::vector<std::vector<int>>{{4}, {2}, {9}}));
  EXPECT_EQ(sensor_process_groups({1, 2, 3, 4, 5}, 2), (std::vector<std::vector<int>>{{1, 2}, {3, 4}, {5}}));
  EXPECT_EQ(sensor_process_groups({1, 2, 3}, 8), (std::vector<std::vector<int>>{{1, 2, 3}}));
  EXPECT_TRUE(sensor_process_groups({}, 3).empty());
  EXPECT_THROW(sensor_process_groups({1}, 0), std::invalid_argument);
  EXPECT_EQ(sensor_process_name({7}), "sensor_node[7]");
  EXPECT_EQ(sensor_process_name({1, 2}), "sensor_node[1,2]");
  EXPECT_EQ(sensor_process_name({1, 2, 3}), "sensor_node[1-3]");
  EXPECT_EQ(sensor_process_name({1, 2, 3, 4, 6, 8, 9, 11, 12, 13}), "sensor_node[1-4,6,8,9,11-13]");
}

TEST(LaunchPlan, OnlyParsesRolesAndSensorLists) {
  const std::vector<int> ids{1, 3, 5};
  auto all = parse_launch_roles("all", ids);
  EXPECT_TRUE(all.all && all.plant && all.channel && all.estimator);
  EXPECT_EQ(all.sensor_ids, ids);
  auto a = parse_launch_roles("plant,sensors", ids);
  EXPECT_TRUE(a.plant && !a.channel && !a.estimator && !a.all);
  EXPECT_EQ(a.sensor_ids, ids);
  auto some = parse_launch_roles("sensors=5,1,channel", ids);
  EXPECT_EQ(some.sensor_ids, (std::vector<int>{1, 5}));  // in scenario order
  EXPECT_TRUE(some.channel && !some.plant);
  EXPECT_EQ(describe_launch_roles(some), "sensors 1,5, channel");
  EXPECT_EQ(describe_launch_roles(parse_launch_roles("estimator", ids)), "estimator");
  EXPECT_TRUE(parse_launch_roles("plant,sensors,channel,estimator", ids).all);
  EXPECT_FALSE(parse_launch_roles("plant,sensors=1,3,channel,estimator", ids).all);
  auto error_of = [&](const std::string& text) {
    try {
      parse_launch_roles(text, ids);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error_of("plant,sensor").find("unknown role 'sensor'"), std::string::npos);
  EXPECT_NE(error_of("sensors=2").find("no sensor 2"), std::string::npos);
  EXPECT_NE(error_of("plant,3").find("unknown role '3'"), std::string::npos);  // an id needs sensors= before it
  EXPECT_NE(error_of("").find("unknown role ''"), std::string::npos);
  EXPECT_NE(error_of("sensors=1,x").find("unknown role 'x'"), std::string::npos);
}

TEST(LaunchPlan, HostsDeriveTheSameRunIdFromScenarioAndDomain) {
  EXPECT_EQ(derived_run_id(42, 7), derived_run_id(42, 7));
  EXPECT_NE(derived_run_id(42, 7), derived_run_id(43, 7));
  EXPECT_NE(derived_run_id(42, 7), derived_run_id(42, 8));
  EXPECT_NE(derived_run_id(0, 0), 0u);
}

TEST(SensorGroups, AutoKeepsAtMostTwoSensorProcessesPerCpu) {
  // One process per sensor up to 2 x CPUs sensors.
  EXPECT_EQ(auto_sensors_per_process(0, 2), 1);
  EXPECT_EQ(auto_sensors_per_process(3, 2), 1);
  EXPECT_EQ(auto_sensors_per_process(4, 2), 1);
  EXPECT_EQ(auto_sensors_per_process(8, 4), 1);
  // Beyond that, the fewest per process that keep ceil(d / K) <= 2 x CPUs.
  for (unsigned cpus : {1u, 2u, 3u, 8u}) {
    for (std::size_t d = 1; d <= 300; ++d) {
      const int k = auto_sensors_per_process(d, cpus);
      std::vector<int> ids(d);
      for (std::size_t i = 0; i < d; ++i) ids[i] = static_cast<int>(i + 1);
      const auto groups = sensor_process_groups(ids, k);
      EXPECT_LE(groups.size(), 2 * cpus) << d << " sensors, " << cpus << " CPUs";
      if (k > 1) {
        EXPECT_GT(sensor_process_groups(ids, k - 1).size(), 2 * cpus) << d << " sensors, " << cpus << " CPUs";
      }
    }
  }
  EXPECT_EQ(auto_sensors_per_process(8, 2), 2);
  EXPECT_EQ(auto_sensors_per_process(64, 2), 16);
  EXPECT_EQ(auto_sensors_per_process(5, 0), 3);  // an unknown CPU count counts as one
  EXPECT_GE(usable_cpus(), 1u);
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

TEST(PeriodCsv, ExactHeaderAndJoinedRows) {
  EXPECT_EQ(PeriodCsvRecorder::header(2), "k,t,x0,x1,xhat0,xhat1,trace_P,fused,late,state,late_samples");
  PeriodCsvRecorder r(2);
  Estimate e;
  e.k = 5;
  e.x_hat = Vector{{0.1, 1.0 / 3.0}};
  e.P = Matrix{{2.0, 0.25}, {0.25, 0.5}};  // Tr P = 2.5
  e.fused = {1, 3};
  e.late = 2;
  e.late_sensors = {1, 1};
  e.late_periods = {3, 4};
  r.add_estimate(e);
  std::ostringstream out;
  EXPECT_EQ(r.flush(out), 0u);  // no truth for k = 5 yet
  r.add_truth({5, 0.05, {1.0, -2.0}, {}});
  EXPECT_EQ(r.flush(out), 1u);
  EXPECT_EQ(out.str(), "5,0.050000000000000003,1,-2,0.10000000000000001,0.33333333333333331,2.5,1;3,2,ok,3:1;4:1\n");
  // 17 significant digits give back the exact double.
  EXPECT_EQ(std::strtod("0.33333333333333331", nullptr), 1.0 / 3.0);
  // Wrong sizes are counted, not written.
  r.add_truth({6, 0.06, {1.0}, {}});
  EXPECT_EQ(r.rejected(), 1u);
}

// Every period the plant ran has a row, in order: one whose estimate never came (the estimator
// was stopped, or the run ended first) is written with empty estimate cells and state `none`,
// and the rows after it wait for it (a file a reader can take as a time series) until an
// estimate of a later period says it will not come.
TEST(PeriodCsv, TruthWithoutEstimateIsARowInOrder) {
  PeriodCsvRecorder r(1);
  std::ostringstream out;
  auto estimate = [](std::uint64_t k, double x) {
    Estimate e;
    e.k = k;
    e.x_hat = Vector{{x}};
    e.P = Matrix{{1.0}};
    e.fused = {1};
    return e;
  };
  r.add_truth({0, 0.0, {1.0}, {}});
  r.add_estimate(estimate(0, 0.5));
  r.add_truth({1, 0.01, {2.0}, {}});  // its estimate never comes
  r.add_truth({2, 0.02, {3.0}, {}});
  EXPECT_EQ(r.flush(out), 1u);  // period 1 waits for its estimate
  r.add_truth({3, 0.03, {4.0}, {}});
  r.add_estimate(estimate(3, 3.5));  // a later period's: period 1's and 2's will not come
  EXPECT_EQ(r.flush(out), 3u);
  r.add_estimate(estimate(2, 2.5));  // too late: its row is written
  r.add_estimate(estimate(4, 9.0));  // no truth for 4 before the end: left out
  r.finish_pending();
  EXPECT_EQ(r.flush(out), 0u);
  EXPECT_EQ(out.str(), "0,0,1,0.5,1,1,0,ok,\n1,0.01,2,,,,,none,\n2,0.02,3,,,,,none,\n3,0.029999999999999999,4,3.5,1,1,0,ok,\n");
  EXPECT_EQ(r.rows_without_estimate(), 2u);
}

// An estimate that arrives after its period was written without one is not written again, and a
// period waits at most kGiveUpPeriods periods of truth for its estimate.
TEST(PeriodCsv, GivesUpOnAnEstimateAfterAWindowOfPeriods) {
  PeriodCsvRecorder r(1);
  std::ostringstream out;
  for (std::int64_t k = 0; k <= PeriodCsvRecorder::kGiveUpPeriods; ++k) r.add_truth({k, 0.01 * k, {1.0}, {}});
  EXPECT_EQ(r.flush(out), 1u);  // period 0, without its estimate
  Estimate e;
  e.k = 0;
  e.x_hat = Vector{{0.5}};
  e.P = Matrix{{1.0}};
  r.add_estimate(e);
  EXPECT_EQ(r.flush(out), 0u);
  EXPECT_EQ(out.str(), "0,0,1,,,,,none,\n");
}

// A closed loop's rows end with the input the plant applied to produce x_k.
TEST(PeriodCsv, ClosedLoopRowsCarryTheAppliedInput) {
  EXPECT_EQ(PeriodCsvRecorder::header(1, 0, 2), "k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u0,u1");
  EXPECT_EQ(PeriodCsvRecorder::header(1, 1, 1),
            "k,t,x0,xhat0,trace_P,fused,late,state,late_samples,revisions,xhat_final0,trace_P_final,fused_final,u0");
  PeriodCsvRecorder r(1, 0, 2);
  std::ostringstream out;
  r.add_truth({0, 0.0, {1.0}, {0.0, 0.0}});
  r.add_truth({1, 0.01, {2.0}, {-0.5, 0.25}});
  r.add_truth({2, 0.02, {2.0}, {1.0}});  // wrong input size: counted, not written
  Estimate e;
  e.k = 1;
  e.x_hat = Vector{{1.5}};
  e.P = Matrix{{1.0}};
  r.add_estimate(e);
  r.finish_pending();
  EXPECT_EQ(r.flush(out), 2u);
  EXPECT_EQ(out.str(), "0,0,1,,,,,none,,0,0\n1,0.01,2,1.5,1,,0,ok,,-0.5,0.25\n");
  EXPECT_EQ(r.rejected(), 1u);
  // A truth-only row of a fuse_within recording keeps every column.
  PeriodCsvRecorder f(1, 1, 1);
  f.add_truth({0, 0.0, {1.0}, {0.0}});
  f.finish_pending();
  std::ostringstream fout;
  f.flush(fout);
  EXPECT_EQ(fout.str(), "0,0,1,,,,,none,,,,,,0\n");
}

TEST(PeriodCsv, EmptyFusedSetIsAnEmptyCell) {
  PeriodCsvRecorder r(1);
  r.add_truth({0, 0.0, {1.0}, {}});
  Estimate e;
  e.k = 0;
  e.x_hat = Vector{{0.5}};
  e.P = Matrix{{1.0}};
  e.state = FilterState::diverging;
  r.add_estimate(e);
  std::ostringstream out;
  r.flush(out);
  EXPECT_EQ(out.str(), "0,0,1,0.5,1,,0,diverging,\n");
}

TEST(SampleCsv, MarksFusedAndUnfusedSamples) {
  EXPECT_EQ(SampleCsvRecorder::header(2), "k,sensor_id,stamp,fused,y0,y1");
  SampleCsvRecorder r(2);
  r.add_delivered({1, 7, 1.5, {0.25, 0.5}});
  r.add_delivered({2, 7, 1.5, {0.75}});
  Estimate e;
  e.k = 7;
  e.fused = {1};
  r.add_estimate(e);
  r.add_delivered({3, 7, 1.6, {1.0}});  // after the estimate: late, not fused
  std::ostringstream out;
  EXPECT_EQ(r.flush(out), 3u);
  EXPECT_EQ(out.str(), "7,1,1.5,1,0.25,0.5\n7,2,1.5,0,0.75,\n7,3,1.6000000000000001,0,1,\n");
}

// ---- the progress bar of simulate / analyze --region

TEST(ProgressBar, OnlyOnATerminalAndNeverWithJson) {
  EXPECT_TRUE(progress_bar_wanted(true, false));
  EXPECT_FALSE(progress_bar_wanted(false, false));  // stderr is a file or a pipe
  EXPECT_FALSE(progress_bar_wanted(true, true));
}

TEST(ProgressBar, LineShowsPercentAndTimeLeft) {
  EXPECT_EQ(progress_line("simulate", 0, 200, 0.0, 10), "simulate [..........]   0%");
  // A quarter done in 30 s: 90 s left at that rate.
  EXPECT_EQ(progress_line("simulate", 50, 200, 30.0, 10), "simulate [##........]  25%  1m30s left");
  EXPECT_EQ(progress_line("x", 200, 200, 12.0, 4), "x [####] 100%");
  EXPECT_EQ(progress_line("x", 1, 1000, 10.0, 4), "x [....]   0%  2h46m left");
}

TEST(ProgressBar, DisabledWritesNothing) {
  std::ostringstream out;
  {
    ProgressBar bar(out, "simulate", false);
    EXPECT_FALSE(bar.callback());  // the core need not even count
    bar.update(1, 2);
    bar.update(2, 2);
  }
  EXPECT_EQ(out.str(), "");
}

TEST(ProgressBar, RedrawsAtMostTenTimesASecondThenClears) {
  std::ostringstream out;
  auto now = std::chrono::steady_clock::time_point{} + 1h;
  {
    ProgressBar bar(out, "simulate", true, [&] { return now; });
    auto progress = bar.callback();
    ASSERT_TRUE(progress);
    progress(0, 100);
    now += 50ms;
    progress(10, 100);  // too soon after the first draw
    now += 60ms;
    progress(20, 100);
    progress(100, 100);  // the end is always drawn
  }
  const std::string text = out.str();
  EXPECT_EQ(text, "\r\033[Ksimulate [..............................]   0%"
                  "\r\033[Ksimulate [######........................]  20%  0s left"
                  "\r\033[Ksimulate [##############################] 100%"
                  "\r\033[K");
}

}  // namespace
}  // namespace netkf::cli

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

namespace netkf::cli {
namespace {

Estimate revision_of(std::uint64_t k, std::uint32_t revision, double x, std::vector<int> fused) {
  Estimate e;
  e.k = k;
  e.revision = revision;
  e.x_hat = Vector{{x}};
  e.P = Matrix{{1.0}};
  e.fused = std::move(fused);
  return e;
}

// late_policy fuse_within, D = 1: a row keeps the in-time and the final estimate and waits
// until the in-time estimate of k + 2 is out; the last rows are written by finish_pending().
TEST(PeriodCsv, FuseWithinKeepsFirstAndFinalEstimate) {
  EXPECT_EQ(PeriodCsvRecorder::header(1, 1), "k,t,x0,xhat0,trace_P,fused,late,state,late_samples,revisions,xhat_final0,trace_P_final,fused_final");
  PeriodCsvRecorder r(1, 1);
  std::ostringstream out;
  r.add_truth({0, 0.0, {1.0}, {}});
  r.add_truth({1, 0.01, {2.0}, {}});
  r.add_estimate(revision_of(0, 0, 0.5, {1}));
  r.add_estimate(revision_of(0, 1, 0.75, {1, 2}));
  EXPECT_EQ(r.flush(out), 0u);  // k = 0 may still be revised
  r.add_estimate(revision_of(1, 0, 1.5, {}));
  EXPECT_EQ(r.flush(out), 0u);  // k = 0's window is open until k = 1's deadline
  r.add_estimate(revision_of(0, 2, 0.875, {1, 2, 3}));
  r.add_estimate(revision_of(2, 0, 9.0, {}));
  EXPECT_EQ(r.flush(out), 1u);
  r.finish_pending();
  EXPECT_EQ(r.flush(out), 1u);
  EXPECT_EQ(out.str(),
            "0,0,1,0.5,1,1,0,ok,,2,0.875,1,1;2;3\n"
            "1,0.01,2,1.5,1,,0,ok,,0,1.5,1,\n");
}

TEST(SampleCsv, FuseWithinMarksFinalAndInTimeFusion) {
  EXPECT_EQ(SampleCsvRecorder::header(1, 2), "k,sensor_id,stamp,fused,fused_in_time,y0");
  SampleCsvRecorder r(1, 2);
  std::ostringstream out;
  r.add_delivered({1, 0, 0.5, {0.25}});
  r.add_estimate(revision_of(0, 0, 0.0, {1}));
  r.add_delivered({2, 0, 0.5, {0.75}});  // late for the in-time estimate, fused in revision 1
  r.add_estimate(revision_of(0, 1, 0.0, {1, 2}));
  r.add_estimate(revision_of(1, 0, 0.0, {}));
  r.add_estimate(revision_of(2, 0, 0.0, {}));
  EXPECT_EQ(r.flush(out), 0u);  // k = 0 is final once the in-time estimate of k = 3 is out
  r.add_estimate(revision_of(3, 0, 0.0, {}));
  EXPECT_EQ(r.flush(out), 2u);
  EXPECT_EQ(out.str(), "0,1,0.5,1,1,0.25\n0,2,0.5,1,0,0.75\n");
  r.add_delivered({1, 2, 0.7, {1.0}});
  r.finish_pending();
  EXPECT_EQ(r.flush(out), 1u);
}

}  // namespace
}  // namespace netkf::cli

// The output files' policy (output_file.hpp), on real files: FIFOs and, where this process
// may make them (root: mknod), character devices like /dev/null and /dev/full.
namespace netkf::cli {
namespace {

namespace fs = std::filesystem;

class OutputFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("netkf-output-files-" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  static std::string read(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }
  static void write(const std::string& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }
  /// A character device with /dev/null's (1, 3) or /dev/full's (1, 7) numbers; false when this
  /// process may not make one.
  static bool make_char_device(const std::string& p, unsigned minor) {
    return ::mknod(p.c_str(), S_IFCHR | 0666, makedev(1, minor)) == 0;
  }
  /// The files of the directory (a temporary file left behind would be one).
  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
  static ExitCode code_of(const std::function<void()>& f) {
    try {
      f();
    } catch (const CommandError& e) {
      return e.code();
    }
    return ExitCode::ok;
  }
  static std::string message_of(const std::function<void()>& f) {
    try {
      f();
    } catch (const CommandError& e) {
      return e.what();
    }
    return {};
  }

  fs::path dir_;
};

TEST_F(OutputFiles, WriteReplacesARegularFileWholeKeepingItsMode) {
  const std::string out = path("copy.yaml");
  write(out, "old text that is longer than the new one\n");
  ::chmod(out.c_str(), 0640);
  write_output_file({"-o", out}, "new\n");
  EXPECT_EQ(read(out), "new\n");
  struct stat st {};
  ASSERT_EQ(::stat(out.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u);
  EXPECT_EQ(entries(), std::vector<std::string>{"copy.yaml"});  // no temporary file left
  // A new file.
  write_output_file({"-o", path("new.csv")}, "k,delivered\n");
  EXPECT_EQ(read(path("new.csv")), "k,delivered\n");
}

TEST_F(OutputFiles, WriteThroughASymlinkReplacesItsTargetAndKeepsTheLink) {
  fs::create_directories(dir_ / "real");
  write(path("real/target.csv"), "old\n");
  fs::create_symlink(dir_ / "real" / "target.csv", dir_ / "link.csv");
  write_output_file({"-o", path("link.csv")}, "new\n");
  EXPECT_TRUE(fs::is_symlink(dir_ / "link.csv"));
  EXPECT_EQ(read(path("real/target.csv")), "new\n");
}

TEST_F(OutputFiles, NonRegularTargetsAreRefusedAndLeftInPlace) {
  const std::string fifo = path("fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  EXPECT_EQ(code_of([&] { write_output_file({"-o", fifo}, "x\n"); }), ExitCode::bad_usage);
  EXPECT_EQ(code_of([&] { open_output_stream({"--record", fifo}); }), ExitCode::bad_usage);  // and no wait for a reader
  EXPECT_THAT(message_of([&] { check_output_path({"--record", fifo}); }), ::testing::HasSubstr("FIFO"));
  EXPECT_TRUE(fs::is_fifo(fifo));
  EXPECT_EQ(code_of([&] { write_output_file({"-o", dir_.string()}, "x\n"); }), ExitCode::bad_usage);
  // A symbolic link to nothing is not followed into a new file.
  fs::create_symlink(dir_ / "missing", dir_ / "dangling");
  EXPECT_EQ(code_of([&] { write_output_file({"-o", path("dangling")}, "x\n"); }), ExitCode::bad_usage);
  EXPECT_FALSE(fs::exists(dir_ / "missing"));
  // A directory that does not exist.
  EXPECT_THAT(message_of([&] { check_output_path({"--summary", path("no-dir/s.json")}); }),
              ::testing::HasSubstr("does not exist"));
  EXPECT_EQ(code_of([&] { check_output_path({"-o", ""}); }), ExitCode::bad_usage);

  const std::string null_copy = path("null"), full_copy = path("full");
  if (!make_char_device(null_copy, 3) || !make_char_device(full_copy, 7)) GTEST_SKIP() << "mknod is not allowed here";
  for (const auto& device : {null_copy, full_copy}) {
    SCOPED_TRACE(device);
    EXPECT_THAT(message_of([&] { write_output_file({"-o", device}, "x\n"); }),
                ::testing::HasSubstr("is a character device, not a regular file"));
    EXPECT_EQ(code_of([&] { open_output_stream({"--record", device}); }), ExitCode::bad_usage);
    struct stat st {};
    ASSERT_EQ(::lstat(device.c_str(), &st), 0);  // still there, still the device
    EXPECT_TRUE(S_ISCHR(st.st_mode));
  }
}

TEST_F(OutputFiles, AStreamEmptiesARegularFileAndReportsWriteErrors) {
  const std::string out = path("run.csv");
  write(out, "an earlier run's rows\n");
  {
    auto s = open_output_stream({"--record", out});
    *s << "k,t\n";
    s->flush();
    EXPECT_TRUE(s->good());
  }
  EXPECT_EQ(read(out), "k,t\n");
  // A write the file system refuses (here: the file size limit) is seen on the stream.
  struct rlimit old {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = ::signal(SIGXFSZ, SIG_IGN);
  struct rlimit small = old;
  small.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  auto s = open_output_stream({"--record", out});
  *s << std::string(8192, 'x');
  s->flush();
  const bool failed = !s->good();
  // write_output_file: the same limit is a clear error, and the old file stays as it was.
  const std::string kept = path("kept.csv");
  write(kept, "kept\n");
  const std::string message = message_of([&] { write_output_file({"-o", kept}, std::string(8192, 'y')); });
  ::setrlimit(RLIMIT_FSIZE, &old);
  ::signal(SIGXFSZ, old_handler);
  EXPECT_TRUE(failed);
  EXPECT_THAT(message, ::testing::HasSubstr("cannot write " + kept + " (-o): File too large"));
  EXPECT_EQ(read(kept), "kept\n");
  s.reset();
  std::vector<std::string> left = entries();
  EXPECT_EQ(left, (std::vector<std::string>{"kept.csv", "run.csv"}));  // the temporary file removed
}

TEST_F(OutputFiles, TwoOutputsOnOneFileAreRefusedHoweverNamed) {
  write(path("same.csv"), "x\n");
  fs::create_symlink(dir_ / "same.csv", dir_ / "alias.csv");
  fs::create_hard_link(dir_ / "same.csv", dir_ / "hard.csv");
  fs::create_directories(dir_ / "sub");
  const std::string a = path("same.csv");
  for (const std::string& b : {a, path("./same.csv"), path("sub/../same.csv"), path("alias.csv"), path("hard.csv")}) {
    SCOPED_TRACE(b);
    EXPECT_THAT(message_of([&] { check_output_files({{"--record", a}, {"--record-samples", b}}); }),
                ::testing::HasSubstr("are one file"));
  }
  // Files that do not exist yet: by their path.
  EXPECT_EQ(code_of([&] { check_output_files({{"--record", path("n.csv")}, {"--summary", path("sub/../n.csv")}}); }),
            ExitCode::bad_usage);
  EXPECT_EQ(code_of([&] { check_output_files({{"--record", path("n.csv")}, {"--record-samples", path("m.csv")}}); }),
            ExitCode::ok);
  // An output that is an input.
  EXPECT_THAT(message_of([&] { check_output_files({{"-o", path("alias.csv")}}, {{"the recording", a}}); }),
              ::testing::HasSubstr("an output may not overwrite an input"));
  // Nothing was touched.
  EXPECT_EQ(read(a), "x\n");
}

TEST_F(OutputFiles, ExistingRecordingsAreRefusedUntilForced) {
  write(path("run.csv"), "a run\n");
  EXPECT_THAT(message_of([&] { refuse_existing({{"--record", path("run.csv")}}, "give --force"); }),
              ::testing::HasSubstr("exists: give --force to replace it"));
  EXPECT_EQ(code_of([&] { refuse_existing({{"--record", path("other.csv")}}, "give --force"); }), ExitCode::ok);
  EXPECT_EQ(read(path("run.csv")), "a run\n");
}

}  // namespace
}  // namespace netkf::cli
