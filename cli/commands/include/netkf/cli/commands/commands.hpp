#pragma once
// Each `netkf` subcommand registers itself on the top-level CLI11 app. A command's
// callback throws CLI::RuntimeError(code) to end with a non-zero exit status.
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace netkf::cli {

void add_launch_command(CLI::App& app);
void add_ctl_command(CLI::App& app);
void add_record_command(CLI::App& app);
void add_analyze_command(CLI::App& app);
void add_simulate_command(CLI::App& app);
void add_fit_command(CLI::App& app);
void add_trace_command(CLI::App& app);
void add_security_command(CLI::App& app);
void add_relay_command(CLI::App& app);
/// `argv`: the command line as given (sweep.yaml records it).
void add_sweep_command(CLI::App& app, const std::vector<std::string>& argv);

}  // namespace netkf::cli
