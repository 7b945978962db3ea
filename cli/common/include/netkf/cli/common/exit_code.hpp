#pragma once
// How a `netkf` command ends (README, "Exit codes"), and the error that carries it. Every
// room below `commands` reports a problem by throwing CommandError; only `commands` and
// main.cpp turn it into a process exit status (and only they know CLI11).
#include <stdexcept>
#include <string>

namespace netkf::cli {

enum class ExitCode : int {
  ok = 0,
  run_failed = 1,  // the run failed: a process died for good, a check failed, a write error mid-run
  bad_usage = 2,   // bad usage or input, found before anything started
  no_network = 3,  // no network answered
  refused = 4,     // the network refused the request (e.g. an invalid link change)
};

/// A command's end with a message for the user ("netkf: error: <what()>").
class CommandError : public std::runtime_error {
 public:
  CommandError(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const { return code_; }
  int exit_status() const { return static_cast<int>(code_); }

 private:
  ExitCode code_;
};

[[noreturn]] inline void fail(ExitCode code, const std::string& message) { throw CommandError(code, message); }

}  // namespace netkf::cli
