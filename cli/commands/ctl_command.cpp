// `netkf ctl`: tune the links of a running network (set-link) and show their status.
#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/io_context.hpp>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <tuple>

#include "command_options.hpp"
#include "commands.hpp"
#include "exit_code.hpp"
#include "channel_catalogue.hpp"
#include "live_bus.hpp"
#include "live_status.hpp"
#include "serve_loop.hpp"
#include "text.hpp"

namespace netkf::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct CtlOptions {
  NetworkSettings network;
  double timeout = 10.0;
  std::string link;  // a sensor id, or "control"
  std::optional<double> bernoulli;
  std::vector<double> gilbert_elliott;
  std::optional<std::string> model;
  std::optional<double> loss;
  std::optional<double> mean_burst;
  std::optional<double> delay;
  std::optional<double> jitter;
  std::optional<std::string> distribution;
  std::optional<std::string> trace;
  std::vector<std::string> set;  // KEY=VALUE
  bool json = false;
};

LinkKeys absolute_trace_paths(LinkKeys keys);
LinkKeys checked_link_keys(const LinkKeys& keys);

/// The link keys a `ctl set-link` asks for. Names and number syntax are checked here (exit 2);
/// whether they make a valid link with the link's current state is the channel's answer.
LinkKeys ctl_link_keys(const CtlOptions& o) {
  LinkKeys keys;
  if (o.bernoulli) {
    keys.push_back({"model", std::string("bernoulli")});
    keys.push_back({"loss", *o.bernoulli});
  }
  if (!o.gilbert_elliott.empty()) {
    if (o.gilbert_elliott.size() != 2 && o.gilbert_elliott.size() != 4)
      fail(ExitCode::bad_usage, "--gilbert-elliott takes P R [LOSS_GOOD LOSS_BAD] (2 or 4 numbers), got " +
                  std::to_string(o.gilbert_elliott.size()));
    keys.push_back({"model", std::string("gilbert_elliott")});
    keys.push_back({"p", o.gilbert_elliott[0]});
    keys.push_back({"r", o.gilbert_elliott[1]});
    if (o.gilbert_elliott.size() == 4) {
      keys.push_back({"loss_good", o.gilbert_elliott[2]});
      keys.push_back({"loss_bad", o.gilbert_elliott[3]});
    }
  }
  if (o.model) keys.push_back({"model", *o.model});
  if (o.loss) keys.push_back({"loss", *o.loss});
  if (o.mean_burst) keys.push_back({"mean_burst", *o.mean_burst});
  if (o.delay) keys.push_back({"delay_ms", *o.delay});
  if (o.jitter) keys.push_back({"jitter_ms", *o.jitter});
  if (o.distribution) keys.push_back({"delay_distribution", *o.distribution});
  if (o.trace) {
    keys.push_back({"model", std::string("trace")});
    keys.push_back({"trace", *o.trace});
  }
  for (const auto& kv : o.set) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) fail(ExitCode::bad_usage, "--set takes KEY=VALUE, got '" + kv + "'");
    const std::string name = kv.substr(0, eq);
    const std::string text = kv.substr(eq + 1);
    if (link_key_is_word(name)) {
      keys.push_back({name, text});
      continue;
    }
    std::size_t used = 0;
    double value = 0.0;
    try {
      value = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != text.size()) fail(ExitCode::bad_usage, "--set " + name + ": '" + text + "' is not a number");
    keys.push_back({name, value});
  }
  if (keys.empty())
    fail(ExitCode::bad_usage, "give what to change: --bernoulli LOSS, --gilbert-elliott P R [LOSS_GOOD LOSS_BAD], --loss, "
            "--mean-burst, --delay, --jitter, --distribution, --model or --set KEY=VALUE");
  return checked_link_keys(absolute_trace_paths(std::move(keys)));
}

/// A trace file is named from here: the channel gets its absolute path (it reads it on its
/// host, which for a local session is this one).
LinkKeys absolute_trace_paths(LinkKeys keys) {
  for (auto& key : keys) {
    if (key.name != "trace" || !std::holds_alternative<std::string>(key.value)) continue;
    const std::string& name = std::get<std::string>(key.value);
    std::error_code ec;
    if (!name.empty()) key.value = std::filesystem::absolute(name, ec).lexically_normal().string();
  }
  return keys;
}

