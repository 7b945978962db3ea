#pragma once
// Options and validators several commands share (CLI11 lives only in this room).
#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "netkf/links/link.hpp"

#include "netkf/cli/common/seconds.hpp"
#include "netkf/cli/live/live_bus.hpp"
#include "netkf/links/link_keys.hpp"

namespace netkf::cli {

/// --domain, --dds-profile, --secure, --discovery-server.
void add_network_options(CLI::App* cmd, NetworkSettings& network);

/// The flags that say what a link is or becomes (`ctl set-link`, `relay`): --bernoulli,
/// --gilbert-elliott, --model, --loss, --mean-burst, --delay, --jitter, --distribution,
/// --trace, --set KEY=VALUE.
struct LinkFlags {
  std::optional<double> bernoulli;
  std::vector<double> gilbert_elliott;
  std::optional<std::string> model;
  std::optional<double> loss;
  std::optional<double> mean_burst;
  std::optional<double> delay;
  std::optional<double> jitter;
  std::optional<std::string> distribution;
  std::optional<std::string> trace;
  std::vector<std::string> set;  // KEY=VALUE
};
void add_link_flags(CLI::App* cmd, LinkFlags& flags);
/// The link keys the flags give (empty when none), names and number syntax checked (exit 2), a
/// trace file named from here made absolute, and each key checked against a link of the model
/// asked for (or of each model): what is left to check is only the link's current state.
LinkKeys link_keys_of(const LinkFlags& flags);

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
