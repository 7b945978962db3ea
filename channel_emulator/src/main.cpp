// channel_emulator: relays raw measurements to the delivered topic through one lossy link
// per sensor (Bernoulli or Gilbert-Elliott, seeded from the scenario), applies link changes
// from netkf/link/control from the next sample on, and publishes link status about once a
// second and after every change (transient-local, so late joiners see it).
//
// Threads: samples are decided and relayed on the DDS receive thread (one draw and a write:
// cheaper than the context switch of a hand-off, see endpoints.hpp); link changes and status
// run on the io thread. One mutex guards the links.
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <mutex>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/log_throttle.hpp"
#include "netkf/nodes/channel_links.hpp"
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
    netkf::dds::Participant participant(netkf::dds::node_participant_options(common, "netkf-channel"));
    spdlog::info("scenario '{}': {} links, domain {}", scenario.name, scenario.sensors.size(), participant.domain());
    for (const auto& r : links.reports()) {
      spdlog::info("link {}: {} stationary loss {:.4f}", r.sensor_id, netkf::link_model_name(r.model),
                   netkf::stationary_loss(r.model));
    }
    {
      netkf::dds::Writer<wire::Measurement> delivered(
          participant, netkf::dds::topics::delivered_measurement,
          static_cast<double>(scenario.sensors.size()) / scenario.period_s());
      netkf::dds::Writer<wire::LinkStatus> status(participant, netkf::dds::topics::link_status);
      netkf::dds::Writer<wire::LinkControlReply> reply(participant, netkf::dds::topics::link_control_reply);

      std::mutex links_mutex;
      netkf::LogThrottle unknown_log;  // a rogue sender: a few warnings, then a count
      auto publish_status = [&] {
        const auto now = netkf::dds::steady_now_ns();
        const auto reports = [&] {
          const std::lock_guard lock(links_mutex);
          return links.reports();
        }();
        for (const auto& r : reports) {
          status.write(netkf::dds::make_link_status(r.sensor_id, r.model, r.stats, r.lifetime, r.last_request_id,
                                                    r.last_request_rejected, r.reject_reason, now));
        }
      };

      auto on_raw = [&](wire::Measurement&& m) {
        std::uint64_t unknown_so_far = 0;
        const auto verdict = [&] {
          const std::lock_guard lock(links_mutex);
          const auto v = links.on_sample(m.sensor_id());
          unknown_so_far = links.unknown_sensor_samples();
          return v;
        }();
        switch (verdict) {
          case netkf::nodes::ChannelLinks::Verdict::delivered:
            delivered.write(m);  // relayed unchanged (stamp is the sensor's publish time)
            break;
          case netkf::nodes::ChannelLinks::Verdict::dropped:
            spdlog::trace("dropped sensor {} period {}", m.sensor_id(), m.k());
            break;
          case netkf::nodes::ChannelLinks::Verdict::unknown_sensor: {
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
        netkf::LinkModel applied_model;
        {
          const std::lock_guard lock(links_mutex);
          try {
            result = links.apply(c.request_id(), c.sensor_id(), netkf::dds::to_link_model(c));
          } catch (const std::exception& e) {
            result = links.reject(c.request_id(), c.sensor_id(), e.what());
          }
          if (result.applied) applied_model = links.report(c.sensor_id())->model;
        }
        if (result.applied) {
          spdlog::info("request {}: link {} set to {} (stationary loss {:.4f})", c.request_id(), c.sensor_id(),
                       netkf::link_model_name(applied_model), netkf::stationary_loss(applied_model));
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
      publish_status();  // final counts for late joiners (transient-local)
      status.wait_for_acknowledgments(std::chrono::milliseconds(500));
      const std::lock_guard lock(links_mutex);  // the raw reader still delivers until it is gone
      for (const auto& r : links.reports()) {
        spdlog::info("link {}: in {} delivered {} dropped {} observed loss {:.4f} mean burst {:.3f}", r.sensor_id,
                     r.stats.samples(), r.stats.delivered(), r.stats.dropped(), r.stats.observed_loss(),
                     r.stats.mean_burst_length());
      }
    }
    spdlog::info("left DDS domain {}", participant.domain());
    return 0;
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
}
