// estimator_node: fuses each period once (all samples in, or the deadline, whichever is
// first), publishes x̂_{k|k}, P_{k|k} every period (never NaN), and in a closed-loop
// scenario sends u_k = -L x̂_{k|k} to the plant. It never sees the truth: the plant's tick
// (k, t_k, applied input) is its only clock. The deadline is a steady_timer.
//
// Threads: delivered samples are handled on the DDS receive thread (bookkeeping, and the fused
// update when a sample completes its period: microseconds, and a hand-off would add a context
// switch per sample to the latency; see endpoints.hpp). Ticks, the deadline and the status log
// run on the io thread, which owns the timers. One mutex guards the estimator core.
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <functional>
#include <mutex>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/log_throttle.hpp"
#include "netkf/nodes/estimator_core.hpp"
#include "netkf/scenario.hpp"

namespace wire = netkf::wire;

namespace {

class EstimatorNode {
 public:
  EstimatorNode(boost::asio::io_context& io, const netkf::Scenario& scenario, netkf::dds::Participant& participant,
                int status_period_ms)
      : io_(io),
        core_(scenario),
        input_dim_(scenario.plant.B ? static_cast<int>(scenario.plant.B->cols()) : 0),
        deadline_timer_(io),
        status_timer_(io),
        status_period_(std::chrono::milliseconds(status_period_ms)),
        estimate_(participant, netkf::dds::topics::estimate),
        control_(participant, netkf::dds::topics::control_input),
        tick_(participant, netkf::dds::topics::tick,
              netkf::dds::post_to<wire::Tick>(io.get_executor(), [this](wire::Tick t) { on_tick(t); })),
        delivered_(participant, netkf::dds::topics::delivered_measurement,
                   [this](wire::Measurement&& m) { on_sample(m); }) {
    schedule_status();
  }

  void stop() {
    deadline_timer_.cancel();
    status_timer_.cancel();
  }

  void log_summary() {
    const std::lock_guard lock(mutex_);
    spdlog::info("published {} estimates (last period {}), late samples {}, rejected {}, state {}", published_,
                 core_.last_fused_period() ? std::to_string(*core_.last_fused_period()) : std::string("none"),
                 core_.late_total(), core_.rejected_total(), netkf::to_string(core_.filter().state()));
  }

 private:
  // io thread
  void on_tick(const wire::Tick& tick) {
    const std::lock_guard lock(mutex_);
    netkf::Vector applied;
    try {
      applied = netkf::dds::tick_applied_input(tick, input_dim_);
    } catch (const std::exception& e) {
      spdlog::warn("tick {}: {}; predicting with zero input", tick.k(), e.what());
    }
    publish(core_.on_tick(tick.k(), applied, netkf::dds::steady_now_ns()));
    if (tick.final_tick()) spdlog::info("the plant ended the run at period {}", tick.k());
    arm_deadline();
  }

  // DDS receive thread
  void on_sample(const wire::Measurement& m) {
    const std::lock_guard lock(mutex_);
    netkf::SensorSample s;
    try {
      s = netkf::dds::to_sensor_sample(m);
    } catch (const std::exception& e) {
      core_.count_rejection(netkf::nodes::SampleRejection::non_finite);
      if (const auto left_out = rejection_log_.allow())
        spdlog::warn("sample of sensor {} for period {} rejected: {}{}", m.sensor_id(), m.k(), e.what(),
                     netkf::dds::left_out_text(*left_out));
      return;
    }
    const auto rejected_before = core_.rejected_total();
    const auto late_before = core_.late_total();
    publish(core_.on_sample(s.sensor_id, m.k(), s.y, m.stamp_ns(), netkf::dds::steady_now_ns()));
    if (core_.rejected_total() != rejected_before) {
      if (const auto left_out = rejection_log_.allow())
        spdlog::warn("sample of sensor {} for period {} rejected ({} rejected so far){}", m.sensor_id(), m.k(),
                     core_.rejected_total(), netkf::dds::left_out_text(*left_out));
    } else if (core_.late_total() != late_before) {
      spdlog::debug("late sample of sensor {} for period {} (period already fused)", m.sensor_id(), m.k());
    }
    // No timer work here: a sample never opens a period (only a tick does), so the deadline
    // armed by the tick stays right; when it fires after the period was fused it finds
    // nothing to do.
  }

