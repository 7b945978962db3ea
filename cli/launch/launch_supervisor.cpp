#include "launch_supervisor.hpp"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <linux/close_range.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <set>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <thread>

namespace netkf::cli {

std::string ChildExit::describe() const {
  if (signal > 0) {
    const char* name = strsignal(signal);
    return "killed by signal " + std::to_string(signal) + " (" + (name ? name : "?") + ")";
  }
  return "exited with status " + std::to_string(exit_code);
}

bool ChildExit::stopped_from_outside() const {
  return signal == SIGKILL || signal == SIGTERM || signal == SIGINT || signal == SIGHUP;
}

RestartPolicy parse_restart_policy(const std::string& text) {
  if (text == "fail") return RestartPolicy::fail;
  if (text == "restart") return RestartPolicy::restart;
  throw std::invalid_argument("unknown restart policy '" + text + "' (expected fail or restart)");
}

std::string SupervisorEvent::message() const {
  const std::string who = child + " (pid " + std::to_string(pid) + ")";
  switch (kind) {
    case Kind::started: return "started " + who;
    case Kind::exited: return who + " " + exit.describe();
    case Kind::restart_scheduled:
      return "restarting " + child + " in " + std::to_string(backoff.count()) + " ms";
    case Kind::gave_up: return "giving up on " + child + ": " + (reason.empty() ? exit.describe() : reason);
    case Kind::start_failed: return "could not start " + child + (reason.empty() ? "" : ": " + reason);
    case Kind::spare_started: return "started a spare of " + child + " (pid " + std::to_string(pid) + ")";
    case Kind::spare_activated:
      return "restarting " + child + " from its warm spare (pid " + std::to_string(pid) + "), at once";
  }
  return {};
}

namespace {

ChildExit decode_status(int status) {
  ChildExit exit;
  if (WIFEXITED(status)) exit.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) exit.signal = WTERMSIG(status);
  return exit;
}

}  // namespace

Supervisor::Supervisor(SupervisorOptions options) : options_(options) {}

Supervisor::~Supervisor() { stop_all(); }

SupervisorEvent Supervisor::start(ChildSpec spec, std::function<void(ChildSpec&)> before_restart) {
  Child child;
  child.spec = std::move(spec);
  child.before_restart = std::move(before_restart);
  children_.push_back(std::move(child));
  auto event = spawn(children_.back());
  if (event.kind == SupervisorEvent::Kind::start_failed && !failed_) {
    failed_ = true;
    failure_reason_ = event.message();
  }
  // Its spare comes with the next poll: the child first, so that it claims the network's
  // resources (the participant id, the presence) before its spare.
  if (children_.back().spec.warm_spare) children_.back().spare_at = Clock::now();
  return event;
}

pid_t Supervisor::spawn_process(const ChildSpec& spec, const std::vector<std::string>& args, std::string& why,
                                int& exit_code) {
  std::vector<std::string> argv_storage;
  argv_storage.push_back(spec.executable);
  argv_storage.insert(argv_storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_storage) argv.push_back(a.data());
  argv.push_back(nullptr);

  // A pipe with O_CLOEXEC tells the parent whether exec succeeded (closed by exec)
  // or failed (the child writes errno).
  int pipe_fds[2];
  if (pipe2(pipe_fds, O_CLOEXEC) != 0) {
    why = std::string("pipe: ") + std::strerror(errno);
    return -1;
  }
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) {
    why = std::string("fork: ") + std::strerror(errno);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    return -1;
  }
  if (pid == 0) {
    // Child: own process group, so a terminal's Ctrl-C reaches only netkf, which
    // then stops the children in order; die with the parent so nothing is orphaned.
    setpgid(0, 0);
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(127);  // parent already gone
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    signal(SIGPIPE, SIG_DFL);
    // Before exec the child has one thread; the threads the program starts inherit its nice.
    if (spec.nice != 0) {
      [[maybe_unused]] const int r = setpriority(PRIO_PROCESS, 0, spec.nice);
    }
    close(pipe_fds[0]);
    // The child inherits stdin/out/err only: nothing else the launch holds (the
    // dashboard's listening and client sockets, recording files) may outlive it in a node.
    if (close_range(3, ~0U, CLOSE_RANGE_CLOEXEC) != 0) {
      const long open_max = std::min(sysconf(_SC_OPEN_MAX), 65536L);
      for (int fd = 3; fd < open_max; ++fd) fcntl(fd, F_SETFD, FD_CLOEXEC);
    }
    execv(argv[0], argv.data());
    const int err = errno;
    [[maybe_unused]] auto n = write(pipe_fds[1], &err, sizeof err);
    _exit(127);
  }
  close(pipe_fds[1]);
  int child_errno = 0;
  ssize_t n;
  do {
    n = read(pipe_fds[0], &child_errno, sizeof child_errno);
  } while (n < 0 && errno == EINTR);
  close(pipe_fds[0]);
  if (n > 0) {
    int status = 0;
    waitpid(pid, &status, 0);
    exit_code = 127;
    why = "could not execute " + spec.executable + ": " + std::strerror(child_errno);
    return -1;
  }
  return pid;
}

