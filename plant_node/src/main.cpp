// plant_node: the stand-in for the physical world (docs/architecture.md). Each period T it steps
// x_{k+1} = A x_k + B u_k + w_k and publishes the truth (netkf/truth) and the sample
// clock with the applied input (netkf/tick). The period is driven by an absolute-deadline
// steady_timer (t_k = t_0 + k T), so periods do not drift.
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/nodes/plant_simulator.hpp"
#include "netkf/scenario.hpp"

namespace {

using namespace std::chrono_literals;
namespace wire = netkf::wire;

struct PlantFlags {
  std::uint64_t max_periods = 0;
  int startup_wait_ms = 10000;
  int truth_readers = -1;  // < 0: one per sensor
  int settle_ms = 500;
};

class PlantNode {
 public:
  PlantNode(boost::asio::io_context& io, const netkf::Scenario& scenario, netkf::dds::Participant& participant,
            const PlantFlags& flags)
      : io_(io),
        scenario_(scenario),
        flags_(flags),
        sim_(scenario),
        period_(std::chrono::milliseconds(scenario.period_ms)),
        timer_(io),
        truth_(participant, netkf::dds::topics::truth),
        tick_(participant, netkf::dds::topics::tick),
        control_(participant, netkf::dds::topics::control_input,
                 netkf::dds::post_to<wire::ControlInput>(io.get_executor(),
                                                         [this](wire::ControlInput c) { on_control(c); })) {}

  /// Wait (bounded) until the sensors and the estimator are matched, so period 0 is seen by all.
  void wait_for_subscribers() {
    const int sensors =
        flags_.truth_readers >= 0 ? flags_.truth_readers : static_cast<int>(scenario_.sensors.size());
    const auto wait = std::chrono::milliseconds(flags_.startup_wait_ms);
    const bool truth_ok = truth_.wait_for_matched(sensors, wait);
    const bool tick_ok = tick_.wait_for_matched(1, wait);
    if (!truth_ok || !tick_ok) {
      spdlog::warn("starting without all subscribers: truth readers {} (want >= {}), tick readers {} (want >= 1)",
                   truth_.matched(), sensors, tick_.matched());
    } else {
      spdlog::info("subscribers matched: truth readers {}, tick readers {}", truth_.matched(), tick_.matched());
    }
    // Matching the plant's writers does not mean sensors already match the channel, etc.
    std::this_thread::sleep_for(std::chrono::milliseconds(flags_.settle_ms));
  }

  void start() {
    start_ = std::chrono::steady_clock::now();
    schedule();
  }

  void stop() {
    stopped_ = true;
    timer_.cancel();
  }

  bool finished() const { return finished_; }

  void log_summary() const {
    spdlog::info("stepped {} periods; control inputs missing at their step {} (of which arrived late {})",
                 sim_.next_period(), sim_.missing_inputs(), sim_.stale_inputs());
  }

 private:
  void schedule() {
    // Absolute deadline: period k fires at start + k T regardless of how long work took.
    timer_.expires_at(start_ + period_ * static_cast<std::int64_t>(sim_.next_period()));
    timer_.async_wait([this](const boost::system::error_code& ec) {
      if (ec || stopped_) return;
      on_period();
    });
  }

