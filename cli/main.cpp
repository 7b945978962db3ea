// netkf: launch and supervise a scenario, tune links, record, analyse, simulate.
#include <iostream>

#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"netkf - Kalman filtering over lossy sensor networks (Fast DDS)"};
  app.require_subcommand(1);
  netkf::cli::add_launch_command(app);
  netkf::cli::add_ctl_command(app);
  netkf::cli::add_record_command(app);
  netkf::cli::add_analyze_command(app);
  netkf::cli::add_simulate_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "netkf: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
