// `netkf trace extract RUN.csv|RUN.mcap --link ID -o link.csv`: the arrival trace a link had
// in a recording, for `netkf fit` or a `model: trace` link (docs/cli.md, "netkf trace extract").
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include "commands.hpp"
#include "exit_code.hpp"
#include "netkf/link_trace.hpp"
#include "netkf/scenario.hpp"
#include "output_file.hpp"
#include "ros2_cdr_codec.hpp"
#include "trace_extract.hpp"

namespace netkf::cli {
namespace {

struct ExtractArgs {
  std::string recording, output;
  std::string link;  // a sensor id, or "control" (the actuation link)
  std::optional<std::int64_t> first, last;
};

[[noreturn]] void fail(int status, const std::string& message) {
  std::cerr << "netkf trace extract: error: " << message << "\n";
  throw CLI::RuntimeError(status);
}

void run_extract(const ExtractArgs& a) {
  LinkTrace trace;
  try {
    check_output_files({{"-o", a.output}}, {{"the recording", a.recording}});
    const int id = *parse_link_name(a.link);
    // The actuation link's arrivals are in the period recording (nu); a sensor's in the samples.
    const auto codec = ros2::make_fastcdr_codec();  // a ros2-profile MCAP's CDR
    trace = extract_link_trace(id == kControlLinkId ? read_input_arrivals(a.recording, codec.get())
                                                    : read_delivered_samples(a.recording, codec.get()),
                               id, a.first, a.last);
  } catch (const std::exception& e) {
    fail(2, e.what());
  }
  const std::string comment = "netkf trace extract: link " + a.link + " of " + a.recording +
                              ", periods " + std::to_string(trace.first_k) + ".." +
                              std::to_string(trace.first_k + trace.size() - 1) + " (k = period)";
  std::ostringstream text;
  write_link_trace(text, trace, comment);
  try {
    write_output_file({"-o", a.output}, text.str());
  } catch (const CommandError& e) {
    fail(e.exit_status(), e.what());
  }
  std::cout << "wrote " << a.output << ": link " << a.link << ", " << trace.size() << " periods, "
            << trace.delivered_count() << " delivered\n";
}

}  // namespace

void add_trace_command(CLI::App& app) {
  auto* trace = app.add_subcommand("trace", "Link traces: extract the trace a link had in a recording");
  trace->require_subcommand(1);
  auto a = std::make_shared<ExtractArgs>();
  auto* cmd = trace->add_subcommand("extract", "Write the arrival trace (k,delivered) a link had in a recording");
  cmd->add_option("recording", a->recording,
                  "a samples CSV (--record-samples) or an MCAP recorded with samples; for --link control the "
                  "period CSV (--record) or any MCAP of the run")
      ->required();
  cmd->add_option("--link", a->link, "the link: a sensor id, or control (the actuation link)")
      ->required()
      ->check([](const std::string& text) {
        return parse_link_name(text) ? std::string() : "a link is a sensor id or control, got '" + text + "'";
      });
  cmd->add_option("-o,--output", a->output, "the trace CSV to write")->required();
  cmd->add_option("--first", a->first, "first period (default: the first period any link delivered in)");
  cmd->add_option("--last", a->last, "last period (default: the last period any link delivered in)");
  cmd->callback([a] { run_extract(*a); });
}

}  // namespace netkf::cli
