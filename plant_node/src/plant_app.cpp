#include "netkf/nodes/plant_app.hpp"

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <algorithm>
#include <chrono>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/dds/presence.hpp"
#include "netkf/nodes/plant_simulator.hpp"
#include "netkf/support/log_throttle.hpp"

namespace netkf::nodes {

namespace wire = netkf::wire;
using namespace std::chrono_literals;

class PlantApp::Impl {
 public:
  Impl(const Scenario& scenario, dds::Participant& participant, PlantAppOptions options)
      : options_(options),
        truth_readers_wanted_(options.truth_readers >= 0 ? options.truth_readers
                                                         : static_cast<int>(scenario.sensors.size())),
        state_bound_(scenario.plant.state_bound),
        on_loss_(scenario.plant.control ? scenario.plant.control->on_loss : OnLoss::zero),
        sim_(scenario),
        period_(std::chrono::milliseconds(scenario.period_ms)),
        timer_(io_),
        startup_timer_(io_),
        truth_(participant, dds::topics::truth),
        tick_(participant, dds::topics::tick),
        run_(participant.run()),
        scenario_hash_(dds::scenario_hash(scenario)) {
    for (const auto& sensor : scenario.sensors) sensor_ids_.push_back(sensor.id);
    if (options_.wait_for_presence) presence_watch_.emplace(participant);
    presence_.emplace(participant, dds::presence_role::plant, std::vector<int>{}, scenario_hash_);
    // The reader last: its callback uses everything above.
    control_.emplace(participant, dds::topics::control_input,
                     dds::post_to<wire::ControlInput>(io_.get_executor(),
                                                      [this](wire::ControlInput c) { on_control(c); }));
  }

  ~Impl() {
    // The reader first: no callback may run into a half-destroyed object.
    control_.reset();
  }

  void run() {
    work_.emplace(io_.get_executor());
    boost::asio::post(io_, [this] { wait_for_subscribers(); });
    io_.run();
    presence_->end(not_ready_     ? "not started: " + *not_ready_
                   : end_detail_  ? *end_detail_
                   : finished_    ? "the run ended"
                                  : "stopped");
    if (not_ready_) throw std::runtime_error(*not_ready_);
  }

  void stop() {
    boost::asio::post(io_, [this] { end(); });
  }

  boost::asio::io_context& io() { return io_; }

  PlantAppStats stats() const {
    const std::lock_guard lock(mutex_);
    return {sim_.next_period(), sim_.missing_inputs(), sim_.stale_inputs(), finished_, reanchored_, periods_skipped_};
  }

  void log_summary() const {
    const auto s = stats();
    spdlog::info("stepped {} periods; control inputs missing at their step {} (of which arrived late {}){}", s.periods,
                 s.missing_inputs, s.stale_inputs,
                 s.clock_reanchored ? fmt::format("; fell behind its clock {} times ({} periods not replayed)",
                                                  s.clock_reanchored, s.periods_behind)
                                    : std::string());
  }

 private:
  // io thread: all below.

  /// Wait (bounded) until the sensors and the estimator are matched, so period 0 is seen by all.
  void wait_for_subscribers() {
    startup_deadline_ = std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.startup_wait_ms);
    poll_subscribers();
  }