  // io thread, with mutex_ held
  void arm_deadline() {
    const auto deadline = core_.pending_deadline_ns();
    if (!deadline || armed_for_ == deadline) return;
    armed_for_ = deadline;
    deadline_timer_.expires_at(std::chrono::steady_clock::time_point(std::chrono::nanoseconds(*deadline)));
    deadline_timer_.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;
      const std::lock_guard lock(mutex_);
      armed_for_.reset();
      publish(core_.on_deadline(netkf::dds::steady_now_ns()));
      arm_deadline();
    });
  }

  void publish(const std::vector<netkf::nodes::PeriodEstimate>& estimates) {
    for (const auto& e : estimates) {
      netkf::dds::EstimateRecord r;
      r.k = e.k;
      r.t = e.t;
      r.x_hat = e.x_hat;
      r.P = e.P;
      r.trace_P_pred = e.trace_P_pred;
      r.fused = e.fused;
      r.late = e.late;
      r.late_sensors = e.late_sensors;
      r.late_total = e.late_total;
      r.rejected_total = e.rejected_total;
      r.state = e.state;
      r.fused_at_ns = e.fused_at_ns;
      r.last_sample_stamp_ns = e.last_sample_stamp_ns;
      try {
        if (e.control) control_.write(netkf::dds::make_control_input(e.k, *e.control));
        r.stamp_ns = netkf::dds::steady_now_ns();
        estimate_.write(netkf::dds::to_wire(r));  // to_wire refuses non-finite values: never NaN on the wire
        ++published_;
      } catch (const std::exception& ex) {
        spdlog::error("estimate for period {} not published: {}", e.k, ex.what());
      }
      if (e.skipped_tick) spdlog::warn("tick {} never arrived: period fused open-loop from a later tick", e.k);
      if (e.state != last_state_) {
        if (e.state == netkf::FilterState::diverging) {
          spdlog::warn("period {}: filter diverging (Tr P = {:.4g}): arrival rates below critical?", e.k, e.P.trace());
        } else {
          spdlog::info("period {}: filter ok again (Tr P = {:.4g})", e.k, e.P.trace());
        }
        last_state_ = e.state;
      }
    }
  }

  void schedule_status() {
    status_timer_.expires_after(status_period_);
    status_timer_.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;
      log_summary();
      schedule_status();
    });
  }

  boost::asio::io_context& io_;
  std::mutex mutex_;  // core_ and the publication state below
  netkf::LogThrottle rejection_log_;  // a broken or rogue sender: a few warnings, then a count
  netkf::nodes::EstimatorCore core_;
  int input_dim_;
  boost::asio::steady_timer deadline_timer_;
  boost::asio::steady_timer status_timer_;
  std::chrono::milliseconds status_period_;
  std::optional<std::int64_t> armed_for_;
  std::uint64_t published_ = 0;
  netkf::FilterState last_state_ = netkf::FilterState::ok;
  netkf::dds::Writer<wire::Estimate> estimate_;
  netkf::dds::Writer<wire::ControlInput> control_;
  netkf::dds::Reader<wire::Tick> tick_;
  netkf::dds::Reader<wire::Measurement> delivered_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"netkf estimator_node: fuses the delivered samples of each period and publishes the estimate"};
  netkf::dds::CommonNodeFlags common;
  int status_period_ms = 10000;
  netkf::dds::add_common_node_flags(app, common);
  app.add_option("--status-period-ms", status_period_ms, "Log a summary this often")
      ->check(CLI::Range(10, 3600000))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    netkf::dds::setup_node_logging("estimator", common.log_level);
    const netkf::Scenario scenario = netkf::load_scenario_file(common.scenario);
    boost::asio::io_context io;
    netkf::dds::Participant participant(netkf::dds::node_participant_options(common, "netkf-estimator", netkf::dds::Role::estimator));
    spdlog::info("scenario '{}': {} sensors, period {} ms, deadline {} ms, {} loop, domain {}", scenario.name,
                 scenario.sensors.size(), scenario.period_ms, scenario.deadline_ms(),
                 scenario.plant.control ? "closed" : "open", participant.domain());
    {
      EstimatorNode node(io, scenario, participant, status_period_ms);
      const netkf::dds::StopOnSignal stop_on_signal(io, [&](int) { node.stop(); });
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
