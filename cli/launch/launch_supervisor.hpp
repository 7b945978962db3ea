#pragma once
// Process supervision for `netkf launch`: spawn the node executables, notice when one
// dies (with its exit status or signal), apply the restart policy, and stop everything
// in bounded time (SIGTERM, wait, SIGKILL). No DDS here, so it is testable alone.
//
// Why fork/exec rather than a library: we need prctl(PR_SET_PDEATHSIG) and a new
// process group in the child between fork and exec, which posix_spawn cannot do.
#include <sys/types.h>

#include <chrono>
#include <functional>
#include <optional>
#include <cstdint>
#include <string>
#include <vector>

namespace netkf::cli {

struct ChildSpec {
  std::string name;               // e.g. "sensor_node[2]" (used in messages)
  std::string executable;         // path to the program
  std::vector<std::string> args;  // argv[1..]
  // Critical children (the plant) are never restarted: the run's clock would restart at
  // k = 0, which would silently corrupt a recording. The plant's clean exit ends the run.
  bool critical = false;
  // CPU priority (nice value, 1..19) of the child and every thread it creates; 0: the launch's own.
  int nice = 0;
  // Keep a warm spare: a second process of the same argv plus `--spare`, started at once, which
  // joins the DDS network and waits (dds/node_support.hpp, SpareGate). When the child dies, the
  // restart activates the spare (SIGUSR1) instead of starting a process that the network must
  // discover first, and a new spare is started. Under load a new participant was discovered only
  // after ~1 s (BENCHMARKS.md, "Blind window of a restart").
  bool warm_spare = false;
  // The warm spare's argv (the supervisor adds `--spare`); empty: `args`. The launch gives an
  // estimator's spare a stronger DDS ownership than the child it replaces (launch_plan.hpp).
  std::vector<std::string> spare_args{};
};

/// How a child ended, as waitpid reported it.
struct ChildExit {
  int exit_code = -1;  // >= 0 when it exited normally
  int signal = 0;      // > 0 when a signal ended it
  std::string describe() const;  // "exited with status 3" / "killed by signal 9 (Killed)"
  bool clean() const { return signal == 0 && exit_code == 0; }
  /// Ended by a signal someone sent to stop it (SIGKILL, SIGTERM, SIGINT, SIGHUP), not a crash.
  bool stopped_from_outside() const;
};

enum class RestartPolicy { fail, restart };
RestartPolicy parse_restart_policy(const std::string& text);  // throws std::invalid_argument

struct SupervisorOptions {
  RestartPolicy policy = RestartPolicy::restart;
  int max_restarts = 3;                                 // per child
  // Doubled at each restart. Short: while a channel or estimator is down, every period is
  // fused open-loop (BENCHMARKS.md, fault recovery).
  std::chrono::milliseconds first_backoff{100};
  std::chrono::milliseconds stop_timeout{3000};         // SIGTERM -> SIGKILL
};

/// Something the supervisor observed; the caller logs it.
struct SupervisorEvent {
  enum class Kind { started, exited, restart_scheduled, gave_up, start_failed, spare_started, spare_activated } kind;
  std::string child;
  pid_t pid = -1;
  ChildExit exit;
  std::chrono::milliseconds backoff{0};
  std::string reason;  // start_failed: why (e.g. "pipe: Too many open files")
  std::string message() const;
};

class Supervisor {
 public:
  using Clock = std::chrono::steady_clock;

  explicit Supervisor(SupervisorOptions options = {});
  ~Supervisor();  // stop_all()
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  /// Spawn a child now. Returns the event (started or start_failed: then failed() is true).
  /// `before_restart` runs before each restart (not the first start), e.g. to write the
  /// checkpoint a restarted estimator resumes from; it may change the next life's argv.
  SupervisorEvent start(ChildSpec spec, std::function<void(ChildSpec&)> before_restart = {});

  /// Reap children that ended, apply the policy, start due restarts. Never blocks. A restart
  /// that cannot start (no descriptor for its pipe, fork failed, exec failed) is one more
  /// restart under the policy: tried again after the next backoff, or, with none left (or
  /// policy fail), the run fails.
  std::vector<SupervisorEvent> poll(Clock::time_point now = Clock::now());

  /// True once the launch must end with an error: a critical child died, a child
  /// ran out of restarts, or (policy fail) any child died unexpectedly.
  bool failed() const { return failed_; }
  std::string failure_reason() const { return failure_reason_; }
  /// True when a critical child ended on its own with status 0 (e.g. the plant
  /// reached --max-periods or its state bound) or was stopped from outside (kill -9 of
  /// the plant): the run is over, cleanly.
  bool finished() const { return finished_; }
  std::string finished_reason() const { return finished_reason_; }

  /// SIGTERM every running child, wait up to stop_timeout, then SIGKILL the rest and
  /// reap them. Returns the exits observed during the stop (for reporting).
  std::vector<SupervisorEvent> stop_all();

  struct ChildStatus {
    std::string name;
    pid_t pid = -1;  // -1 when not running
    bool running = false;
    int restarts = 0;
    bool restart_pending = false;  // dead, to be started again after its back-off
  };
  /// Every child started so far, in start order.
  std::vector<ChildStatus> children() const;

  /// pid of the running child with that name (nullopt when not running); "NAME (spare)": its spare.
  std::optional<pid_t> pid_of(const std::string& name) const;
  std::size_t running_count() const;

 private:
  struct Child {
    ChildSpec spec;
    std::function<void(ChildSpec&)> before_restart;  // may change the next life's argv
    pid_t pid = -1;  // -1 when not running
    int restarts = 0;
    std::optional<Clock::time_point> restart_at;
    pid_t spare_pid = -1;  // warm_spare: the spare waiting to take over (-1: none)
    std::optional<Clock::time_point> spare_at;  // when to start the next spare
    int spare_failures = 0;
  };
  SupervisorEvent spawn(Child& child);
  /// Start the child's spare now (or, failing, after a backoff).
  SupervisorEvent spawn_spare(Child& child, Clock::time_point now);
  /// fork/exec `args` of the child's spec; the pid, or -1 with `why`.
  pid_t spawn_process(const ChildSpec& spec, const std::vector<std::string>& args, std::string& why, int& exit_code);
  void handle_exit(Child& child, const ChildExit& exit, Clock::time_point now,
                   std::vector<SupervisorEvent>& events);
  /// Schedule the child's next restart after its backoff, or fail the run when it may not
  /// restart again (`why` ends the failure reason).
  void restart_or_give_up(Child& child, pid_t old_pid, const ChildExit& exit, const std::string& why,
                          Clock::time_point now, std::vector<SupervisorEvent>& events);

  SupervisorOptions options_;
  std::vector<Child> children_;
  bool stopping_ = false;
  bool failed_ = false;
  bool finished_ = false;
  std::string failure_reason_;
  std::string finished_reason_;
};

/// Directory holding the node executables: $NETKF_BIN_DIR if set, else the build
/// tree's root found from /proc/self/exe (build/<preset>/cli/netkf -> build/<preset>).
std::string node_binary_root();
/// Path of a node executable, e.g. node_executable("sensor_node") ->
/// <root>/sensor_node/sensor_node (or <root>/sensor_node when installed flat).
std::string node_executable(const std::string& name);

}  // namespace netkf::cli
