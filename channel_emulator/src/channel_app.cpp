#include "netkf/nodes/channel_app.hpp"

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <iterator>
#include <mutex>
#include <optional>
#include <string>

#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/dds/presence.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_text.hpp"
#include "netkf/relay/relay_links.hpp"
#include "netkf/support/log_throttle.hpp"
#include "netkf/support/release_queue.hpp"

namespace netkf::nodes {

namespace wire = netkf::wire;

class ChannelApp::Impl {
 public:
  Impl(const Scenario& scenario, dds::Participant& participant, ChannelAppOptions options)
      : links_(scenario),
        release_timer_(io_),
        status_timer_(io_),
        status_period_(std::chrono::milliseconds(options.status_period_ms)),
        delivered_(participant, dds::topics::delivered_measurement,
                   static_cast<double>(scenario.sensors.size()) / scenario.period_s()),
        // At most one batch per sensor process and truth (a batch holds two sensors or more).
        delivered_batch_(participant, dds::topics::delivered_measurement_batch,
                         static_cast<double>(scenario.sensors.size() / 2) / scenario.period_s()),
        status_(participant, dds::topics::link_status),
        reply_(participant, dds::topics::link_control_reply),
        journal_(participant, dds::topics::link_change) {
    for (const auto& r : links_.statuses()) {
      spdlog::info("link {}: {}; stationary loss {:.4f}, in time for the deadline {:.4f}", r.name(),
                   describe_link(r.link), stationary_loss(r.link.loss), r.in_time);
    }
    // The actuation link: the estimator's inputs reach the plant through this process.
    if (scenario.actuation_link())
      input_out_.emplace(participant, dds::topics::control_input, dds::WriterOptions{.samples_per_second = 1.0 / scenario.period_s()});
    if (!scenario.events.empty()) spdlog::info("timeline: {} link events", scenario.events.size());
    // The readers last: their callbacks use everything above.
    raw_.emplace(participant, dds::topics::raw_measurement, [this](wire::Measurement&& m) { on_raw(m); });
    raw_batch_.emplace(participant, dds::topics::raw_measurement_batch,
                       [this](wire::MeasurementBatch&& b) { on_raw_batch(std::move(b)); });
    if (input_out_)
      input_in_.emplace(participant, dds::topics::sent_control_input, [this](wire::ControlInput&& c) { on_input(c); });
    control_.emplace(participant, dds::topics::link_control,
                     dds::post_to<wire::LinkControl>(io_.get_executor(), [this](wire::LinkControl c) { on_control(c); }));
    announce_when_readers_match(participant, dds::scenario_hash(scenario), options.delivered_readers);
    // The first status as soon as run() serves, then one per status period.
    boost::asio::post(io_, [this] {
      status_next_ = std::chrono::steady_clock::now();
      status_loop();
    });
  }

  // Present (what the plant waits for before period 0) once `readers` readers (the estimator, the
  // launch's recorder) matched both delivered writers and, with an actuation link, the plant's
  // input reader matched: a sample relayed before is lost to that reader.
  void announce_when_readers_match(dds::Participant& participant, std::uint64_t hash, int readers) {
    auto announce = [this, &participant, hash] {
      presence_.emplace(participant, dds::presence_role::channel, std::vector<int>{}, hash);
    };
    if (readers <= 0) {
      announce();
      return;
    }
    readers_matched_.emplace(
        io_,
        [this, readers] {
          return delivered_.matched() >= readers && delivered_batch_.matched() >= readers &&
                 (!input_out_ || input_out_->matched() >= 1);
        },
        std::chrono::seconds(5),
        [this, readers, announce](bool matched) {
          if (matched)
            spdlog::debug("{} readers of the delivered samples matched after {} ms", readers,
                          readers_matched_->waited().count());
          else
            spdlog::warn("after {} ms the delivered samples have {} readers (want {}){}; present anyway",
                         readers_matched_->waited().count(), std::min(delivered_.matched(), delivered_batch_.matched()),
                         readers, input_out_ && input_out_->matched() < 1 ? " and the plant's input reader has not matched" : "");
          announce();
        });
  }

  ~Impl() {
    // The readers first: no callback may run into a half-destroyed object.
    control_.reset();
    input_in_.reset();
    raw_batch_.reset();
    raw_.reset();
  }

