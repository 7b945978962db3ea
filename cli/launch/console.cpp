#include "console.hpp"

#include <boost/asio/post.hpp>
#include <algorithm>
#include <iostream>
#include <random>

#include "netkf/cli/live/live_status.hpp"
#include "netkf/dds/node_support.hpp"
#include "netkf/links/link_keys.hpp"

namespace netkf::cli {

namespace {
constexpr std::size_t kScreenEvents = 8;                      // events kept on the in-place screen
constexpr auto kLinkChangeTimeout = std::chrono::seconds(3);  // the channel answers within ms when alive
constexpr std::size_t kChangesInFlight = 16;  // well within the control topic's 64 requests

const char* level_prefix(LiveEvent::Level level) {
  switch (level) {
    case LiveEvent::Level::warning: return "WARNING: ";
    case LiveEvent::Level::error: return "ERROR: ";
    default: return "";
  }
}
}  // namespace

LiveConsole::LiveConsole(boost::asio::io_context& io, LiveModel& model, LiveConsoleOptions options,
                         SendLinkControl send_link_control)
    : io_(io),
      options_(std::move(options)),
      send_link_control_(std::move(send_link_control)),
      model_(model),
      next_status_(Clock::now()),
      next_refresh_(Clock::now()) {
  // Request ids unlikely to collide with those of a `netkf ctl` or another launch.
  std::random_device rd;
  next_request_id_ = ((static_cast<std::uint64_t>(rd()) << 31) ^ rd()) & 0x3fffffffffffffffULL;
  if (next_request_id_ == 0) next_request_id_ = 1;

  const Scenario& scenario = model_.scenario();
  if (options_.dashboard) {
    DashboardServer::Hooks hooks;
    hooks.set_parameters = [this](DashboardServer::ClientId c, const dashboard::SetParameters& r) {
      on_set_parameters(c, r);
    };
    hooks.get_parameters = [this](const dashboard::GetParameters& r) {
      return dashboard::parameter_values(model_.snapshot().links, r.names, r.id);
    };
    hooks.metrics = [this] { return render_metrics(); };
    hooks.refused = [this](const std::string& what) {
      if (const auto left_out = dashboard_log_.allow())
        log(LiveEvent::Level::warning, "dashboard: " + what + dds::left_out_text(*left_out));
    };
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

void LiveConsole::truth(const Truth& truth) {
  if (dashboard_) dashboard_->publish(catalogue::ChannelId::truth, catalogue::truth_message(truth), wall_ns());
}

void LiveConsole::estimate(const Estimate& estimate) {
  // A revision (late_policy fuse_within) corrects an earlier period: only the page plots it.
  if (estimate.revision > 0) {
    if (dashboard_) dashboard_->publish(catalogue::ChannelId::estimate, catalogue::estimate_message(estimate), wall_ns());
    return;
  }
  if (estimate.has_pipeline_latency()) metrics_.observe_pipeline_latency(estimate.pipeline_latency_s());
  if (dashboard_) dashboard_->publish(catalogue::ChannelId::estimate, catalogue::estimate_message(estimate), wall_ns());
}

void LiveConsole::link_status(const LinkStatus& status, bool link_moved) {
  // This link only: every link reports once a second (a copy of all links per report was
  // quadratic, the launch's whole thread at 4096 links).
  const LinkView* link = model_.find_link(status.sensor_id);
  if (auto a = applied_.find(status.sensor_id); a != applied_.end() && status.last_request_id == a->second.request_id)
    applied_.erase(a);
  if (link) {
    if (dashboard_) dashboard_->publish(catalogue::ChannelId::link_status, catalogue::link_status_message(*link), wall_ns(), link->sensor_id);
    if (link_moved) {
      theory_due_ = true;  // the configured operating point moved: reassess now
      if (dashboard_) dashboard_->broadcast_parameter_values(dashboard::link_parameter_values(*link, std::nullopt));
    }
  }
  emit_events();
}

void LiveConsole::link_reply(const LinkReply& reply) {
  auto it = pending_.find(reply.request_id);
  if (it == pending_.end()) return;  // another client's request
  PendingChange& change = it->second;
  if (reply.applied) {
    // The channel's status with the new link follows; until then this is the link.
    applied_[change.sensor_id] = {reply.request_id, change.link, Clock::now() + kLinkChangeTimeout};
    dashboard_->send_to(change.client, dashboard::link_parameter_values(current_link(change.sensor_id), change.id));
  } else {
    answer(change.client, change.id, change.sensor_id, LiveEvent::Level::error,
           "link " + link_name(change.sensor_id) + ": change refused by the channel: " + reply.reason);
  }
  if (reply.applied && !change.took_effect) {
    // The link's next change waits for this one's journal entry (a link whose sensor sends
    // nothing holds it until the deadline).
    change.answered = true;
    change.deadline = Clock::now() + kLinkChangeTimeout;
    return;
  }
  pending_.erase(it);
  send_waiting_changes();
}

void LiveConsole::link_change(const LinkChange& change) {
  emit_events();
  if (change.origin != LinkChange::Origin::request) return;
  if (auto it = pending_.find(change.request_id); it != pending_.end()) {
    if (!it->second.answered) {
      it->second.took_effect = true;  // the answer is still on its way
      return;
    }
    pending_.erase(it);
    send_waiting_changes();
  }
}

void LiveConsole::invalid_sample(const std::string& what) {
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
  for (auto& change : dashboard::link_changes(request, model_.snapshot().links)) {
    if (!change.keys) {
      dashboard_->send_to(client, dashboard::status_message(LiveEvent::Level::error, change.refusal));
      for (const auto& l : model_.snapshot().links)
        if (l.sensor_id == change.sensor_id && request.id)
          dashboard_->send_to(client, dashboard::link_parameter_values(current_link(l.sensor_id), request.id));
      continue;
    }
    const auto [waiting, first] = waiting_.try_emplace(change.sensor_id);
    if (!first)
      answer(waiting->second.client, waiting->second.id, change.sensor_id, LiveEvent::Level::warning,
             "link " + link_name(change.sensor_id) +
                 ": change superseded by a newer one before it was sent to the channel (not applied)");
    waiting->second = {client, request.id, std::move(*change.keys)};
  }
  send_waiting_changes();
}

void LiveConsole::send_waiting_changes() {
  for (auto it = waiting_.begin(); it != waiting_.end() && pending_.size() < kChangesInFlight;) {
    const int sensor_id = it->first;
    const bool in_flight = std::any_of(pending_.begin(), pending_.end(),
                                       [sensor_id](const auto& p) { return p.second.sensor_id == sensor_id; });
    if (in_flight) {
      ++it;
      continue;
    }
    const LinkRequest request = std::move(it->second);
    it = waiting_.erase(it);
    send_change(sensor_id, request);
  }
}

void LiveConsole::send_change(int sensor_id, const LinkRequest& request) {
  const std::string link_text = "link " + link_name(sensor_id);
  LinkSpec link;
  try {
    // The keys sent change; the link keeps the others as it is now (a change applied since
    // the request was made included).
    link = apply_link_keys(current_link(sensor_id).link, request.keys);
  } catch (const LinkError& e) {
    return answer(request.client, request.id, sensor_id, LiveEvent::Level::error, link_text + ": " + e.what());
  }
  const std::uint64_t request_id = next_request_id_++;
  model_.note_own_request(request_id, "dashboard");
  if (!send_link_control_ || !send_link_control_(request_id, sensor_id, request.keys))
    return answer(request.client, request.id, sensor_id, LiveEvent::Level::error,
                  link_text + ": the change could not be sent (no channel emulator?)");
  pending_[request_id] = {request.client, request.id, sensor_id, link, Clock::now() + kLinkChangeTimeout};
}

LinkView LiveConsole::current_link(int sensor_id) const {
  LinkView view;
  for (const auto& l : model_.snapshot().links)
    if (l.sensor_id == sensor_id) view = l;
  if (auto a = applied_.find(sensor_id); a != applied_.end() && Clock::now() < a->second.until) view.link = a->second.link;
  return view;
}

void LiveConsole::answer(DashboardServer::ClientId client, const std::optional<std::string>& id, int sensor_id,
                         LiveEvent::Level level, const std::string& message) {
  if (!dashboard_) return;
  dashboard_->send_to(client, dashboard::status_message(level, message));
  if (id) dashboard_->send_to(client, dashboard::link_parameter_values(current_link(sensor_id), id));
}

void LiveConsole::request_theory(bool with_region) {
  TheoryRequest r;
  r.configured = model_.configured_scenario();
  r.observed_rates = model_.observed_rates_since_change();
  r.observed_actuation_rate = model_.observed_actuation_rate_since_change();
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
  if (dashboard_) metrics_.update_dashboard(dashboard_->stats());
  return metrics_.serialize();
}

void LiveConsole::tick(Clock::time_point now) {
  // Link changes the channel never answered.
  const std::size_t in_flight = pending_.size();
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (now < it->second.deadline) {
      ++it;
      continue;
    }
    const PendingChange change = it->second;
    it = pending_.erase(it);
    if (!change.answered)
      answer(change.client, change.id, change.sensor_id, LiveEvent::Level::error,
             "link " + link_name(change.sensor_id) + ": the channel emulator did not answer the change");
  }
  if (pending_.size() < in_flight) send_waiting_changes();
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
