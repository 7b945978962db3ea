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
#include "netkf/cli/commands/commands.hpp"
#include "netkf/cli/common/exit_code.hpp"
#include "netkf/cli/common/serve_loop.hpp"
#include "netkf/cli/common/text.hpp"
#include "netkf/cli/live/channel_catalogue.hpp"
#include "netkf/cli/live/live_bus.hpp"
#include "netkf/cli/live/live_status.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_text.hpp"
#include "netkf/relay/relay_links.hpp"

namespace netkf::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct CtlOptions {
  NetworkSettings network;
  double timeout = 10.0;
  std::string link;  // a sensor id, "control", or a topic a netkf relay relays (docs/relay.md)
  LinkFlags change;
  bool json = false;
};

/// The link keys a `ctl set-link` asks for. Names and number syntax are checked here (exit 2);
/// whether they make a valid link with the link's current state is the channel's answer.
LinkKeys ctl_link_keys(const CtlOptions& o) {
  LinkKeys keys = link_keys_of(o.change);
  if (keys.empty())
    fail(ExitCode::bad_usage, "give what to change: --bernoulli LOSS, --gilbert-elliott P R [LOSS_GOOD LOSS_BAD], --loss, "
            "--mean-burst, --delay, --jitter, --distribution, --model or --set KEY=VALUE");
  return keys;
}

namespace {
// Link status and presence are transient-local: what was discovered arrives in a burst. But
// processes on other hosts are discovered later (a discovery server relays them one by one):
// wait until every presence writer discovered was heard and nothing new came for a grace period
// (400 ms, which alone missed a host's processes under load), at most until `deadline`.
void settle_status(boost::asio::io_context& io, const LiveBus& bus, const std::map<int, LinkStatus>& links,
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
  std::map<int, LinkStatus> links;
  BusHandlers h;
  h.link_status = [&](LinkStatus&& l) { links[l.sensor_id] = std::move(l); };
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
  std::vector<LinkStatus> list;
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
  std::optional<LinkReply> reply;
  std::optional<LinkStatus> acknowledged;
  const std::uint64_t request_id = random_request_id();  // unlikely to collide with another ctl's
  BusHandlers h;
  h.link_reply = [&](LinkReply&& r) {
    if (r.request_id == request_id) reply = r;
  };
  h.link_status = [&](LinkStatus&& l) {
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
  // A link that is neither a sensor id nor control names a topic of `netkf relay` (docs/relay.md).
  const std::optional<int> link_id = parse_link_name(o.link);
  const char* answerer = link_id ? "channel emulator" : "netkf relay";
  if (!run_until(io, [&] { return bus->link_control_readers() > 0 && bus->link_reply_writers() > 0; }, timeout))
    fail(ExitCode::no_network, std::string("no ") + answerer + " found on DDS domain " + std::to_string(bus->domain()) +
                " within " + number_text(o.timeout) + " s (is a " + (link_id ? "network" : "relay") + " running? " +
                (link_id ? "netkf launch" : "netkf relay --to-domain ...") + ")");
  LinkKeys request = keys;
  if (!link_id) request.insert(request.begin(), LinkKey{kRelayTopicKey, o.link});
  if (!bus->send_link_control(request_id, link_id.value_or(relay_topic_link_id(o.link)), request))
    fail(ExitCode::no_network, "DDS refused to send the link change");
  const auto left = timeout - std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start);
  if (!run_until(io, [&] { return reply.has_value(); }, std::max(left, std::chrono::milliseconds(1000))))
    fail(ExitCode::no_network, std::string("no ") + answerer + " answered request " + std::to_string(request_id) +
                " within " + number_text(o.timeout) + " s" + (link_id ? "" : " (is " + o.link + " relayed on this domain?)"));
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
  set->add_option("link", o->link,
                  "The link: a sensor id, control (the actuation link, plant.control.link), or a topic that a netkf relay "
                  "relays to this domain (docs/relay.md)")
      ->required()
      ->check([](const std::string& text) {
        return text.empty() || text.find_first_of(" \t\n") != std::string::npos
                   ? "a link is a sensor id, control or a topic name, got '" + text + "'"
                   : std::string();
      });
  add_link_flags(set, o->change);
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