  void run() {
    work_.emplace(io_.get_executor());
    io_.run();
    {
      const std::lock_guard lock(mutex_);
      if (held_.size() > 0) spdlog::info("{} delayed samples still held at shutdown: not relayed", held_.size());
      if (held_inputs_.size() > 0)
        spdlog::info("{} delayed control inputs still held at shutdown: not relayed", held_inputs_.size());
    }
    publish_status();  // final counts for late joiners (transient-local)
    status_.wait_for_acknowledgments(std::chrono::milliseconds(500));
  }

  void stop() {
    boost::asio::post(io_, [this] {
      release_timer_.cancel();
      status_timer_.cancel();
      work_.reset();
      io_.stop();
    });
  }

  boost::asio::io_context& io() { return io_; }

  ChannelAppStats stats() const {
    ChannelAppStats s;
    {
      const std::lock_guard lock(mutex_);
      s.links = links_.statuses();
      s.held = held_.size() + held_inputs_.size();
      s.unknown_sensor_samples = links_.unknown_sensor_samples();
    }
    s.delivered_readers = std::min(delivered_.matched(), delivered_batch_.matched());
    s.raw_batches = raw_batch_ ? raw_batch_->received() : 0;
    return s;
  }

  void log_summary() const {
    if (raw_batch_ && raw_batch_->received() > 0)
      spdlog::info("{} raw samples came in {} batches (sensor processes of several sensors)", batched_samples_.load(),
                   raw_batch_->received());
    const std::lock_guard lock(mutex_);  // the raw reader still delivers until it is gone
    for (const auto& r : links_.statuses()) {
      const double loss =
          r.samples_total == 0 ? 0.0 : static_cast<double>(r.dropped_total) / static_cast<double>(r.samples_total);
      spdlog::info("link {}: in {} delivered {} dropped {} observed loss {:.4f} (since the last change: mean burst {:.3f})",
                   r.name(), r.samples_total, r.delivered_total, r.dropped_total, loss, r.mean_burst_length);
    }
  }

 private:
  // Any thread (io thread; run()'s caller once the io thread is done).
  void publish_status() {
    const auto now = dds::steady_now_ns();
    std::vector<LinkStatus> statuses;
    {
      const std::lock_guard lock(mutex_);
      statuses = links_.statuses();
      for (auto& r : statuses)
        r.held = r.sensor_id == kControlLinkId ? held_inputs_.held(r.sensor_id) : held_.held(r.sensor_id);
    }
    for (const auto& r : statuses) status_.write(dds::to_wire(r, now));
  }

  // DDS receive thread. Journal entries are written where they are made (a sample or a
  // request: rare, short).
  void publish_changes(const std::vector<LinkChange>& changes) {
    for (const auto& c : changes) {
      if (!c.failure.empty()) {
        spdlog::warn("timeline: link {} event at period {} not applied: {}", link_name(c.sensor_id), c.at_period,
                     c.failure);
        continue;
      }
      if (c.origin == LinkChange::Origin::timeline)
        spdlog::info("timeline: link {} from period {}: {}", link_name(c.sensor_id), c.at_period, describe_link(c.link));
      journal_.write(dds::to_wire(c, dds::steady_now_ns()));
    }
  }

  // io thread. The release timer: relay what is due, then sleep until the next release;
  // re-armed from the receive thread (posted) when a new earliest sample arrives.
  void release_due() {
    std::vector<wire::Measurement> due;
    std::vector<wire::ControlInput> inputs_due;
    std::optional<std::chrono::steady_clock::time_point> next;
    {
      const std::lock_guard lock(mutex_);
      const auto now = std::chrono::steady_clock::now();
      due = held_.take_due(now);
      inputs_due = held_inputs_.take_due(now);
      next = held_.next_release();
      if (const auto input_next = held_inputs_.next_release(); input_next && (!next || *input_next < *next))
        next = input_next;
    }
    for (const auto& m : due) delivered_.write(m);
    for (const auto& c : inputs_due) input_out_->write(c);
    if (next) {
      release_timer_.expires_at(*next);
      release_timer_.async_wait([this](const boost::system::error_code& ec) {
        if (!ec) release_due();
      });
    }
  }

  // When a delayed sample or input leaves: its link's delay from now.
  static std::chrono::steady_clock::time_point release_time(const SampleFate& fate) {
    return std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                  std::chrono::duration<double, std::milli>(fate.delay_ms));
  }

  // What became of one raw sample: decided under mutex_, acted on outside it.
  struct Routed {
    SampleFate fate;
    bool rearm = false;                // a new earliest held sample: the release timer must move
    std::uint64_t unknown_so_far = 0;  // for the unknown-sensor warning
  };

