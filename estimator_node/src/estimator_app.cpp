#include "netkf/nodes/estimator_app.hpp"

#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <vector>

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/dds/presence.hpp"
#include "netkf/support/log_throttle.hpp"

namespace netkf::nodes {

namespace wire = netkf::wire;


class EstimatorApp::Impl {
 public:
  Impl(const Scenario& scenario, dds::Participant& participant, EstimatorAppOptions options)
      : core_(scenario),
        input_dim_(scenario.plant.B ? static_cast<int>(scenario.plant.B->cols()) : 0),
        controls_(scenario.plant.control.has_value()),
        deadline_timer_(io_),
        status_timer_(io_),
        status_period_(std::chrono::milliseconds(options.status_period_ms)),
        liveliness_timer_(io_),
        readers_timer_(io_),
        estimate_(participant, dds::topics::estimate, dds::WriterOptions{.ownership_strength = options.ownership_strength}),
        // With an actuation link the inputs go to the channel emulator, which relays them to
        // the plant on that link (dds/topics.hpp).
        control_(participant, scenario.actuation_link() ? dds::topics::sent_control_input : dds::topics::control_input,
                 dds::WriterOptions{.ownership_strength = options.ownership_strength}) {
    if (options.resume) {
      resumed_ = true;
      core_.resume(*options.resume);
      spdlog::info("restart {}: resuming after period {} (Tr P = {:.4g}); the periods missed since are fused "
                   "with nothing, predicted with the inputs the plant acknowledged",
                   options.resume->restarts + 1, options.resume->k, options.resume->P.trace());
    }
    // The readers last: their callbacks use everything above. The tick topic is transient-local,
    // so a restarted estimator receives the recent ticks (and the inputs they acknowledge).
    tick_.emplace(participant, dds::topics::tick,
                  dds::post_to<wire::Tick>(io_.get_executor(), [this](wire::Tick t) { on_tick(t); }));
    delivered_.emplace(participant, dds::topics::delivered_measurement,
                       [this](wire::Measurement&& m) { on_sample(m); });
    // A batch's samples are handled one by one, exactly as if each had come alone (the batch's
    // run was checked by the reader; the elements' own is not read).
    delivered_batch_.emplace(participant, dds::topics::delivered_measurement_batch, [this](wire::MeasurementBatch&& b) {
      for (const auto& m : b.samples()) on_sample(m);
    });
    // Its presence (what the plant waits for before period 0) once its readers matched: run().
    announce_ = [this, &participant, hash = dds::scenario_hash(scenario)] {
      presence_.emplace(participant, dds::presence_role::estimator, std::vector<int>{}, hash);
    };
    schedule_status();
    push_back_liveliness_check();
  }

  // Before it says it is present (the plant starts period 0 when every process is), the estimator
  // waits (bounded) until a reader of its estimates (the launch's) and, in a closed loop, the
  // plant's control reader have matched its writers: the topics are volatile, and an estimate or
  // an input written before is lost (the recording once began with 39 periods without an estimate).
  //
  // A restarted estimator publishes the periods it missed at once, as soon as the transient-local
  // ticks arrive. The estimate topic is volatile: a reader that has not matched the new writer
  // by then loses them (e2e fault_estimator once recorded 15 periods too few). So its ticks are
  // held (bounded) until some reader has matched; samples that arrive meanwhile wait in the core.
  //
  // In a closed loop the plant's control reader must have matched too: an input written before
  // that is lost (the topic is volatile), and the plant runs open loop until the first input
  // reaches it. Under load a restarted process's control writer matched up to a second after it
  // started (the network discovers a new participant at its periodic announcement): holding the
  // ticks costs nothing, since no input of this life could reach the plant earlier anyway, and the
  // warm spare (`netkf launch`) is what makes the wait short. The wait polls on the io thread, so a
  // signal still stops the node at once.
  void hold_ticks_until_readers_match() {
    holding_ticks_ = true;
    readers_wait_started_ = std::chrono::steady_clock::now();
    poll_readers();
  }