SupervisorEvent Supervisor::spawn(Child& child) {
  SupervisorEvent event{SupervisorEvent::Kind::started, child.spec.name, -1, {}, {}, {}};
  child.pid = spawn_process(child.spec, child.spec.args, event.reason, event.exit.exit_code);
  event.pid = child.pid;
  if (child.pid < 0) event.kind = SupervisorEvent::Kind::start_failed;
  return event;
}

SupervisorEvent Supervisor::spawn_spare(Child& child, Clock::time_point now) {
  child.spare_at.reset();
  SupervisorEvent event{SupervisorEvent::Kind::spare_started, child.spec.name, -1, {}, {}, {}};
  auto args = child.spec.spare_args.empty() ? child.spec.args : child.spec.spare_args;
  args.emplace_back("--spare");
  child.spare_pid = spawn_process(child.spec, args, event.reason, event.exit.exit_code);
  event.pid = child.spare_pid;
  if (child.spare_pid < 0) {
    // A restart without a spare still works (a fresh process): retry the spare later.
    event.kind = SupervisorEvent::Kind::start_failed;
    event.child += " (spare)";
    if (++child.spare_failures <= options_.max_restarts)
      child.spare_at = now + options_.first_backoff * (1 << child.spare_failures);
  }
  return event;
}

void Supervisor::handle_exit(Child& child, const ChildExit& exit, Clock::time_point now,
                             std::vector<SupervisorEvent>& events) {
  const pid_t old_pid = child.pid;
  child.pid = -1;
  events.push_back({SupervisorEvent::Kind::exited, child.spec.name, old_pid, exit, {}, {}});
  if (stopping_) return;
  if (child.spec.critical && exit.clean()) {
    // The plant ends on its own after --max-periods or at its state bound.
    finished_ = true;
    if (finished_reason_.empty()) finished_reason_ = child.spec.name + " finished";
    return;
  }
  if (child.spec.critical && exit.stopped_from_outside()) {
    // The plant is the run's physical world: killed from outside, the world ended, and with it
    // the run (cleanly: what was recorded stays valid). A crash (SIGSEGV, SIGABRT, an error
    // status) is a failure.
    finished_ = true;
    if (finished_reason_.empty())
      finished_reason_ = child.spec.name + " " + exit.describe() + ": the run ends with it (not restarted)";
    return;
  }
  restart_or_give_up(child, old_pid, exit, exit.describe(), now, events);
}

void Supervisor::restart_or_give_up(Child& child, pid_t old_pid, const ChildExit& exit, const std::string& why,
                                    Clock::time_point now, std::vector<SupervisorEvent>& events) {
  const bool may_restart = options_.policy == RestartPolicy::restart && !child.spec.critical &&
                           child.restarts < options_.max_restarts;
  if (!may_restart) {
    events.push_back({SupervisorEvent::Kind::gave_up, child.spec.name, old_pid, exit, {}, why});
    if (!failed_) {
      failed_ = true;
      failure_reason_ = child.spec.name + " " + why +
                        (child.spec.critical ? " (critical process, not restarted)"
                         : options_.policy == RestartPolicy::fail ? " (restart policy: fail)"
                                                                   : " (no restarts left)");
    }
    return;
  }
  if (child.spare_pid > 0) {
    // The warm spare takes over at once: its participant is already part of the network.
    child.restarts++;
    if (child.before_restart) child.before_restart(child.spec);
    kill(child.spare_pid, SIGUSR1);
    child.pid = child.spare_pid;
    child.spare_pid = -1;
    events.push_back({SupervisorEvent::Kind::spare_activated, child.spec.name, child.pid, exit, {}, {}});
    events.push_back(spawn_spare(child, now));
    return;
  }
  const auto backoff = options_.first_backoff * (1 << child.restarts);
  child.restarts++;
  child.restart_at = now + backoff;
  SupervisorEvent e{SupervisorEvent::Kind::restart_scheduled, child.spec.name, old_pid, exit, {}, {}};
  e.backoff = std::chrono::duration_cast<std::chrono::milliseconds>(backoff);
  events.push_back(e);
}