  void poll_subscribers() {
    if (stopped_) return;
    if (presence_watch_) {
      // Across hosts nobody counts the readers by hand: presence says who takes part.
      const auto processes = presence_watch_->processes();
      const auto readiness = dds::assess_readiness(processes, sensor_ids_, run_, scenario_hash_);
      if (readiness.conflict) {
        not_ready_ = "refusing to start: " + *readiness.conflict;
        end();
        return;
      }
      // The presences arrive in any order: the readers this plant was told of (its own launch's)
      // count even before theirs has arrived.
      truth_readers_wanted_ = std::max(readiness.truth_readers, std::max(options_.truth_readers, 0));
      if (!readiness.ready) {
        if (std::chrono::steady_clock::now() >= startup_deadline_) {
          std::string missing;
          for (const auto& m : readiness.missing) missing += (missing.empty() ? "" : ", ") + m;
          std::string others;
          for (const auto& p : dds::other_runs(processes, run_)) others += (others.empty() ? "" : ", ") + p.who();
          not_ready_ = "not started: after " + std::to_string(options_.startup_wait_ms) + " ms still missing " +
                       missing + " (no presence on netkf/presence of this run; are their hosts launched with the "
                       "same scenario, --domain and discovery server?)" +
                       (others.empty() ? std::string() : "; present, but of another run (another scenario file or "
                                                         "--run-id): " + others);
          end();
          return;
        }
        startup_timer_.expires_after(10ms);
        startup_timer_.async_wait([this](const boost::system::error_code& ec) {
          if (!ec) poll_subscribers();
        });
        return;
      }
    }
    const bool truth_ok = truth_.matched() >= truth_readers_wanted_;
    const bool tick_ok = tick_.matched() >= options_.tick_readers;
    if ((!truth_ok || !tick_ok) && std::chrono::steady_clock::now() < startup_deadline_) {
      startup_timer_.expires_after(10ms);
      startup_timer_.async_wait([this](const boost::system::error_code& ec) {
        if (!ec) poll_subscribers();
      });
      return;
    }
    if ((!truth_ok || !tick_ok) && presence_watch_) {
      not_ready_ = "not started: every process is present, but after " + std::to_string(options_.startup_wait_ms) +
                   " ms the truth has " + std::to_string(truth_.matched()) + " readers (want " +
                   std::to_string(truth_readers_wanted_) + ") and the tick " + std::to_string(tick_.matched()) +
                   " (want " + std::to_string(options_.tick_readers) + ")";
      end();
      return;
    }
    if (!truth_ok || !tick_ok) {
      spdlog::warn("starting without all subscribers: truth readers {} (want >= {}), tick readers {} (want >= {})",
                   truth_.matched(), truth_readers_wanted_, tick_.matched(), options_.tick_readers);
    } else {
      spdlog::info("subscribers matched: truth readers {}, tick readers {}", truth_.matched(), tick_.matched());
    }
    // Matching the plant's writers does not mean sensors already match the channel, etc.
    startup_timer_.expires_after(std::chrono::milliseconds(options_.settle_ms));
    startup_timer_.async_wait([this](const boost::system::error_code& ec) {
      if (ec || stopped_) return;
      // A reader (a recorder, another host's launch) whose presence arrived during the settle
      // delay is waited for too, so that it also sees period 0.
      if (presence_watch_ && std::chrono::steady_clock::now() < startup_deadline_ &&
          dds::assess_readiness(presence_watch_->processes(), sensor_ids_, run_, scenario_hash_).truth_readers >
              truth_.matched()) {
        poll_subscribers();
        return;
      }
      start();
    });
  }

  void start() {
    start_ = std::chrono::steady_clock::now();
    schedule();
  }

  void schedule() {
    // Absolute deadline: period k fires at start + k T regardless of how long work took.
    const auto k = next_period();
    auto due = start_ + period_ * static_cast<std::int64_t>(k);
    const auto now = std::chrono::steady_clock::now();
    if (now - due > period_) {
      // More than a period behind (the process was stopped, or starved of CPU): the missed
      // periods are not replayed back to back, since none of them could get its control input
      // (the loop needs a period to close). The clock goes on from now, one period per T; the
      // periods keep their numbers and t_k = k T, so the run is shorter in wall time, not in k.
      const auto behind = static_cast<std::uint64_t>((now - due) / period_);
      start_ += now - due;
      due = now;
      ++reanchored_;
      periods_skipped_ += behind;
      if (const auto left_out = reanchor_log_.allow())
        spdlog::warn("period {}: the plant's clock was {} periods behind (its process was stopped or starved of "
                     "CPU); it goes on from now instead of replaying them without control inputs{}",
                     k, behind, dds::left_out_text(*left_out));
    }
    timer_.expires_at(due);
    timer_.async_wait([this](const boost::system::error_code& ec) {
      if (ec || stopped_) return;
      on_period();
    });
  }

  std::uint64_t next_period() const {
    const std::lock_guard lock(mutex_);
    return sim_.next_period();
  }

  void on_period() {
    PlantStep s;
    bool closed_loop = false;
    std::uint64_t missing = 0, stale = 0;
    {
      const std::lock_guard lock(mutex_);
      s = sim_.step();
      closed_loop = sim_.closed_loop();
      missing = sim_.missing_inputs();
      stale = sim_.stale_inputs();
    }
    const bool max_reached = options_.max_periods > 0 && s.k + 1 >= options_.max_periods;
    const bool final_period = s.bound_exceeded || max_reached;
    if (s.input_missing) {
      spdlog::debug("period {}: no control input for period {} arrived in time; applied {}", s.k, s.k - 1,
                    on_loss_ == OnLoss::hold ? "the previous one" : "zero");
    }
    const Vector applied = closed_loop ? s.applied_input : Vector();
    if (s.x.allFinite()) truth_.write(dds::make_truth(s.k, s.t, s.x, applied, !s.input_missing));
    tick_.write(dds::make_tick(s.k, s.t, applied, final_period));
    if (s.k % 1000 == 0) {
      spdlog::info("period {} t={:.3f}s |x|_inf={:.4g}; inputs missing so far {} (late: {})", s.k, s.t,
                   s.x.lpNorm<Eigen::Infinity>(), missing, stale);
    }
    if (s.bound_exceeded) {
      end_detail_ = bound_exceeded_text(s, closed_loop);
      spdlog::warn("run ends: {}", *end_detail_);
    } else if (max_reached) {
      spdlog::info("run ends after --max-periods {} periods", options_.max_periods);
    }
    if (final_period) {
      {
        const std::lock_guard lock(mutex_);
        finished_ = true;
      }
      end();
      return;
    }
    schedule();
  }