/// Names, duplicates and word/number kinds: the link type's own check, on a link of the
/// model asked for (or of each model) so that only the current state is left to the channel.
/// A trace file is read here too: an unreadable or malformed one is refused before it is sent.
LinkKeys checked_link_keys(const LinkKeys& keys) {
  const bool has_model = std::any_of(keys.begin(), keys.end(), [](const LinkKey& k) { return k.name == "model"; });
  std::string first_problem;
  for (const LinkSpec& probe : {LinkSpec(BernoulliLink{0.5}), LinkSpec(GilbertElliottLink{0.1, 0.5, 0.0, 1.0})}) {
    try {
      (void)apply_link_keys(probe, keys);
      return keys;
    } catch (const LinkError& e) {
      // loop or offset alone change a trace link the channel has: only it can check them.
      if (!has_model && (e.key() == "loop" || e.key() == "offset")) return keys;
      if (first_problem.empty()) first_problem = e.what();
    }
  }
  fail(ExitCode::bad_usage, "invalid link change: " + first_problem);
}

namespace {
// Link status and presence are transient-local: what was discovered arrives in a burst. But
// processes on other hosts are discovered later (a discovery server relays them one by one):
// wait until every presence writer discovered was heard and nothing new came for a grace period
// (400 ms, which alone missed a host's processes under load), at most until `deadline`.
void settle_status(boost::asio::io_context& io, const LiveBus& bus, const std::map<int, LinkStatusRecord>& links,
                   Clock::time_point deadline) {
  constexpr auto grace = std::chrono::milliseconds(400);
  const auto heard = [&] {
    std::size_t running = 0;
    for (const auto& p : bus.processes()) running += p.alive ? 1 : 0;
    return std::tuple{links.size(), running, bus.presence_announcers()};
  };
  auto last = heard();
  auto quiet_since = Clock::now();
  while (Clock::now() < deadline) {
    run_until(io, [] { return false; }, std::chrono::milliseconds(100));
    const auto now = heard();
    if (now != last) {
      last = now;
      quiet_since = Clock::now();
    } else if (Clock::now() - quiet_since >= grace && std::get<1>(now) >= static_cast<std::size_t>(std::get<2>(now))) {
      return;
    }
  }
}
}  // namespace

int run_ctl_status(const CtlOptions& o) {
  boost::asio::io_context io;
  std::map<int, LinkStatusRecord> links;
  BusHandlers h;
  h.link_status = [&](LinkStatusRecord&& l) { links[l.sensor_id] = std::move(l); };
  std::unique_ptr<LiveBus> bus;
  try {
    BusOptions bus_options = o.network.bus("netkf-ctl", dds::Role::observer);
    bus_options.presence = BusOptions::Presence{};  // watch who takes part, without announcing
    bus = std::make_unique<LiveBus>(io, bus_options, h, false);
  } catch (const std::exception& e) {
    fail(ExitCode::bad_usage, std::string("DDS: ") + e.what());
  }
  const auto timeout = std::chrono::milliseconds(static_cast<int>(o.timeout * 1000));
  if (!run_until(io, [&] { return !links.empty(); }, timeout))
    fail(ExitCode::no_network, "no link status received within " + number_text(o.timeout) + " s on DDS domain " +
                std::to_string(bus->domain()) + " (is a network running? netkf launch)");
  settle_status(io, *bus, links, Clock::now() + timeout);
  std::vector<LinkStatusRecord> list;
  for (auto& [id, l] : links) list.push_back(l);
  // The processes of the network, on every host (presence), running ones first.
  std::vector<dds::PresenceRecord> processes;
  for (const auto& p : bus->processes())
    if (p.running()) processes.push_back(p);
  if (o.json) {
    nlohmann::json j{{"domain", bus->domain()}, {"links", nlohmann::json::array()},
                     {"processes", nlohmann::json::array()}};
    for (const auto& l : list) j["links"].push_back(catalogue::link_status_json(l));
    for (const auto& p : processes) {
      j["processes"].push_back({{"role", p.role}, {"sensor_ids", p.sensor_ids}, {"host", p.host}, {"pid", p.pid},
                                {"run", hex_id(p.run)}, {"detail", p.detail}});
    }
    std::cout << j.dump(2) << "\n";
  } else {
    std::cout << render_link_table(list);
    if (!processes.empty()) {
      std::cout << "\nprocesses (" << processes.size() << "):\n";
      for (const auto& p : processes)
        std::cout << "  " << p.who() << (p.detail.empty() ? "" : ": " + p.detail) << "\n";
    }
  }
  return 0;
}

