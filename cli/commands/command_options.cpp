#include "command_options.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>

#include "netkf/cli/common/exit_code.hpp"
#include "netkf/links/link_keys.hpp"

namespace netkf::cli {

void add_network_options(CLI::App* cmd, NetworkSettings& network) {
  cmd->add_option("--domain", network.domain, "DDS domain id (default: $NETKF_DOMAIN, else 0)")->check(CLI::Range(0, 232));
  cmd->add_option("--dds-profile", network.profile,
                  "Fast DDS XML profile (default: $NETKF_DDS_PROFILE, else built-in localhost-only)");
  cmd->add_option("--secure", network.secure,
                  "DDS Security: the directory made by `netkf security init` (default: $NETKF_SECURE, else none)");
  cmd->add_option("--discovery-server", network.discovery_server,
                  "Discover the network through the Fast DDS Discovery Server at ADDR:PORT, e.g. on another host "
                  "(default: $NETKF_DISCOVERY_SERVER, else the localhost-only profile; deploy/README.md)");
  cmd->add_option("--naming", network.naming,
                  "Topic and type names of the network: netkf, or ros2 (rt/netkf/..., netkf_msgs; docs/ros2.md) "
                  "(default: $NETKF_NAMING, else the scenario's naming, else netkf)")
      ->check(CLI::IsMember({"netkf", "ros2"}));
}

CLI::Validator seconds_in(double min, double max, bool above_min) {
  return CLI::Validator(
      [=](std::string& v) -> std::string {
        double s = std::nan("");
        try {
          std::size_t used = 0;
          s = std::stod(v, &used);
          if (used != v.size()) s = std::nan("");
        } catch (const std::exception&) {  // not a number, or out of double's range (1e999)
        }
        const std::string problem = seconds_problem(s, min, max, above_min);
        return problem.empty() ? problem : problem + ", got '" + v + "'";
      },
      "SECONDS");
}

CLI::Validator timeout_seconds() { return seconds_in(0.0, 3600.0, /*above_min=*/true); }

CLI::Validator duration_seconds() { return seconds_in(0.0, kMaxDurationSeconds); }

void run_command(const std::function<int()>& body) {
  int rc = 0;
  try {
    rc = body();
  } catch (const CommandError& e) {
    std::cerr << "netkf: error: " << e.what() << "\n";
    throw CLI::RuntimeError(e.exit_status());
  }
  if (rc != 0) throw CLI::RuntimeError(rc);
}

void add_link_flags(CLI::App* cmd, LinkFlags& flags) {
  auto* b = cmd->add_option("--bernoulli", flags.bernoulli, "i.i.d. drops with probability LOSS");
  auto* ge = cmd->add_option("--gilbert-elliott", flags.gilbert_elliott,
                             "Gilbert-Elliott P R [LOSS_GOOD LOSS_BAD] (defaults 0 and 1)")
                 ->expected(2, 4);
  b->excludes(ge);
  cmd->add_option("--model", flags.model, link_model_choices() + " (with the keys of that model)");
  cmd->add_option("--trace", flags.trace, "Replay a trace file (k,delivered[,delay_ms]): model trace; --set loop=, offset=");
  cmd->add_option("--loss", flags.loss,
                  "Loss: a bernoulli link's P(drop), or a gilbert_elliott link's stationary loss (with --mean-burst)");
  cmd->add_option("--mean-burst", flags.mean_burst,
                  "gilbert_elliott by the user's form: mean length of a run of drops (>= 1), with --loss");
  cmd->add_option("--delay", flags.delay, "Base delay of a delivered sample, ms");
  cmd->add_option("--jitter", flags.jitter, "Spread of the delay, ms (half-width, sd or scale: see --distribution)");
  cmd->add_option("--distribution", flags.distribution, "Delay distribution: uniform, normal, pareto, paretonormal");
  cmd->add_option("--set", flags.set, "Any link key: KEY=VALUE (docs/scenario-format.md, \"Links\"); repeatable");
}

namespace {

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
  for (const LinkModel& probe : one_link_of_each_model()) {
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

}  // namespace

LinkKeys link_keys_of(const LinkFlags& o) {
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
  if (keys.empty()) return keys;
  return checked_link_keys(absolute_trace_paths(std::move(keys)));
}

}  // namespace netkf::cli