  /// Why the run ends at the state bound, as the plant can tell: in a closed loop, whether the
  /// inputs stopped arriving (the estimator or its path stalled) or arrived and did not hold
  /// the state (the links, or an outage upstream of the estimator: the launch names it).
  std::string bound_exceeded_text(const PlantStep& s, bool closed_loop) const {
    const std::string head = fmt::format("{} at period {}: |x|_inf = {:.4g} exceeds plant.state_bound = {:.4g}",
                                         closed_loop ? dds::kPlantDiverged : "the open-loop plant left its bound",
                                         s.k, s.x.lpNorm<Eigen::Infinity>(), state_bound_);
    if (!closed_loop)
      return head + "; the plant is open-loop unstable and the scenario has no control (add plant.B and control "
                    "to close the loop)";
    if (s.inputs_missing_in_a_row >= kStalledInputs)
      return head + fmt::format("; no control input arrived for the last {} periods (since period {}): the "
                                "estimator or its path to the plant stalled",
                                s.inputs_missing_in_a_row, s.k - s.inputs_missing_in_a_row);
    return head + "; the control inputs arrived but did not hold the state (links below the critical arrival "
                  "rate, or samples that stopped reaching the estimator)";
  }
  /// Inputs missing in a row that say the controller stalled rather than lost a few inputs.
  static constexpr std::uint64_t kStalledInputs = 3;

  void on_control(const wire::ControlInput& c) {
    try {
      std::string why;
      bool accepted = false;
      {
        const std::lock_guard lock(mutex_);
        const Vector u = dds::control_input_u(c, sim_.input_dim());
        accepted = sim_.set_input(c.k(), u, &why);
      }
      if (!accepted) {
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

  void end() {
    stopped_ = true;
    timer_.cancel();
    startup_timer_.cancel();
    work_.reset();
    io_.stop();
  }

  boost::asio::io_context io_;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
  PlantAppOptions options_;
  int truth_readers_wanted_;
  double state_bound_;
  OnLoss on_loss_;  // what the actuator applies when an input is missing
  mutable std::mutex mutex_;  // sim_ and finished_ (read by stats() from any thread)
  PlantSimulator sim_;
  bool finished_ = false;
  std::chrono::steady_clock::duration period_;
  boost::asio::steady_timer timer_;          // the period clock
  boost::asio::steady_timer startup_timer_;  // the subscriber poll, then the settle delay
  std::chrono::steady_clock::time_point startup_deadline_;
  std::chrono::steady_clock::time_point start_;
  bool stopped_ = false;
  dds::Writer<wire::Truth> truth_;
  dds::Writer<wire::Tick> tick_;
  std::uint64_t run_;
  std::uint64_t scenario_hash_;
  std::vector<int> sensor_ids_;
  std::optional<dds::PresenceWatcher> presence_watch_;  // with wait_for_presence
  std::optional<std::string> not_ready_;                // why the run did not start
  std::optional<std::string> end_detail_;               // why the run ended (the state bound)
  std::uint64_t reanchored_ = 0;                        // times the clock fell behind a period
  std::uint64_t periods_skipped_ = 0;                   // periods it fell behind in all
  LogThrottle reanchor_log_;
  std::optional<dds::Reader<wire::ControlInput>> control_;
  std::optional<dds::PresenceAnnouncer> presence_;
};

PlantApp::PlantApp(const Scenario& scenario, dds::Participant& participant, PlantAppOptions options)
    : impl_(std::make_unique<Impl>(scenario, participant, options)) {}
PlantApp::~PlantApp() = default;
void PlantApp::run() { impl_->run(); }
void PlantApp::stop() { impl_->stop(); }
boost::asio::io_context& PlantApp::io() { return impl_->io(); }
PlantAppStats PlantApp::stats() const { return impl_->stats(); }
void PlantApp::log_summary() const { impl_->log_summary(); }

}  // namespace netkf::nodes