  // io thread
  void poll_readers() {
    constexpr auto kWait = std::chrono::seconds(5);
    const bool estimate_ok = estimate_.matched() >= 1;
    const bool control_ok = !controls_ || control_.matched() >= 1;
    const auto waited = std::chrono::steady_clock::now() - readers_wait_started_;
    if ((!estimate_ok || !control_ok) && waited < kWait) {
      readers_timer_.expires_after(std::chrono::milliseconds(2));
      readers_timer_.async_wait([this](const boost::system::error_code& ec) {
        if (!ec) poll_readers();
      });
      return;
    }
    if (!estimate_ok)
      spdlog::warn("no reader of {} matched within {} s; going on anyway", estimate_.topic_name(),
                   kWait.count());
    if (!control_ok)
      spdlog::warn("the control input's reader ({}) did not match within {} s; going on anyway",
                   control_.topic_name(), kWait.count());
    const auto text = fmt::format("the readers of the estimate{} matched {:.0f} ms after the start; {} ticks were held",
                                  controls_ ? " and the control input" : "",
                                  std::chrono::duration<double, std::milli>(waited).count(), held_ticks_.size());
    if (resumed_) spdlog::info("restart: {}", text);
    else spdlog::debug("{}", text);
    if (announce_) std::exchange(announce_, {})();
    holding_ticks_ = false;
    auto held = std::move(held_ticks_);
    held_ticks_.clear();
    for (const auto& t : held) on_tick(t);
  }

  ~Impl() {
    // The readers first: no callback may run into a half-destroyed object.
    delivered_batch_.reset();
    delivered_.reset();
    tick_.reset();
  }

  void run() {
    work_.emplace(io_.get_executor());
    boost::asio::post(io_, [this] { hold_ticks_until_readers_match(); });
    io_.run();
  }

  void stop() {
    boost::asio::post(io_, [this] {
      deadline_timer_.cancel();
      status_timer_.cancel();
      liveliness_timer_.cancel();
      readers_timer_.cancel();
      work_.reset();
      io_.stop();
    });
  }

  boost::asio::io_context& io() { return io_; }

  EstimatorAppStats stats() const {
    const std::lock_guard lock(mutex_);
    EstimatorAppStats s;
    s.published = published_;
    s.revisions = revisions_;
    s.late_fused_total = core_.late_fused_total();
    s.last_fused_period = core_.last_fused_period();
    s.late_total = core_.late_total();
    s.rejected_total = core_.rejected_total();
    s.restarts = core_.restarts();
    s.state = core_.filter().state();
    return s;
  }

  void log_summary() const {
    const auto s = stats();
    std::string reasons;
    {
      const std::lock_guard lock(mutex_);
      for (int r = 0; r < static_cast<int>(SampleRejection::count_); ++r) {
        const auto reason = static_cast<SampleRejection>(r);
        if (const auto n = core_.rejected(reason))
          reasons += (reasons.empty() ? " (" : ", ") + std::string(to_string(reason)) + " " + std::to_string(n);
      }
      if (!reasons.empty()) reasons += ")";
    }
    const std::string revised =
        core_.max_delay_periods() > 0 ? fmt::format(" ({} of them revisions; {} late samples fused into them)",
                                                    s.revisions, s.late_fused_total)
                                      : std::string();
    spdlog::info("published {} estimates{} (last period {}), late samples {}, rejected {}{}, state {}{}", s.published,
                 revised, s.last_fused_period ? std::to_string(*s.last_fused_period) : std::string("none"),
                 s.late_total, s.rejected_total, reasons, netkf::to_string(s.state),
                 s.restarts ? ", restarts " + std::to_string(s.restarts) : std::string());
  }

  bool wait_for_estimate_readers(int n, std::chrono::milliseconds timeout) const {
    return estimate_.wait_for_matched(n, timeout);
  }