  // DDS receive thread, under mutex_: the sample's fate on its link; a delayed one is held.
  Routed route_locked(const wire::Measurement& m, std::vector<LinkChange>& changes) {
    Routed r;
    r.fate = links_.on_sample(m.sensor_id(), static_cast<std::int64_t>(m.k()));
    r.unknown_so_far = links_.unknown_sensor_samples();
    auto taken = links_.take_changes();
    changes.insert(changes.end(), std::make_move_iterator(taken.begin()), std::make_move_iterator(taken.end()));
    if (r.fate.verdict == SampleFate::Verdict::delivered && r.fate.delay_ms > 0.0)
      r.rearm = held_.hold(release_time(r.fate), m.sensor_id(), m);
    return r;
  }

  // DDS receive thread: the log lines of a sample not relayed now (a delayed one is held).
  void note_not_relayed(const wire::Measurement& m, const Routed& r) {
    if (r.fate.verdict == SampleFate::Verdict::dropped) {
      spdlog::trace("dropped sensor {} period {}", m.sensor_id(), m.k());
    } else if (r.fate.verdict == SampleFate::Verdict::unknown_sensor) {
      const std::lock_guard lock(mutex_);  // the throttle's state
      if (const auto left_out = unknown_log_.allow())
        spdlog::warn("sample from unknown sensor id {} (period {}) not relayed ({} so far){}", m.sensor_id(), m.k(),
                     r.unknown_so_far, dds::left_out_text(*left_out));
    }
  }

  static bool relay_now(const Routed& r) {
    return r.fate.verdict == SampleFate::Verdict::delivered && r.fate.delay_ms <= 0.0;
  }

  // DDS receive thread
  void on_raw(const wire::Measurement& m) {
    std::vector<LinkChange> changes;
    Routed r;
    {
      const std::lock_guard lock(mutex_);
      r = route_locked(m, changes);
    }
    if (!changes.empty()) publish_changes(changes);
    if (relay_now(r)) delivered_.write(m);  // relayed unchanged (stamp is the sensor's publish time)
    if (r.rearm) boost::asio::post(io_, [this] { release_due(); });
    note_not_relayed(m, r);
  }

  // DDS receive thread: each sample of the batch goes its own link's way, in the batch's order
  // (so every link sees the same sequence as from a process of its own); the ones relayed at
  // once leave as one batch, delayed ones one by one when due.
  void on_raw_batch(wire::MeasurementBatch&& batch) {
    std::vector<LinkChange> changes;
    std::vector<Routed> routed;
    routed.reserve(batch.samples().size());
    bool rearm = false;
    {
      const std::lock_guard lock(mutex_);
      for (const auto& m : batch.samples()) {  // their own run is not read: the writers stamp theirs
        routed.push_back(route_locked(m, changes));
        rearm = rearm || routed.back().rearm;
      }
    }
    batched_samples_.fetch_add(batch.samples().size());
    if (!changes.empty()) publish_changes(changes);
    wire::MeasurementBatch now;
    for (std::size_t i = 0; i < routed.size(); ++i) {
      if (relay_now(routed[i]))
        now.samples().push_back(std::move(batch.samples()[i]));
      else
        note_not_relayed(batch.samples()[i], routed[i]);
    }
    if (!now.samples().empty()) delivered_batch_.write(std::move(now));
    if (rearm) boost::asio::post(io_, [this] { release_due(); });
  }

  // DDS receive thread: an input the estimator sent goes the actuation link's way (a draw and
  // a write, as a sample); a delayed one is held like a delayed sample. The plant applies it
  // only if it arrives before the tick that needs it.
  void on_input(const wire::ControlInput& c) {
    std::vector<LinkChange> changes;
    SampleFate fate;
    bool rearm = false;
    {
      const std::lock_guard lock(mutex_);
      fate = links_.on_sample(kControlLinkId, static_cast<std::int64_t>(c.k()));
      auto taken = links_.take_changes();
      changes.insert(changes.end(), std::make_move_iterator(taken.begin()), std::make_move_iterator(taken.end()));
      if (fate.verdict == SampleFate::Verdict::delivered && fate.delay_ms > 0.0)
        rearm = held_inputs_.hold(release_time(fate), kControlLinkId, c);
    }
    if (!changes.empty()) publish_changes(changes);
    if (fate.verdict == SampleFate::Verdict::delivered && fate.delay_ms <= 0.0) input_out_->write(c);
    if (fate.verdict == SampleFate::Verdict::dropped) spdlog::trace("dropped the control input of period {}", c.k());
    if (rearm) boost::asio::post(io_, [this] { release_due(); });
  }

