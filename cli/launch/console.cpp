#include "console.hpp"

#include <boost/asio/post.hpp>
#include <iostream>
#include <random>

#include "live_status.hpp"
#include "netkf/dds/node_support.hpp"

namespace netkf::cli {

namespace {
constexpr std::size_t kScreenEvents = 8;                      // events kept on the in-place screen
constexpr auto kLinkChangeTimeout = std::chrono::seconds(3);  // the channel answers within ms when alive

const char* level_prefix(LiveEvent::Level level) {
  switch (level) {
    case LiveEvent::Level::warning: return "WARNING: ";
    case LiveEvent::Level::error: return "ERROR: ";
    default: return "";
  }
}
}  // namespace

LiveConsole::LiveConsole(boost::asio::io_context& io, const Scenario& scenario, LiveConsoleOptions options,
                     SendLinkControl send_link_control)
    : io_(io),
      options_(std::move(options)),
      send_link_control_(std::move(send_link_control)),
      model_(scenario),
      next_status_(Clock::now()),
      next_refresh_(Clock::now()) {
  // Request ids unlikely to collide with those of a `netkf ctl` or another launch.
  std::random_device rd;
  next_request_id_ = ((static_cast<std::uint64_t>(rd()) << 31) ^ rd()) & 0x3fffffffffffffffULL;
  if (next_request_id_ == 0) next_request_id_ = 1;

  if (options_.dashboard) {
    DashboardServer::Hooks hooks;
    hooks.set_parameters = [this](DashboardServer::ClientId c, const dashboard::SetParameters& r) {
      on_set_parameters(c, r);
    };
    hooks.get_parameters = [this](const dashboard::GetParameters& r) {
      return dashboard::parameter_values(model_.snapshot().links, r.names, r.id);
    };
    hooks.metrics = [this] { return render_metrics(); };
    std::random_device session;
    dashboard_ = std::make_unique<DashboardServer>(
        io_, *options_.dashboard, dashboard::server_info(std::to_string(session()), scenario), std::move(hooks));
    dashboard_->publish(catalogue::ChannelId::scenario, catalogue::scenario_message(scenario), wall_ns());
    for (const auto& l : model_.snapshot().links)
      dashboard_->publish(catalogue::ChannelId::link_status, catalogue::link_status_message(l), wall_ns(), l.sensor_id);
  }
  theory_ = std::make_unique<TheoryWorker>([this](TheoryView view) {
    // On the worker thread: hand the result to the loop.
    boost::asio::post(io_, [this, view = std::move(view)]() mutable { on_theory(std::move(view)); });
  });
}

LiveConsole::~LiveConsole() {
  theory_.reset();  // never waits for a computation in progress
  if (dashboard_) dashboard_->stop();
}

std::uint64_t LiveConsole::wall_ns() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

void LiveConsole::truth(const TruthRecord& truth) {
  model_.add_truth(truth);
  if (dashboard_) dashboard_->publish(catalogue::ChannelId::truth, catalogue::truth_message(truth), wall_ns());
}

void LiveConsole::estimate(const Estimate& estimate) {
  // A revision (late_policy fuse_within) corrects an earlier period: only the page plots it.
  if (estimate.revision > 0) {
    if (dashboard_) dashboard_->publish(catalogue::ChannelId::estimate, catalogue::estimate_message(estimate), wall_ns());
    return;
  }
  model_.add_estimate(estimate);
  if (estimate.has_pipeline_latency()) metrics_.observe_pipeline_latency(estimate.pipeline_latency_s());
  if (dashboard_) dashboard_->publish(catalogue::ChannelId::estimate, catalogue::estimate_message(estimate), wall_ns());
}

void LiveConsole::link_status(const LinkStatusRecord& status) {
  const auto before = model_.snapshot().links;
  model_.add_link_status(status);
  for (const auto& l : model_.snapshot().links) {
    if (l.sensor_id != status.sensor_id) continue;
    if (dashboard_) dashboard_->publish(catalogue::ChannelId::link_status, catalogue::link_status_message(l), wall_ns(), l.sensor_id);
    for (const auto& b : before) {
      if (b.sensor_id == l.sensor_id && (!b.reported || !(b.link == l.link))) {
        theory_due_ = true;  // the configured operating point moved: reassess now
        if (dashboard_) dashboard_->broadcast_parameter_values(dashboard::link_parameter_values(l, std::nullopt));
      }
    }
  }
  emit_events();
}

void LiveConsole::link_reply(const LinkReplyRecord& reply) {
  auto it = pending_.find(reply.request_id);
  if (it == pending_.end()) return;  // another client's request
  const PendingChange change = it->second;
  pending_.erase(it);
  if (!dashboard_) return;
  LinkView current;
  for (const auto& l : model_.snapshot().links)
    if (l.sensor_id == change.sensor_id) current = l;
  if (reply.applied) {
    current.link = change.link;  // the channel's status with the new link follows
    dashboard_->send_to(change.client, dashboard::link_parameter_values(current, change.id));
  } else {
    dashboard_->send_to(change.client,
                        dashboard::status_message(LiveEvent::Level::error, "link " + std::to_string(change.sensor_id) +
                                                                               ": change refused by the channel: " +
                                                                               reply.reason));
    if (change.id) dashboard_->send_to(change.client, dashboard::link_parameter_values(current, change.id));
  }
}

void LiveConsole::link_change(const LinkChangeRecord& change) {
  model_.add_link_change(change);
  emit_events();
}

void LiveConsole::invalid_sample(const std::string& what) {
  model_.count_invalid();
  if (const auto left_out = invalid_log_.allow())
    log(LiveEvent::Level::warning, "rejected a sample: " + what + dds::left_out_text(*left_out));
}

void LiveConsole::log(LiveEvent::Level level, const std::string& line) {
  if (options_.status_screen) {
    screen_events_.push_back(std::string(level_prefix(level)) + line);
    while (screen_events_.size() > kScreenEvents) screen_events_.pop_front();
  } else {
    std::cerr << "netkf launch: " << level_prefix(level) << line << "\n" << std::flush;
  }
}

void LiveConsole::announce(LiveEvent::Level level, const std::string& line) {
  log(level, line);
  if (dashboard_) dashboard_->broadcast_status(level, line);
}

void LiveConsole::set_processes(std::vector<ProcessView> processes) { model_.set_processes(std::move(processes)); }

void LiveConsole::count_restart(const std::string& process) { metrics_.count_restart(process); }

void LiveConsole::on_set_parameters(DashboardServer::ClientId client, const dashboard::SetParameters& request) {
  for (const auto& change : dashboard::link_changes(request, model_.snapshot().links)) {
    const LinkView* current = nullptr;
    for (const auto& l : model_.snapshot().links)
      if (l.sensor_id == change.sensor_id) current = &l;
    if (!change.keys) {
      dashboard_->send_to(client, dashboard::status_message(LiveEvent::Level::error, change.refusal));
      if (request.id && current) dashboard_->send_to(client, dashboard::link_parameter_values(*current, request.id));
      continue;
    }
    const std::uint64_t request_id = next_request_id_++;
    model_.note_own_request(request_id, "dashboard");
    if (!send_link_control_ || !send_link_control_(request_id, change.sensor_id, *change.keys)) {
      dashboard_->send_to(client, dashboard::status_message(LiveEvent::Level::error,
                                                            "link " + std::to_string(change.sensor_id) +
                                                                ": the change could not be sent (no channel emulator?)"));
      continue;
    }
    pending_[request_id] = {client, request.id, change.sensor_id, change.link, Clock::now() + kLinkChangeTimeout};
  }
}

void LiveConsole::request_theory(bool with_region) {
  TheoryRequest r;
  r.configured = model_.configured_scenario();
  r.observed_rates = model_.observed_rates_since_change();
  r.k = model_.snapshot().period ? static_cast<std::int64_t>(model_.snapshot().period->estimate.k) : -1;
  r.with_region = with_region;
  theory_->request(std::move(r));
}

void LiveConsole::on_theory(TheoryView view) {
  model_.set_theory(std::move(view));
  if (dashboard_) dashboard_->publish(catalogue::ChannelId::theory, catalogue::theory_message(model_.snapshot().theory), wall_ns());
  emit_events();
}

void LiveConsole::emit_events() {
  for (const auto& e : model_.take_events()) announce(e.level, e.text);
}

std::string LiveConsole::render_metrics() {
  metrics_.update(model_.snapshot());
  return metrics_.serialize();
}

void LiveConsole::tick(Clock::time_point now) {
  // Link changes the channel never answered.
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (now < it->second.deadline) {
      ++it;
      continue;
    }
    if (dashboard_)
      dashboard_->send_to(it->second.client,
                          dashboard::status_message(LiveEvent::Level::error,
                                                    "link " + std::to_string(it->second.sensor_id) +
                                                        ": the channel emulator did not answer the change"));
    it = pending_.erase(it);
  }
  // Theory and the page's network summary about once a second, and the theory at once
  // after a link's model changed (when the worker is free: requests never pile up).
  const bool refresh_due = now >= next_refresh_;
  if (refresh_due) next_refresh_ = now + std::chrono::seconds(1);
  if ((refresh_due || theory_due_) && !theory_->busy()) {
    request_theory(!region_requested_);
    region_requested_ = true;
    theory_due_ = false;
  }
  if (refresh_due && dashboard_)
    dashboard_->publish(catalogue::ChannelId::network, catalogue::network_message(model_.snapshot()), wall_ns());
  if (options_.status_interval > 0 && now >= next_status_) {
    next_status_ = now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options_.status_interval));
    const bool pending = theory_->busy();
    if (options_.status_screen) {
      std::cerr << render_status_screen(options_.header, model_.snapshot(), pending,
                                        std::vector<std::string>(screen_events_.begin(), screen_events_.end()))
                << std::flush;
    } else {
      std::cerr << render_status(model_.snapshot(), pending) << std::flush;
    }
  }
  emit_events();
}

void LiveConsole::stop() {
  if (dashboard_) dashboard_->stop();
}

std::optional<std::string> LiveConsole::dashboard_url() const {
  if (!dashboard_) return std::nullopt;
  return dashboard_->url();
}

}  // namespace netkf::cli
