// channel_emulator: relays raw measurements to the delivered topic through one link per
// sensor (Bernoulli or Gilbert-Elliott loss, then an optional delay, seeded from the
// scenario), applies the scenario's timeline and the changes from netkf/link/control from a
// period's first sample on, journals every change on netkf/link/change, and publishes link
// status about once a second and after every change (transient-local, so late joiners see it).
//
// Threads: samples are decided and relayed on the DDS receive thread (one draw and a write:
// cheaper than the context switch of a hand-off, see endpoints.hpp); a delayed sample goes
// into the release queue, which the io thread's timer empties at each release time. Link
// changes and status run on the io thread. One mutex guards the links and the queue.
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <functional>
#include <mutex>
#include <optional>
#include <vector>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/log_throttle.hpp"
#include "netkf/nodes/channel_links.hpp"
#include "netkf/nodes/release_queue.hpp"
#include "netkf/scenario.hpp"

namespace wire = netkf::wire;

int main(int argc, char** argv) {
  CLI::App app{"netkf channel_emulator: drops samples per link model and relays the rest; tunable at runtime"};
  netkf::dds::CommonNodeFlags common;
  int status_period_ms = 1000;
  netkf::dds::add_common_node_flags(app, common);
  app.add_option("--status-period-ms", status_period_ms, "Publish link status this often")
      ->check(CLI::Range(10, 3600000))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    netkf::dds::setup_node_logging("channel", common.log_level);
    const netkf::Scenario scenario = netkf::load_scenario_file(common.scenario);
    netkf::nodes::ChannelLinks links(scenario);
    boost::asio::io_context io;
    netkf::dds::Participant participant(netkf::dds::node_participant_options(common, "netkf-channel", netkf::dds::Role::channel));
    spdlog::info("scenario '{}': {} links, domain {}", scenario.name, scenario.sensors.size(), participant.domain());
    for (const auto& r : links.reports()) {
      spdlog::info("link {}: {}; stationary loss {:.4f}, in time for the deadline {:.4f}", r.sensor_id,
                   netkf::describe_link(r.link), netkf::stationary_loss(r.link.loss),
                   netkf::probability_within(r.link.delay, scenario.deadline_ms()));
    }
    if (!scenario.events.empty()) spdlog::info("timeline: {} link events", scenario.events.size());
    {
      netkf::dds::Writer<wire::Measurement> delivered(
          participant, netkf::dds::topics::delivered_measurement,
          static_cast<double>(scenario.sensors.size()) / scenario.period_s());
      netkf::dds::Writer<wire::LinkStatus> status(participant, netkf::dds::topics::link_status);
      netkf::dds::Writer<wire::LinkControlReply> reply(participant, netkf::dds::topics::link_control_reply);

      netkf::dds::Writer<wire::LinkChange> journal(participant, netkf::dds::topics::link_change);

      std::mutex links_mutex;  // the links, the release queue and the throttle
      netkf::nodes::ReleaseQueue<wire::Measurement> held;
      boost::asio::steady_timer release_timer(io);
      netkf::LogThrottle unknown_log;  // a rogue sender: a few warnings, then a count
      auto publish_status = [&] {
        const auto now = netkf::dds::steady_now_ns();
        std::vector<netkf::dds::LinkStatusFacts> facts;
        {
          const std::lock_guard lock(links_mutex);
          for (const auto& r : links.reports()) {
            facts.push_back({r.sensor_id, r.link, netkf::probability_within(r.link.delay, scenario.deadline_ms()),
                             r.stats, r.lifetime, r.last_request_id, r.last_request_rejected, r.reject_reason,
                             held.held(r.sensor_id), r.past_deadline});
          }
        }
        for (const auto& f : facts) status.write(netkf::dds::make_link_status(f, now));
      };

      // Journal entries are written where they are made (a sample or a request: rare, short).
      auto publish_changes = [&](const std::vector<netkf::nodes::AppliedLinkChange>& changes) {
        for (const auto& c : changes) {
          if (!c.failure.empty()) {
            spdlog::warn("timeline: link {} event at period {} not applied: {}", c.sensor_id, c.at_period, c.failure);
            continue;
          }
          if (c.origin == netkf::nodes::AppliedLinkChange::Origin::timeline)
            spdlog::info("timeline: link {} from period {}: {}", c.sensor_id, c.at_period, netkf::describe_link(c.link));
          journal.write(netkf::dds::make_link_change(c.sensor_id, static_cast<std::uint64_t>(c.at_period),
                                                     netkf::nodes::to_string(c.origin), c.request_id, c.link,
                                                     netkf::dds::steady_now_ns()));
        }
      };

      // The release timer: relay what is due, then sleep until the next release. Runs on the
      // io thread; re-armed from the receive thread (posted) when a new earliest sample arrives.
      std::function<void()> release_due = [&] {
        std::vector<wire::Measurement> due;
        std::optional<std::chrono::steady_clock::time_point> next;
        {
          const std::lock_guard lock(links_mutex);
          due = held.take_due(std::chrono::steady_clock::now());
          next = held.next_release();
        }
        for (const auto& m : due) delivered.write(m);
        if (next) {
          release_timer.expires_at(*next);
          release_timer.async_wait([&](const boost::system::error_code& ec) {
            if (!ec) release_due();
          });
        }
      };

      auto on_raw = [&](wire::Measurement&& m) {
        std::uint64_t unknown_so_far = 0;
        bool rearm = false;
        std::vector<netkf::nodes::AppliedLinkChange> changes;
        const auto fate = [&] {
          const std::lock_guard lock(links_mutex);
          const auto f = links.on_sample(m.sensor_id(), static_cast<std::int64_t>(m.k()));
          unknown_so_far = links.unknown_sensor_samples();
          changes = links.take_changes();
          if (f.verdict == netkf::nodes::SampleFate::Verdict::delivered && f.delay_ms > 0.0) {
            const auto release = std::chrono::steady_clock::now() +
                                 std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                     std::chrono::duration<double, std::milli>(f.delay_ms));
            rearm = held.hold(release, m.sensor_id(), m);
          }
          return f;
        }();
        if (!changes.empty()) publish_changes(changes);
        switch (fate.verdict) {
          case netkf::nodes::SampleFate::Verdict::delivered:
            if (fate.delay_ms <= 0.0) {
              delivered.write(m);  // relayed unchanged (stamp is the sensor's publish time)
            } else if (rearm) {
              boost::asio::post(io, [&] { release_due(); });
            }
            break;
          case netkf::nodes::SampleFate::Verdict::dropped:
            spdlog::trace("dropped sensor {} period {}", m.sensor_id(), m.k());
            break;
          case netkf::nodes::SampleFate::Verdict::unknown_sensor: {
            const std::lock_guard lock(links_mutex);  // the throttle's state
            if (const auto left_out = unknown_log.allow())
              spdlog::warn("sample from unknown sensor id {} (period {}) not relayed ({} so far){}", m.sensor_id(),
                           m.k(), unknown_so_far, netkf::dds::left_out_text(*left_out));
            break;
          }
        }
      };

      auto on_control = [&](wire::LinkControl c) {
        netkf::nodes::LinkChangeResult result;
        netkf::LinkSpec applied;
        {
          const std::lock_guard lock(links_mutex);
          result = links.request(c.request_id(), c.sensor_id(), netkf::dds::link_keys_of(c));
          if (result.applied) applied = links.report(c.sensor_id())->link;
        }
        if (result.applied) {
          spdlog::info("request {}: link {} set to {} (stationary loss {:.4f}) from its next sample", c.request_id(),
                       c.sensor_id(), netkf::describe_link(applied), netkf::stationary_loss(applied.loss));
        } else {
          spdlog::warn("request {}: link {} change rejected: {}", c.request_id(), c.sensor_id(), result.reason);
        }
        reply.write(netkf::dds::make_link_control_reply(result.request_id, result.sensor_id, result.applied,
                                                        result.reason));
        publish_status();
      };

      netkf::dds::Reader<wire::Measurement> raw(participant, netkf::dds::topics::raw_measurement, on_raw);
      netkf::dds::Reader<wire::LinkControl> control(
          participant, netkf::dds::topics::link_control,
          netkf::dds::post_to<wire::LinkControl>(io.get_executor(), on_control));

      boost::asio::steady_timer timer(io);
      const auto period = std::chrono::milliseconds(status_period_ms);
      auto next = std::chrono::steady_clock::now();
      std::function<void()> status_loop = [&] {
        publish_status();
        next += period;
        timer.expires_at(next);
        timer.async_wait([&](const boost::system::error_code& ec) {
          if (!ec) status_loop();
        });
      };
      status_loop();

      const netkf::dds::StopOnSignal stop_on_signal(io);
      io.run();
      {
        const std::lock_guard lock(links_mutex);
        if (held.size() > 0) spdlog::info("{} delayed samples still held at shutdown: not relayed", held.size());
      }
      publish_status();  // final counts for late joiners (transient-local)
      status.wait_for_acknowledgments(std::chrono::milliseconds(500));
      const std::lock_guard lock(links_mutex);  // the raw reader still delivers until it is gone
      for (const auto& r : links.reports()) {
        spdlog::info("link {}: in {} delivered {} dropped {} observed loss {:.4f} mean burst {:.3f}", r.sensor_id,
                     r.lifetime.samples(), r.lifetime.delivered(), r.lifetime.dropped(), r.lifetime.observed_loss(),
                     r.lifetime.mean_burst_length());
      }
    }
    spdlog::info("left DDS domain {}", participant.domain());
    return 0;
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
}