  // io thread
  void on_control(const wire::LinkControl& c) {
    if (is_relay_topic_link_id(c.sensor_id())) return;  // a topic of `netkf relay`: not a link of this network
    LinkReply result;
    LinkSpec applied;
    const LinkKeys keys = dds::link_keys_of(c);
    // A trace is read here, outside the lock the sample path takes (a request is rare; the
    // trace is bounded, docs/scenario-format.md). A file that cannot be read rejects the request.
    TraceRows traces;
    for (const auto& key : keys) {
      if (key.name != "trace" || !std::holds_alternative<std::string>(key.value)) continue;
      try {
        traces.emplace(std::get<std::string>(key.value), read_link_trace_for(std::get<std::string>(key.value)));
      } catch (const LinkError& e) {
        result = links_reject(c, e.what());
      }
    }
    if (!result.reason.empty()) {
      spdlog::warn("request {}: link {} change rejected: {}", c.request_id(), link_name(c.sensor_id()), result.reason);
      reply_.write(dds::to_wire(result));
      publish_status();
      return;
    }
    {
      const std::lock_guard lock(mutex_);
      result = links_.request(c.request_id(), c.sensor_id(), keys, &traces);
      if (result.applied) applied = *links_.link(c.sensor_id());
    }
    if (result.applied) {
      spdlog::info("request {}: link {} set to {} (stationary loss {:.4f}) from its next sample", c.request_id(),
                   link_name(c.sensor_id()), describe_link(applied), stationary_loss(applied.loss));
    } else {
      spdlog::warn("request {}: link {} change rejected: {}", c.request_id(), link_name(c.sensor_id()), result.reason);
    }
    reply_.write(dds::to_wire(result));
    publish_status();
  }

  LinkReply links_reject(const wire::LinkControl& c, const std::string& reason) {
    const std::lock_guard lock(mutex_);
    return links_.reject(c.request_id(), c.sensor_id(), reason);
  }

  // io thread
  void status_loop() {
    publish_status();
    status_next_ += status_period_;
    status_timer_.expires_at(status_next_);
    status_timer_.async_wait([this](const boost::system::error_code& ec) {
      if (!ec) status_loop();
    });
  }

  boost::asio::io_context io_;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
  mutable std::mutex mutex_;  // the links, the release queue and the throttle
  ChannelLinks links_;
  ReleaseQueue<wire::Measurement> held_;
  ReleaseQueue<wire::ControlInput> held_inputs_;  // the actuation link's delayed inputs
  LogThrottle unknown_log_;  // a rogue sender: a few warnings, then a count
  boost::asio::steady_timer release_timer_;
  boost::asio::steady_timer status_timer_;
  std::chrono::milliseconds status_period_;
  std::chrono::steady_clock::time_point status_next_;
  dds::Writer<wire::Measurement> delivered_;
  dds::Writer<wire::MeasurementBatch> delivered_batch_;
  dds::Writer<wire::LinkStatus> status_;
  dds::Writer<wire::LinkControlReply> reply_;
  dds::Writer<wire::LinkChange> journal_;
  std::optional<dds::Reader<wire::Measurement>> raw_;
  std::optional<dds::Reader<wire::MeasurementBatch>> raw_batch_;
  std::atomic<std::uint64_t> batched_samples_{0};
  std::optional<dds::Reader<wire::LinkControl>> control_;
  std::optional<dds::Writer<wire::ControlInput>> input_out_;  // with an actuation link: to the plant
  std::optional<dds::Reader<wire::ControlInput>> input_in_;   // the inputs the estimator sent
  std::optional<dds::PresenceAnnouncer> presence_;
  std::optional<dds::WhenMatched> readers_matched_;  // destroyed first: its callback creates presence_
};

ChannelApp::ChannelApp(const Scenario& scenario, dds::Participant& participant, ChannelAppOptions options)
    : impl_(std::make_unique<Impl>(scenario, participant, options)) {}
ChannelApp::~ChannelApp() = default;
void ChannelApp::run() { impl_->run(); }
void ChannelApp::stop() { impl_->stop(); }
boost::asio::io_context& ChannelApp::io() { return impl_->io(); }
ChannelAppStats ChannelApp::stats() const { return impl_->stats(); }
void ChannelApp::log_summary() const { impl_->log_summary(); }

}  // namespace netkf::nodes
