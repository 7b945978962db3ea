// netkf: launch and supervise a scenario, tune links, record, analyse, simulate, sweep.
// Exit codes (README, "Exit codes"; cli/common/include/netkf/cli/common/exit_code.hpp): 0 done, 1 failure of the run,
// 2 bad usage or input, 3 no network answered, 4 the network refused the request.
#include <iostream>

#include "netkf/cli/commands/commands.hpp"
#include "netkf/cli/common/exit_code.hpp"

int main(int argc, char** argv) {
  CLI::App app{"netkf - Kalman filtering over lossy sensor networks (Fast DDS)"};
  app.require_subcommand(1);
  netkf::cli::add_launch_command(app);
  netkf::cli::add_ctl_command(app);
  netkf::cli::add_record_command(app);
  netkf::cli::add_analyze_command(app);
  netkf::cli::add_simulate_command(app);
  netkf::cli::add_fit_command(app);
  netkf::cli::add_trace_command(app);
  netkf::cli::add_security_command(app);
  netkf::cli::add_relay_command(app);
  netkf::cli::add_sweep_command(app, std::vector<std::string>(argv, argv + argc));
  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // a command's own code, its message already printed
  } catch (const netkf::cli::CommandError& e) {
    std::cerr << "netkf: error: " << e.what() << "\n";
    return e.exit_status();
  } catch (const CLI::ParseError& e) {
    // --help and --version end with 0; every argument error is "bad usage", 2 (not
    // CLI11's own codes 101-127).
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const std::exception& e) {
    std::cerr << "netkf: error: " << e.what() << "\n";
    return static_cast<int>(netkf::cli::ExitCode::run_failed);
  }
  return 0;
}
