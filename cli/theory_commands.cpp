// TEMPORARY placeholder until the theory commands land (analyze, simulate).
#include "commands.hpp"
namespace netkf::cli {
void add_analyze_command(CLI::App& app) { app.add_subcommand("analyze", "(not built yet)"); }
void add_simulate_command(CLI::App& app) { app.add_subcommand("simulate", "(not built yet)"); }
}  // namespace netkf::cli