 private:
  // io thread
  void on_tick(const wire::Tick& tick) {
    if (holding_ticks_) {
      held_ticks_.push_back(tick);
      return;
    }
    const std::lock_guard lock(mutex_);
    Vector applied;
    try {
      applied = dds::tick_applied_input(tick, input_dim_);
    } catch (const std::exception& e) {
      spdlog::warn("tick {}: {}; predicting with zero input", tick.k(), e.what());
    }
    publish(core_.on_tick(tick.k(), applied, dds::steady_now_ns()));
    if (tick.final_tick()) spdlog::info("the plant ended the run at period {}", tick.k());
    arm_deadline();
  }

  // DDS receive thread
  void on_sample(const wire::Measurement& m) {
    const std::lock_guard lock(mutex_);
    SensorSample s;
    try {
      s = dds::to_sensor_sample(m);
    } catch (const std::exception& e) {
      core_.count_rejection(SampleRejection::non_finite);
      if (const auto left_out = rejection_log_.allow())
        spdlog::warn("sample of sensor {} for period {} rejected: {}{}", m.sensor_id(), m.k(), e.what(),
                     dds::left_out_text(*left_out));
      return;
    }
    const auto rejected_before = core_.rejected_total();
    const auto late_before = core_.late_total();
    publish(core_.on_sample(s.sensor_id, m.k(), s.y, m.stamp_ns(), dds::steady_now_ns()));
    // late_policy fuse_within: a late sample was kept; the re-run (up to D + 1 fused updates) runs
    // on the io thread, not here, and one re-run serves every late sample that came meanwhile.
    if (core_.revision_pending() && !revise_posted_) {
      revise_posted_ = true;
      boost::asio::post(io_, [this] { revise(); });
    }
    if (core_.rejected_total() != rejected_before) {
      if (const auto left_out = rejection_log_.allow())
        spdlog::warn("sample of sensor {} for period {} rejected ({} rejected so far){}", m.sensor_id(), m.k(),
                     core_.rejected_total(), dds::left_out_text(*left_out));
    } else if (core_.late_total() != late_before) {
      spdlog::debug("late sample of sensor {} for period {} (period already fused)", m.sensor_id(), m.k());
    }
    // No timer work here: a sample never opens a period (only a tick does), so the deadline
    // armed by the tick stays right; when it fires after the period was fused it finds
    // nothing to do.
  }

