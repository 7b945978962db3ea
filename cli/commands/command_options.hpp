#pragma once
// Options and validators several commands share (CLI11 lives only in this room).
#include <CLI/CLI.hpp>

#include "live_bus.hpp"

namespace netkf::cli {

/// --domain, --dds-profile, --secure, --discovery-server.
void add_network_options(CLI::App* cmd, NetworkSettings& network);

/// A wait in seconds: finite, more than 0, at most an hour (NaN, -1 and 1e300 are refused).
CLI::Validator timeout_seconds();

/// Run a command's body: a CommandError prints "netkf: error: ..." and ends the process
/// with its exit code (CLI::RuntimeError, which main returns).
void run_command(const std::function<int()>& body);

}  // namespace netkf::cli
