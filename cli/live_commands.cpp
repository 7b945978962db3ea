// TEMPORARY placeholder until the live-network commands land (launch, ctl, record).
#include "commands.hpp"
namespace netkf::cli {
void add_launch_command(CLI::App& app) { app.add_subcommand("launch", "(not built yet)"); }
void add_ctl_command(CLI::App& app) { app.add_subcommand("ctl", "(not built yet)"); }
void add_record_command(CLI::App& app) { app.add_subcommand("record", "(not built yet)"); }
}  // namespace netkf::cli
