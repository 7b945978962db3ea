#pragma once
// Options and validators several commands share (CLI11 lives only in this room).
#include <CLI/CLI.hpp>

#include "live_bus.hpp"
#include "seconds.hpp"

namespace netkf::cli {

/// --domain, --dds-profile, --secure, --discovery-server.
void add_network_options(CLI::App* cmd, NetworkSettings& network);

/// Every time-like flag (durations, timeouts, intervals): a number of seconds as
/// seconds_problem() (seconds.hpp) accepts it. NaN, inf, 1e300, -1 and "abc" are refused
/// (exit 2).
CLI::Validator seconds_in(double min, double max, bool above_min = false);
/// A wait in seconds: more than 0, at most an hour.
CLI::Validator timeout_seconds();
/// A run's length: 0 (none: until Ctrl-C or the run's end) to kMaxDurationSeconds.
CLI::Validator duration_seconds();

/// Run a command's body: a CommandError prints "netkf: error: ..." and ends the process
/// with its exit code (CLI::RuntimeError, which main returns).
void run_command(const std::function<int()>& body);

}  // namespace netkf::cli
