// `netkf trace extract RUN.csv|RUN.mcap --link ID -o link.csv` (or `FATES.csv --topic T`, a
// relay's record): the arrival trace a link had in a recording, for `netkf fit` or a
// `model: trace` link (docs/cli.md, "netkf trace extract").
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include "netkf/cli/commands/commands.hpp"
#include "netkf/cli/common/exit_code.hpp"
#include "netkf/cli/common/output_file.hpp"
#include "netkf/cli/recording/ros2_cdr_codec.hpp"
#include "netkf/cli/recording/trace_extract.hpp"
#include "netkf/links/link_trace.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::cli {
namespace {

struct ExtractArgs {
  std::string recording, output;
  std::string link;   // a sensor id, or "control" (the actuation link)
  std::string topic;  // or a topic of a `netkf relay --record` file
  std::optional<std::int64_t> first, last;
};

[[noreturn]] void fail(int status, const std::string& message) {
  std::cerr << "netkf trace extract: error: " << message << "\n";
  throw CLI::RuntimeError(status);
}

// `what`: "link 1" or "topic rt/scan"; `unit`: what k counts ("periods", or a topic's "samples").
void write_extracted(const ExtractArgs& a, const LinkTrace& trace, const std::string& what, const std::string& unit) {
  const std::string comment = "netkf trace extract: " + what + " of " + a.recording + ", " + unit + " " +
                              std::to_string(trace.first_k) + ".." + std::to_string(trace.first_k + trace.size() - 1) +
                              (unit == "periods" ? " (k = period)" : " (k = the topic's sample index)");
  std::ostringstream text;
  write_link_trace(text, trace, comment);
  try {
    write_output_file({"-o", a.output}, text.str());
  } catch (const CommandError& e) {
    fail(e.exit_status(), e.what());
  }
  std::cout << "wrote " << a.output << ": " << what << ", " << trace.size() << " " << unit << ", "
            << trace.delivered_count() << " delivered\n";
}

// A launch's recording: the trace of a sensor's link or the actuation link, k the period.
LinkTrace extract_from_launch(const ExtractArgs& a) {
  if (a.link.empty()) throw std::runtime_error("name the link with --link (--topic is for a relay's record)");
  const int id = *parse_link_name(a.link);
  // The actuation link's arrivals are in the period recording (nu); a sensor's in the samples.
  const auto codec = ros2::make_fastcdr_codec();  // a ros2-profile MCAP's CDR
  return extract_link_trace(id == kControlLinkId ? read_input_arrivals(a.recording, codec.get())
                                                 : read_delivered_samples(a.recording, codec.get()),
                            id, a.first, a.last);
}

// A relay's record (`netkf relay --record`): the trace of one topic's link, k its sample index.
LinkTrace extract_from_relay(const ExtractArgs& a) {
  if (a.topic.empty())
    throw std::runtime_error(a.recording + " is a relay's record: name its topic with --topic (not --link)");
  return extract_topic_trace(read_relay_fates(a.recording), a.topic, a.first, a.last);
}

void run_extract(const ExtractArgs& a) {
  LinkTrace trace;
  bool relayed = false;
  try {
    check_output_files({{"-o", a.output}}, {{"the recording", a.recording}});
    relayed = !a.topic.empty() || is_relay_record(a.recording);
    trace = relayed ? extract_from_relay(a) : extract_from_launch(a);
  } catch (const std::exception& e) {
    fail(2, e.what());
  }
  if (relayed) write_extracted(a, trace, "topic " + a.topic, "samples");
  else write_extracted(a, trace, "link " + a.link, "periods");
}

}  // namespace

void add_trace_command(CLI::App& app) {
  auto* trace = app.add_subcommand("trace", "Link traces: extract the trace a link had in a recording");
  trace->require_subcommand(1);
  auto a = std::make_shared<ExtractArgs>();
  auto* cmd = trace->add_subcommand("extract", "Write the arrival trace (k,delivered) a link had in a recording");
  cmd->add_option("recording", a->recording,
                  "a samples CSV (--record-samples) or an MCAP recorded with samples; for --link control the "
                  "period CSV (--record) or any MCAP of the run; for --topic a relay's record")
      ->required();
  auto* link = cmd->add_option("--link", a->link, "the link: a sensor id, or control (the actuation link)")
      ->check([](const std::string& text) {
        return parse_link_name(text) ? std::string() : "a link is a sensor id or control, got '" + text + "'";
      });
  cmd->add_option("--topic", a->topic, "or, in a relay's record (netkf relay --record), the topic")->excludes(link);
  cmd->add_option("-o,--output", a->output, "the trace CSV to write")->required();
  cmd->add_option("--first", a->first,
                  "first period, or a topic's first sample index (default: the first period any link delivered "
                  "in; a topic's first sample in the record)");
  cmd->add_option("--last", a->last,
                  "last period, or a topic's last sample index (default: the last period any link delivered in; "
                  "a topic's last sample in the record)");
  cmd->callback([a] { run_extract(*a); });
}

}  // namespace netkf::cli