int run_ctl_set_link(const CtlOptions& o) {
  const LinkKeys keys = ctl_link_keys(o);

  boost::asio::io_context io;
  std::optional<LinkReplyRecord> reply;
  std::optional<LinkStatusRecord> acknowledged;
  const std::uint64_t request_id = random_request_id();  // unlikely to collide with another ctl's
  BusHandlers h;
  h.link_reply = [&](LinkReplyRecord&& r) {
    if (r.request_id == request_id) reply = r;
  };
  h.link_status = [&](LinkStatusRecord&& l) {
    if (l.last_request_id == request_id) acknowledged = l;
  };
  std::unique_ptr<LiveBus> bus;
  try {
    bus = std::make_unique<LiveBus>(io, o.network.bus("netkf-ctl", dds::Role::ctl), h, true);
  } catch (const std::exception& e) {
    fail(ExitCode::bad_usage, std::string("DDS: ") + e.what());
  }
  const auto timeout = std::chrono::milliseconds(static_cast<int>(o.timeout * 1000));
  const auto start = Clock::now();
  if (!run_until(io, [&] { return bus->link_control_readers() > 0 && bus->link_reply_writers() > 0; }, timeout))
    fail(ExitCode::no_network, "no channel emulator found on DDS domain " + std::to_string(bus->domain()) + " within " +
                number_text(o.timeout) + " s (is a network running? netkf launch)");
  const int sensor_id = *parse_link_name(o.link);
  if (!bus->send_link_control(request_id, sensor_id, keys)) fail(ExitCode::no_network, "DDS refused to send the link change");
  const auto left = timeout - std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start);
  if (!run_until(io, [&] { return reply.has_value(); }, std::max(left, std::chrono::milliseconds(1000))))
    fail(ExitCode::no_network, "the channel emulator did not answer request " + std::to_string(request_id) + " within " +
                number_text(o.timeout) + " s");
  if (!reply->applied) fail(ExitCode::refused, "link " + o.link + ": change rejected: " + reply->reason);
  // Show the status that acknowledges the request (published right after applying).
  run_until(io, [&] { return acknowledged.has_value(); }, std::chrono::milliseconds(2000));
  if (acknowledged) {
    const auto& l = *acknowledged;
    std::cout << "link " << o.link << ": applied " << describe_link(l.link) << " (request " << request_id
              << ", effective arrival rate " << l.arrival_rate() << ")\n";
    std::cout << render_link_table({l});
  } else {
    std::cout << "link " << o.link << ": applied (request " << request_id << ")\n";
  }
  return 0;
}

}  // namespace

void add_ctl_command(CLI::App& app) {
  auto o = std::make_shared<CtlOptions>();
  auto* cmd = app.add_subcommand("ctl", "Tune links of a running network and show their status");
  cmd->require_subcommand(1);
  auto* set = cmd->add_subcommand(
      "set-link", "Change one link from its next sample on: only what is given changes (e.g. --delay keeps the loss)");
  set->add_option("link", o->link, "The link: a sensor id, or control (the actuation link, plant.control.link)")
      ->required()
      ->check([](const std::string& text) {
        return parse_link_name(text) ? std::string() : "a link is a sensor id or control, got '" + text + "'";
      });
  auto* b = set->add_option("--bernoulli", o->bernoulli, "i.i.d. drops with probability LOSS");
  auto* ge = set->add_option("--gilbert-elliott", o->gilbert_elliott,
                             "Gilbert-Elliott P R [LOSS_GOOD LOSS_BAD] (defaults 0 and 1)")
                 ->expected(2, 4);
  b->excludes(ge);
  set->add_option("--model", o->model, "bernoulli, gilbert_elliott or trace (with the keys of that model)");
  set->add_option("--trace", o->trace, "Replay a trace file (k,delivered[,delay_ms]): model trace; --set loop=, offset=");
  set->add_option("--loss", o->loss,
                  "Loss: a bernoulli link's P(drop), or a gilbert_elliott link's stationary loss (with --mean-burst)");
  set->add_option("--mean-burst", o->mean_burst,
                  "gilbert_elliott by the user's form: mean length of a run of drops (>= 1), with --loss");
  set->add_option("--delay", o->delay, "Base delay of a delivered sample, ms");
  set->add_option("--jitter", o->jitter, "Spread of the delay, ms (half-width, sd or scale: see --distribution)");
  set->add_option("--distribution", o->distribution, "Delay distribution: uniform, normal, pareto, paretonormal");
  set->add_option("--set", o->set, "Any link key: KEY=VALUE (docs/scenario-format.md, \"Links\"); repeatable");
  add_network_options(set, o->network);
  set->add_option("--timeout", o->timeout, "Seconds to wait for the channel emulator's answer")->check(timeout_seconds());
  set->callback([o] { run_command([&] { return run_ctl_set_link(*o); }); });
  auto* status = cmd->add_subcommand("status", "Table of links (model, counts, observed loss)");
  status->add_flag("--json", o->json, "One JSON object on stdout");
  add_network_options(status, o->network);
  status->add_option("--timeout", o->timeout, "Seconds to wait for the first link status")->check(timeout_seconds());
  status->callback([o] { run_command([&] { return run_ctl_status(*o); }); });
}

}  // namespace netkf::cli
