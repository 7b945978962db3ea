// `netkf relay`: the lossy link between two DDS domains for anyone's topics (docs/relay.md).
#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <chrono>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <thread>

#include <spdlog/spdlog.h>

#include "command_options.hpp"
#include "netkf/cli/commands/commands.hpp"
#include "netkf/cli/common/exit_code.hpp"
#include "netkf/cli/common/output_file.hpp"
#include "netkf/cli/common/serve_loop.hpp"
#include "netkf/cli/live/relay_summary.hpp"
#include "netkf/cli/relay/relay_app.hpp"
#include "netkf/dds/participant.hpp"  // resolve_naming
#include "netkf/links/link_keys.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/relay/relay_config.hpp"

namespace netkf::cli {
namespace {

struct RelayCommandOptions {
  std::optional<std::string> file;
  std::optional<int> from_domain;
  std::optional<int> to_domain;
  std::vector<std::string> topics;
  LinkFlags link;
  bool per_writer = false;
  std::optional<std::string> seed;
  std::optional<int> depth;
  std::optional<std::string> record;
  std::optional<std::string> events;
  std::vector<std::string> checks;
  std::optional<std::string> summary;
  std::optional<unsigned short> metrics_port;
  std::optional<std::string> profile;
  std::optional<std::string> naming;
  double duration = 0.0;
};

void print_counts(const std::vector<RelayTopicCounts>& counts) {
  std::printf("%-32s %-36s %10s %10s %10s %9s %8s\n", "topic", "type", "samples", "delivered", "dropped", "loss",
              "refused");
  for (const auto& c : counts) {
    const double loss = c.samples ? static_cast<double>(c.dropped) / static_cast<double>(c.samples) : 0.0;
    std::printf("%-32s %-36s %10llu %10llu %10llu %9.4f %8llu\n", c.topic.c_str(),
                c.type.empty() ? "(no writer seen)" : c.type.c_str(), static_cast<unsigned long long>(c.samples),
                static_cast<unsigned long long>(c.delivered), static_cast<unsigned long long>(c.dropped), loss,
                static_cast<unsigned long long>(c.refused));
  }
  std::fflush(stdout);
}

/// The relay's settings: a relay file's (docs/relay.md), or the flags' (one link for every
/// --topic); --from-domain, --to-domain, --seed and --depth given beside a file override it.
RelayOptions relay_options(const RelayCommandOptions& o) {
  RelayOptions options;
  const LinkKeys keys = link_keys_of(o.link);
  try {
    if (o.file) {
      if (!o.topics.empty() || !keys.empty())
        fail(ExitCode::bad_usage, "give the topics and their links in " + *o.file + " or with --topic and the link "
                                  "flags, not both");
      if (o.per_writer)
        fail(ExitCode::bad_usage, "--per-writer is for --topic; in " + *o.file + " give a topic per_writer: true");
      const RelayConfig file = load_relay_config_file(*o.file);
      options.from_domain = file.from_domain;
      options.to_domain = file.to_domain;
      options.seed = file.seed;
      options.depth = file.depth;
      options.topics = file.topics;
      options.timeline = file.events;
    } else {
      if (o.topics.empty()) fail(ExitCode::bad_usage, "give a relay file or --topic (repeatable) with a link");
      if (keys.empty())
        fail(ExitCode::bad_usage, "give the topics' link: --bernoulli LOSS, --gilbert-elliott P R [LOSS_GOOD "
                                  "LOSS_BAD], --trace FILE or --model with its keys");
      if (!o.from_domain || !o.to_domain) fail(ExitCode::bad_usage, "give --from-domain and --to-domain (or a relay file)");
      const LinkSpec link = link_from_keys(keys);
      for (const auto& t : o.topics) options.topics.push_back({t, link, std::nullopt, o.per_writer});
    }
    if (o.from_domain) options.from_domain = *o.from_domain;
    if (o.to_domain) options.to_domain = *o.to_domain;
    if (o.seed) options.seed = parse_seed(*o.seed);
    if (o.depth) options.depth = *o.depth;
    if (o.events) {
      // A journal holds the session's every change (the file's events that applied, the live
      // ones): it replaces the file's timeline rather than adding to it.
      RelayConfig relay;
      relay.topics = options.topics;
      options.timeline = load_relay_events_file(*o.events, relay);
      spdlog::info("replaying {} change(s) of {}{}", options.timeline.size(), *o.events,
                   o.file ? " instead of the relay file's events" : "");
    }
  } catch (const CommandError&) {
    throw;
  } catch (const std::exception& e) {
    fail(ExitCode::bad_usage, e.what());
  }
  if (options.from_domain == options.to_domain)
    fail(ExitCode::bad_usage, "the two domains must differ (the relay would relay its own samples)");
  return options;
}

/// The files the relay writes, checked before it starts: regular files, none of them an input
/// or another, and the recording and its journal new (a session cannot be recorded again).
void check_relay_outputs(const RelayCommandOptions& o) {
  std::vector<FileArg> recordings, outputs, inputs;
  if (o.record) {
    recordings.push_back({"--record", *o.record});
    recordings.push_back({"--record's journal", relay_journal_file(*o.record).string()});
  }
  outputs = recordings;
  if (o.summary) outputs.push_back({"--summary", *o.summary});
  if (o.file) inputs.push_back({"the relay file", *o.file});
  if (o.events) inputs.push_back({"--events", *o.events});
  check_output_files(outputs, inputs);
  refuse_existing(recordings, "give another name");
}

/// The end of a relay with --check or --summary: the checks' table, the summary's JSON; exit 1
/// when a check failed (as a launch's, run_summary.hpp).
void conclude_relay(const std::vector<Check>& checks, std::ostream* summary_out, const std::string& summary_file,
                    const std::string& end, const std::vector<RelayTopicCounts>& counts) {
  std::vector<RelayTopicSummary> topics;
  for (const auto& c : counts) topics.push_back({c.topic, c.lifetime, c.since_change, c.refused});
  const auto results =
      evaluate_checks(checks, [&topics](const std::string& name) { return measure_relay(topics, name); });
  if (!results.empty()) std::cout << render_check_table(results) << std::flush;
  if (summary_out) {
    errno = 0;
    nlohmann::ordered_json j{{"end", end}};  // as a launch's summary begins
    const auto body = relay_summary_json(topics, results);  // named: items() of a temporary would dangle
    for (const auto& item : body.items()) j[item.key()] = item.value();
    *summary_out << j.dump(2) << "\n";
    summary_out->flush();
    if (!*summary_out)
      fail(ExitCode::run_failed, "cannot write the summary to " + summary_file + ": " + std::strerror(errno));
  }
  if (!all_passed(results)) {
    std::size_t failed = 0;
    for (const auto& r : results) failed += !r.passed;
    fail(ExitCode::run_failed, std::to_string(failed) + " of " + std::to_string(results.size()) + " checks failed");
  }
}

int run_relay(const RelayCommandOptions& o) {
  check_relay_outputs(o);
  RelayOptions options = relay_options(o);
  std::vector<Check> checks;
  std::vector<std::string> topic_names, per_writer_names;
  for (const auto& t : options.topics) (t.per_writer ? per_writer_names : topic_names).push_back(t.name);
  topic_names.insert(topic_names.end(), per_writer_names.begin(), per_writer_names.end());
  for (const auto& text : o.checks) {
    try {
      checks.push_back(parse_relay_check(text, topic_names, per_writer_names));
    } catch (const std::invalid_argument& e) {
      fail(ExitCode::bad_usage, e.what());
    }
  }
  std::unique_ptr<std::ostream> summary_out;
  if (o.summary) summary_out = open_output_stream({"--summary", *o.summary});
  const std::size_t topics = options.topics.size();
  const int from = options.from_domain, to = options.to_domain;
  if (o.profile) options.profile = *o.profile;
  try {
    options.naming = dds::resolve_naming(o.naming, TopicNaming::netkf);
  } catch (const std::exception& e) {
    fail(ExitCode::bad_usage, e.what());
  }
  if (o.record) options.record = *o.record;
  if (o.metrics_port) options.metrics_port = *o.metrics_port;
  std::unique_ptr<RelayApp> app;
  try {
    app = std::make_unique<RelayApp>(std::move(options));
  } catch (const std::exception& e) {
    fail(ExitCode::bad_usage, e.what());
  }
  std::thread relay_thread([&] { app->run(); });
  boost::asio::io_context io;
  bool stop = false;
  boost::asio::signal_set signals(io, SIGINT, SIGTERM);
  signals.async_wait([&](const boost::system::error_code& ec, int) { stop = !ec; });
  const auto start = std::chrono::steady_clock::now();
  std::cerr << "netkf relay: " << topics << " topic(s) from domain " << from << " to domain " << to << "; Ctrl-C stops"
            << std::endl;
  serve(io, std::chrono::milliseconds(100), [&] {
    return !(stop || (o.duration > 0 &&
                      std::chrono::steady_clock::now() - start >= std::chrono::duration<double>(o.duration)));
  });
  signals.cancel();
  app->stop();
  relay_thread.join();
  const auto counts = app->counts();
  app.reset();  // the last samples' fates and the timeline's last changes are written
  print_counts(counts);
  if (summary_out || !checks.empty())
    conclude_relay(checks, summary_out.get(), o.summary.value_or(""), stop ? "signal" : "duration reached", counts);
  return 0;
}

}  // namespace

void add_relay_command(CLI::App& app) {
  auto o = std::make_shared<RelayCommandOptions>();
  auto* cmd = app.add_subcommand(
      "relay", "Relay DDS topics of any type from one domain to another through a lossy link (docs/relay.md)");
  cmd->add_option("file", o->file, "A relay file: the domains and a link per topic (docs/relay.md)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--from-domain", o->from_domain, "The domain the topics' writers are on")->check(CLI::Range(0, 232));
  cmd->add_option("--to-domain", o->to_domain, "The domain the relay writes them on, for the readers there")
      ->check(CLI::Range(0, 232));
  cmd->add_option("--topic", o->topics, "A DDS topic name to relay (e.g. rt/chatter); repeatable");
  add_link_flags(cmd, o->link);
  cmd->add_flag("--per-writer", o->per_writer,
                "Each writer of a --topic its own link, a copy of the link flags' (named TOPIC@PARTICIPANT; "
                "docs/relay.md)");
  cmd->add_option("--seed", o->seed, "Seed of the links' random streams (each topic its own stream; default 1)");
  cmd->add_option("--depth", o->depth, "Keep-last history of the relay's readers and writers (default 100)")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--record", o->record, "A CSV line per sample: topic,index,sequence,bytes,fate,delay_ms (a new file)");
  cmd->add_option("--events", o->events,
                  "Replay a journal (--record FILE wrote FILE.events.yaml): its changes replace the relay file's "
                  "events; the same seed and the same samples make the same decisions")
      ->check(CLI::ExistingFile);
  cmd->add_option("--check", o->checks,
                  "Pass/fail check at the end on a topic's link: link.TOPIC.NAME<VALUE (or <=, >, >=), e.g. "
                  "'link.rt/chatter.observed_loss<0.35'; NAME: samples, delivered, dropped, refused, observed_loss, "
                  "mean_burst, observed_arrival_rate_since_change; repeatable; exit 1 when one fails")
      ->allow_extra_args(false);
  cmd->add_option("--summary", o->summary,
                  "Write each topic's link quantities and every check's verdict as JSON at the end (docs/relay.md)");
  cmd->add_option("--dds-profile", o->profile, "Fast DDS XML profile of both sides (default: built-in localhost-only)");
  cmd->add_option("--naming", o->naming,
                  "Names of netkf's own topics the relay answers and reports on (link control, status, journal): netkf "
                  "or ros2, as the `netkf ctl` that talks to it (default: $NETKF_NAMING, else netkf; the relayed "
                  "topics keep their names)")
      ->check(CLI::IsMember({"netkf", "ros2"}));
  cmd->add_option("--duration", o->duration, "Stop after S seconds (default: until Ctrl-C)")->check(duration_seconds());
  cmd->add_option("--dashboard", o->metrics_port,
                  "Serve the topics' links on 127.0.0.1:PORT (0: a free port, logged): GET /metrics (Prometheus) and a "
                  "Foxglove WebSocket (netkf/link/status; parameters link.ID.KEY set a topic's link); no page yet")
      ->check(CLI::Range(0, 65535));
  cmd->callback([o] { run_command([&] { return run_relay(*o); }); });
}

}  // namespace netkf::cli