std::vector<SupervisorEvent> Supervisor::poll(Clock::time_point now) {
  std::vector<SupervisorEvent> events;
  for (auto& child : children_) {
    if (child.spare_pid > 0) {
      int status = 0;
      if (waitpid(child.spare_pid, &status, WNOHANG) == child.spare_pid) {
        // A spare that died before it was needed: another one after a backoff.
        events.push_back({SupervisorEvent::Kind::exited, child.spec.name + " (spare)", child.spare_pid,
                          decode_status(status), {}, {}});
        child.spare_pid = -1;
        if (++child.spare_failures <= options_.max_restarts)
          child.spare_at = now + options_.first_backoff * (1 << child.spare_failures);
      }
    }
    if (child.pid <= 0) continue;
    int status = 0;
    const pid_t r = waitpid(child.pid, &status, WNOHANG);
    if (r == child.pid) handle_exit(child, decode_status(status), now, events);
  }
  if (!stopping_ && !failed_) {
    for (auto& child : children_)
      if (child.spare_pid <= 0 && child.spare_at && *child.spare_at <= now) events.push_back(spawn_spare(child, now));
    for (auto& child : children_) {
      if (child.pid <= 0 && child.restart_at && *child.restart_at <= now) {
        child.restart_at.reset();
        if (child.before_restart) child.before_restart(child.spec);
        auto event = spawn(child);
        events.push_back(event);
        if (event.kind == SupervisorEvent::Kind::start_failed)
          restart_or_give_up(child, -1, event.exit, "could not be restarted: " + event.reason, now, events);
      }
    }
  }
  return events;
}

std::vector<SupervisorEvent> Supervisor::stop_all() {
  stopping_ = true;
  std::vector<SupervisorEvent> events;
  for (auto& child : children_) {
    child.restart_at.reset();
    child.spare_at.reset();
    if (child.pid > 0) kill(child.pid, SIGTERM);
    if (child.spare_pid > 0) kill(child.spare_pid, SIGTERM);
  }
  const auto deadline = Clock::now() + options_.stop_timeout;
  auto reap = [&] {
    for (auto& child : children_) {
      if (child.spare_pid > 0 && waitpid(child.spare_pid, nullptr, WNOHANG) == child.spare_pid) child.spare_pid = -1;
      if (child.pid <= 0) continue;
      int status = 0;
      if (waitpid(child.pid, &status, WNOHANG) == child.pid)
        handle_exit(child, decode_status(status), Clock::now(), events);
    }
  };
  auto spares = [&] {
    return std::count_if(children_.begin(), children_.end(), [](const Child& c) { return c.spare_pid > 0; });
  };
  while ((running_count() > 0 || spares() > 0) && Clock::now() < deadline) {
    reap();
    if (running_count() > 0 || spares() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  for (auto& child : children_) {
    if (child.spare_pid > 0) {
      kill(-child.spare_pid, SIGKILL);
      kill(child.spare_pid, SIGKILL);
      waitpid(child.spare_pid, nullptr, 0);
      child.spare_pid = -1;
    }
    if (child.pid <= 0) continue;
    // Did not stop in time: SIGKILL the child's whole group (it may have helpers).
    kill(-child.pid, SIGKILL);
    kill(child.pid, SIGKILL);
    int status = 0;
    if (waitpid(child.pid, &status, 0) == child.pid) {
      auto exit = decode_status(status);
      events.push_back({SupervisorEvent::Kind::exited, child.spec.name + " (after SIGKILL)", child.pid, exit, {}, {}});
    }
    child.pid = -1;
  }
  return events;
}

std::vector<Supervisor::ChildStatus> Supervisor::children() const {
  std::vector<ChildStatus> out;
  for (const auto& child : children_) {
    out.push_back({child.spec.name, child.pid, child.pid > 0, child.restarts, child.restart_at.has_value()});
    if (child.spare_pid > 0) out.push_back({child.spec.name + " (spare)", child.spare_pid, true, 0, false});
  }
  return out;
}

std::optional<pid_t> Supervisor::pid_of(const std::string& name) const {
  for (const auto& child : children_) {
    if (child.spec.name == name && child.pid > 0) return child.pid;
    if (child.spare_pid > 0 && child.spec.name + " (spare)" == name) return child.spare_pid;
  }
  return std::nullopt;
}

std::size_t Supervisor::running_count() const {
  std::size_t n = 0;
  for (const auto& child : children_) n += child.pid > 0 ? 1 : 0;
  return n;
}

std::string node_binary_root() {
  if (const char* env = std::getenv("NETKF_BIN_DIR"); env && *env) return env;
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return ".";
  // build/<preset>/cli/netkf -> build/<preset>
  return self.parent_path().parent_path().string();
}

std::string node_executable(const std::string& name) {
  const std::filesystem::path root = node_binary_root();
  for (const auto& candidate : {root / name / name, root / name}) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(candidate, ec)) return candidate.string();
  }
  return (root / name / name).string();
}


}  // namespace netkf::cli