  // io thread
  void revise() {
    const std::lock_guard lock(mutex_);
    revise_posted_ = false;
    publish(core_.revise(dds::steady_now_ns()));  // empty when a tick or the deadline re-ran first
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
      publish(core_.on_deadline(dds::steady_now_ns()));
      arm_deadline();
      assert_liveliness_if_quiet();
      push_back_liveliness_check();
    });
  }

  void publish(const std::vector<PeriodEstimate>& estimates) {
    for (const auto& e : estimates) {
      Estimate r = e;  // what goes on the wire, stamped at publication
      try {
        if (e.control) control_.write(dds::make_control_input(e.k, *e.control));
        r.stamp_ns = dds::steady_now_ns();
        estimate_.write(dds::to_wire(r));  // to_wire refuses non-finite values: never NaN on the wire
        last_write_.store(std::chrono::steady_clock::now());
        ++published_;
        if (e.revision > 0) ++revisions_;
      } catch (const std::exception& ex) {
        spdlog::error("estimate for period {} not published: {}", e.k, ex.what());
      }
      if (e.skipped_tick) spdlog::warn("tick {} never arrived: period fused open-loop from a later tick", e.k);
      if (!e.fused.empty()) fused_since_start_ = true;
      if (e.revision == 0 && e.state != last_state_) {  // the state of the newest in-time estimate
        if (e.state == FilterState::diverging && !fused_since_start_) {
          // A new life (a restart, a standby) whose sensors are not discovered yet: the cause is
          // discovery, not the links.
          spdlog::warn("period {}: filter diverging (Tr P = {:.4g}): no sample fused since this estimator started",
                       e.k, e.P.trace());
        } else if (e.state == FilterState::diverging) {
          spdlog::warn("period {}: filter diverging (Tr P = {:.4g}): arrival rates below critical?", e.k, e.P.trace());
        } else {
          spdlog::info("period {}: filter ok again (Tr P = {:.4g})", e.k, e.P.trace());
        }
        last_state_ = e.state;
      }
    }
  }

  // The estimate and control writers' liveliness, asserted from the io thread (the one that
  // handles ticks and deadlines): an estimator whose io thread stops (killed, stopped, hung)
  // loses its writers after dds::kOwnershipLease and a standby takes over. Writes assert it too.
  // The check runs at each period's deadline and, on its own timer, only when no deadline came
  // for a quarter lease (a silent plant, a period longer than that): each deadline pushes the
  // timer back. A timer of its own every quarter lease (80 Hz) woke this thread at phases
  // unrelated to the period, some inside the period's burst of samples (BENCHMARKS.md, "Levers
  // toward two hops at the cost of two hops").
  void push_back_liveliness_check() {
    liveliness_timer_.expires_after(dds::kOwnershipLease / 4);  // cancels the pending wait
    liveliness_timer_.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;  // pushed back by a deadline, or stopping
      assert_liveliness_if_quiet();
      push_back_liveliness_check();
    });
  }

  // Only when nothing was written for a quarter lease (a write asserts it): no extra messages at
  // the default period.
  void assert_liveliness_if_quiet() {
    if (std::chrono::steady_clock::now() - last_write_.load() >= dds::kOwnershipLease / 4) {
      estimate_.assert_liveliness();
      control_.assert_liveliness();
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

  boost::asio::io_context io_;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
  mutable std::mutex mutex_;  // core_ and the publication state below
  LogThrottle rejection_log_;  // a broken or rogue sender: a few warnings, then a count
  EstimatorCore core_;
  int input_dim_;
  bool controls_;  // a closed loop: it sends the plant u = -L x̂
  boost::asio::steady_timer deadline_timer_;
  boost::asio::steady_timer status_timer_;
  std::chrono::milliseconds status_period_;
  boost::asio::steady_timer liveliness_timer_;
  std::atomic<std::chrono::steady_clock::time_point> last_write_{};  // of the estimate and control writers
  boost::asio::steady_timer readers_timer_;  // a restart's wait for its readers
  bool holding_ticks_ = false;               // io thread: a restart waits for its readers
  std::vector<wire::Tick> held_ticks_;
  std::chrono::steady_clock::time_point readers_wait_started_;
  std::optional<std::int64_t> armed_for_;
  std::uint64_t published_ = 0;
  std::uint64_t revisions_ = 0;  // of published_
  bool revise_posted_ = false;   // a revise() is queued on the io thread
  FilterState last_state_ = FilterState::ok;
  bool fused_since_start_ = false;  // some period of this process fused a sample
  bool resumed_ = false;  // restarted from a checkpoint
  dds::Writer<wire::Estimate> estimate_;
  dds::Writer<wire::ControlInput> control_;
  std::optional<dds::Reader<wire::Tick>> tick_;
  std::optional<dds::Reader<wire::Measurement>> delivered_;
  std::optional<dds::Reader<wire::MeasurementBatch>> delivered_batch_;
  std::function<void()> announce_;  // creates presence_ once the readers matched
  std::optional<dds::PresenceAnnouncer> presence_;
};

EstimatorApp::EstimatorApp(const Scenario& scenario, dds::Participant& participant, EstimatorAppOptions options)
    : impl_(std::make_unique<Impl>(scenario, participant, std::move(options))) {}
EstimatorApp::~EstimatorApp() = default;
void EstimatorApp::run() { impl_->run(); }
void EstimatorApp::stop() { impl_->stop(); }
boost::asio::io_context& EstimatorApp::io() { return impl_->io(); }
EstimatorAppStats EstimatorApp::stats() const { return impl_->stats(); }

bool EstimatorApp::wait_for_estimate_readers(int n, std::chrono::milliseconds timeout) const {
  return impl_->wait_for_estimate_readers(n, timeout);
}
void EstimatorApp::log_summary() const { impl_->log_summary(); }

}  // namespace netkf::nodes
