// `netkf record`: record a running network (any host's) to CSV or MCAP until its run ends.
#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <chrono>
#include <iostream>
#include <memory>

#include "command_options.hpp"
#include "netkf/cli/commands/commands.hpp"
#include "netkf/cli/common/exit_code.hpp"
#include "netkf/cli/common/output_file.hpp"
#include "netkf/cli/common/serve_loop.hpp"
#include "netkf/cli/launch/launch.hpp"
#include "netkf/cli/launch/run_end_watch.hpp"
#include "netkf/cli/live/live_bus.hpp"
#include "netkf/cli/recording/recording.hpp"
#include "netkf/cli/recording/ros2_cdr_codec.hpp"

namespace netkf::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct RecordOptions {
  std::optional<std::string> scenario;
  double duration = 0.0;
  std::string out;
  std::optional<std::string> samples;
  std::optional<std::string> mcap_profile;
  bool force = false;
  NetworkSettings network;
};

int run_record(const RecordOptions& o) {
  // Every file it writes, before anything is opened (output_file.hpp); an earlier recording
  // is only replaced with --force.
  const auto outputs = Recording::outputs("--out", o.out, "--samples", o.samples);
  std::vector<FileArg> inputs;
  if (o.scenario) inputs.push_back({"the scenario", *o.scenario});
  check_output_files(outputs, inputs);
  McapOptions mcap = Recording::mcap_options("--out", o.out, o.mcap_profile, ros2::make_fastcdr_codec());
  if (!o.force) refuse_existing(outputs, "give --force");
  const Scenario scenario = load_or_default(o.scenario);
  boost::asio::io_context io;
  Recording recording(o.out, o.samples, scenario, std::move(mcap));
  std::uint64_t invalid_samples = 0;
  std::unique_ptr<LiveBus> bus;
  try {
    // Present as a recorder: a plant waits for it, so the recording starts at period 0. Its
    // scenario only sizes the recording (hash 0: it conflicts with no network's scenario).
    BusOptions bus_options = o.network.bus("netkf-record", dds::Role::observer);
    bus_options.scenario_naming = scenario.naming;
    bus_options.presence = BusOptions::Presence{dds::presence_role::record, 0, {}};
    bus = std::make_unique<LiveBus>(io, bus_options, recording_handlers(recording, invalid_samples),
                                    false);
  } catch (const std::exception& e) {
    fail(ExitCode::bad_usage, std::string("DDS: ") + e.what());
  }
  bool stop = false;
  boost::asio::signal_set signals(io, SIGINT, SIGTERM);
  signals.async_wait([&](const boost::system::error_code& ec, int) { stop = !ec; });
  const auto start = Clock::now();
  // The recording ends with the run (any run's plant: a recorder has no run id), a little after
  // the launches without the plant, so that it also takes their last estimates.
  RunEndWatch run_end(0, std::chrono::milliseconds(1500));
  auto last_presence_look = start;
  serve(io, std::chrono::milliseconds(100), [&] {
    recording.flush();
    const auto now = Clock::now();
    if (now - last_presence_look >= std::chrono::milliseconds(500)) {
      last_presence_look = now;
      run_end.look(bus->processes(), now);
    }
    return !(stop || recording.write_error() || run_end.over(now) ||
             (o.duration > 0 && now - start >= std::chrono::duration<double>(o.duration)));
  });
  recording.flush();
  recording.finish();
  signals.cancel();
  const int domain = bus->domain();
  bus->end_presence(recording.write_error() ? "failure: " + *recording.write_error() : run_end.why().value_or("stopped"));
  bus.reset();
  if (run_end.why()) std::cerr << "netkf record: " << *run_end.why() << "\n";
  std::cerr << "netkf record: " << recording.rows() << (is_mcap_path(o.out) ? " periods" : " rows") << " written to "
            << o.out << "\n";
  if (recording.write_error()) fail(ExitCode::run_failed, *recording.write_error() + ": the recording was stopped");
  if (recording.rows() == 0)
    fail(ExitCode::no_network, "nothing was recorded: no network answered on DDS domain " + std::to_string(domain) +
                                   " (is a network running? netkf launch; the same --domain)");
  return 0;
}

}  // namespace

void add_record_command(CLI::App& app) {
  auto o = std::make_shared<RecordOptions>();
  auto* cmd = app.add_subcommand("record", "Record truth and estimates of a running network to CSV");
  cmd->add_option("scenario", o->scenario, "Scenario the network runs (for the state size; default: built-in)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", o->out,
                  "CSV file: k,t,x..,xhat..,trace_P,fused,late,state,late_samples; or FILE.mcap: an MCAP file (truth, estimates, "
                  "link status and changes; delivered samples with --samples)")
      ->required();
  cmd->add_option("--samples", o->samples, "Also write every delivered measurement to this CSV");
  cmd->add_option("--mcap-profile", o->mcap_profile,
                  "With --out FILE.mcap: json (default) or ros2 (a rosbag2 bag of netkf_msgs CDR; docs/recording.md)")
      ->check(CLI::IsMember({"json", "ros2"}));
  cmd->add_option("--duration", o->duration, "Stop after S seconds (default: until Ctrl-C)")->check(duration_seconds());
  cmd->add_flag("--force", o->force, "Replace the --out and --samples files (and the journal) of an earlier recording");
  add_network_options(cmd, o->network);
  cmd->callback([o] { run_command([&] { return run_record(*o); }); });
}

}  // namespace netkf::cli