  void on_period() {
    netkf::nodes::PlantStep s = sim_.step();
    const bool max_reached = flags_.max_periods > 0 && s.k + 1 >= flags_.max_periods;
    const bool final_period = s.bound_exceeded || max_reached;
    if (s.input_missing) {
      spdlog::debug("period {}: no control input for period {} arrived in time; applied zero", s.k, s.k - 1);
    }
    const netkf::Vector applied = sim_.closed_loop() ? s.applied_input : netkf::Vector();
    if (s.x.allFinite()) truth_.write(netkf::dds::make_truth(s.k, s.t, s.x, applied));
    tick_.write(netkf::dds::make_tick(s.k, s.t, applied, final_period));
    if (s.k % 1000 == 0) {
      spdlog::info("period {} t={:.3f}s |x|_inf={:.4g}; inputs missing so far {} (late: {})", s.k, s.t,
                   s.x.lpNorm<Eigen::Infinity>(), sim_.missing_inputs(), sim_.stale_inputs());
    }
    if (s.bound_exceeded) {
      if (sim_.closed_loop()) {
        spdlog::warn(
            "run ends at period {}: |x|_inf = {:.4g} exceeds plant.state_bound = {:.4g}; the closed loop went "
            "unstable (are the links below the critical arrival rate?)",
            s.k, s.x.lpNorm<Eigen::Infinity>(), scenario_.plant.state_bound);
      } else {
        spdlog::warn(
            "run ends at period {}: |x|_inf = {:.4g} exceeds plant.state_bound = {:.4g}; the plant is open-loop "
            "unstable and the scenario has no control (add plant.B and control to close the loop)",
            s.k, s.x.lpNorm<Eigen::Infinity>(), scenario_.plant.state_bound);
      }
    } else if (max_reached) {
      spdlog::info("run ends after --max-periods {} periods", flags_.max_periods);
    }
    if (final_period) {
      finished_ = true;
      io_.stop();
      return;
    }
    schedule();
  }

  void on_control(const wire::ControlInput& c) {
    try {
      const netkf::Vector u = netkf::dds::control_input_u(c, sim_.input_dim());
      std::string why;
      if (!sim_.set_input(c.k(), u, &why)) {
        // A stale input (fused at the deadline and delivered after the next step) is expected
        // now and then on a loaded machine: the plant applied zero and acknowledged that.
        if (why.find("stale") != std::string::npos) {
          spdlog::debug("control input rejected: {}", why);
        } else {
          spdlog::warn("control input rejected: {}", why);
        }
      }
    } catch (const std::exception& e) {
      spdlog::warn("control input for period {} rejected: {}", c.k(), e.what());
    }
  }

  boost::asio::io_context& io_;
  const netkf::Scenario& scenario_;
  PlantFlags flags_;
  netkf::nodes::PlantSimulator sim_;
  std::chrono::steady_clock::duration period_;
  boost::asio::steady_timer timer_;
  std::chrono::steady_clock::time_point start_;
  bool stopped_ = false;
  bool finished_ = false;
  netkf::dds::Writer<wire::Truth> truth_;
  netkf::dds::Writer<wire::Tick> tick_;
  netkf::dds::Reader<wire::ControlInput> control_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"netkf plant_node: simulates x_{k+1} = A x_k + B u_k + w_k and publishes truth and sample clock"};
  netkf::dds::CommonNodeFlags common;
  PlantFlags flags;
  netkf::dds::add_common_node_flags(app, common);
  app.add_option("--max-periods", flags.max_periods, "Stop after this many periods (0 = unlimited)")
      ->capture_default_str();
  app.add_option("--startup-wait-ms", flags.startup_wait_ms,
                 "Wait at most this long for the sensors and the estimator to match before period 0")
      ->capture_default_str();
  app.add_option("--truth-readers", flags.truth_readers,
                 "Truth readers to wait for before period 0 (default: one per sensor; with sensors grouped "
                 "in processes, one per sensor process; a launcher that also records the truth adds 1)");
  CLI11_PARSE(app, argc, argv);

  try {
    netkf::dds::setup_node_logging("plant", common.log_level);
    const netkf::Scenario scenario = netkf::load_scenario_file(common.scenario);
    boost::asio::io_context io;
    netkf::dds::Participant participant(netkf::dds::node_participant_options(common, "netkf-plant", netkf::dds::Role::plant));
    spdlog::info("scenario '{}' period {} ms, domain {}", scenario.name, scenario.period_ms, participant.domain());
    {
      PlantNode node(io, scenario, participant, flags);
      const netkf::dds::StopOnSignal stop_on_signal(io, [&](int) { node.stop(); });
      node.wait_for_subscribers();
      node.start();
      io.run();
      node.log_summary();
    }
    spdlog::info("left DDS domain {}", participant.domain());
    return 0;
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
}
