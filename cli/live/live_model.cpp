#include "netkf/cli/live/live_model.hpp"
#include "netkf/links/link_delay.hpp"
#include "netkf/links/link_text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

namespace netkf::cli {

LiveModel::LiveModel(Scenario scenario) : scenario_(std::move(scenario)), cost_(scenario_), next_event_{0} {
  for (const auto& sensor : scenario_.sensors) {
    LinkView view;
    view.sensor_id = sensor.id;
    view.link = sensor.link;
    view.in_time = probability_within(sensor.link.delay, scenario_.deadline_ms());
    snapshot_.links.push_back(view);
  }
  // The actuation link (plant.control.link) last: a link like the sensors', carrying inputs.
  if (const LinkSpec* control = scenario_.actuation_link()) {
    LinkView view;
    view.sensor_id = kControlLinkId;
    view.link = *control;
    view.in_time = probability_within(control->delay, scenario_.actuation_deadline_ms());
    snapshot_.links.push_back(view);
  }
  for (std::size_t i = 0; i < snapshot_.links.size(); ++i) link_index_[snapshot_.links[i].sensor_id] = i;
}

LinkView* LiveModel::link(int sensor_id) {
  return const_cast<LinkView*>(std::as_const(*this).find_link(sensor_id));
}

const LinkView* LiveModel::find_link(int sensor_id) const {
  const auto it = link_index_.find(sensor_id);
  return it == link_index_.end() ? nullptr : &snapshot_.links[it->second];
}

void LiveModel::add_truth(const Truth& truth) {
  if (snapshot_.period && static_cast<std::int64_t>(snapshot_.period->estimate.k) == truth.k)
    snapshot_.period->truth = truth.x;
  score(join_.add_truth(truth.k, truth.x));
  cost_.add(truth);
  snapshot_.mean_cost = cost_.mean();
  snapshot_.periods_costed = cost_.periods();
}

void LiveModel::add_estimate(const Estimate& e) {
  if (!std::isfinite(e.trace_P_pred) || !e.x_hat.allFinite() || !e.P.allFinite()) {
    // The bus validates estimates; this is the views' own last gate.
    saw_non_finite_ = true;
    ++snapshot_.invalid_samples;
    return;
  }
  auto& s = snapshot_;
  ++s.estimates;
  if (s.estimates == kSilentSensorCheck) {
    // By now every sensor has published many samples (status arrives once a second).
    std::string silent;
    for (const auto& l : s.links)
      if (l.samples_total == 0 && l.sensor_id != kControlLinkId) silent += (silent.empty() ? "" : ", ") + link_name(l.sensor_id);
    if (!silent.empty())
      raise(LiveEvent::Level::error, "sensors " + silent + " have sent nothing to the channel in " +
                                         std::to_string(kSilentSensorCheck) + " periods: is every sensor process running?");
  }
  sum_trace_ += e.trace_P();
  sum_trace_pred_ += e.trace_P_pred;
  s.mean_trace_P = sum_trace_ / static_cast<double>(s.estimates);
  s.mean_trace_P_pred = sum_trace_pred_ / static_cast<double>(s.estimates);
  s.late_total = std::max(s.late_total, e.late_total);
  window_fused_ += e.fused.size();
  window_late_ += e.late;
  if (++window_estimates_ == kLateWindow) check_late_share();
  for (int id : e.late_sensors)
    if (LinkView* l = link(id)) ++l->late_total;
  s.rejected_total = std::max<std::uint64_t>(s.rejected_total, e.rejected_total);
  if (e.restarts > s.estimator_restarts) {
    s.estimator_restarts = e.restarts;
    restart_gap_from_ = e.k;
    raise(LiveEvent::Level::warning, "estimator restarted (restart " + std::to_string(e.restarts) +
                                         "): resumed from its estimate of period " + std::to_string(e.k > 0 ? e.k - 1 : 0) +
                                         "; the periods it missed are predicted open-loop");
  }
  if (restart_gap_from_ && !e.fused.empty() && e.k >= *restart_gap_from_) {
    const auto gap = static_cast<std::uint64_t>(e.k - *restart_gap_from_);
    s.restart_gap_periods += gap;
    if (gap > 0)
      raise(LiveEvent::Level::info, "estimator fusing again from period " + std::to_string(e.k) + " (" +
                                        std::to_string(gap) + " periods without samples after its restart)");
    restart_gap_from_.reset();
  }
  const auto k = static_cast<std::int64_t>(e.k);
  if (!s.period || e.k >= s.period->estimate.k) {
    PeriodView p{e, {}};
    if (const auto* truth = join_.truth(k)) p.truth = *truth;
    s.period = std::move(p);
  }
  score(join_.add_estimate(k, e.x_hat));
}

void LiveModel::check_late_share() {
  const auto late = window_late_, arrived = window_fused_ + window_late_;
  window_estimates_ = window_fused_ = window_late_ = 0;
  if (arrived == 0 || snapshot_.links.empty()) return;
  // What the links themselves make late: a sample delayed beyond the deadline (mean over links).
  double explained = 0.0;
  std::size_t sensor_links = 0;
  for (const auto& l : snapshot_.links) {
    if (l.sensor_id == kControlLinkId) continue;  // inputs are not fused
    explained += 1.0 - l.in_time;
    ++sensor_links;
  }
  if (sensor_links == 0) return;
  explained /= static_cast<double>(sensor_links);
  const double share = static_cast<double>(late) / static_cast<double>(arrived);
  const bool too_many = late >= 10 && share > explained + kLateExcess;
  if (too_many && !late_warned_) {
    char text[320];
    std::snprintf(text, sizeof text,
                  "%llu of %llu samples of the last %llu periods arrived after their period was fused (%.0f %%; the "
                  "links' delays explain %.0f %%): the channel or the estimator cannot keep up with %zu sensors at "
                  "%d ms, or deadline_ms (%d) is too short",
                  static_cast<unsigned long long>(late), static_cast<unsigned long long>(arrived),
                  static_cast<unsigned long long>(kLateWindow), 100.0 * share, 100.0 * explained,
                  scenario_.sensors.size(), scenario_.period_ms, scenario_.deadline_ms());
    raise(LiveEvent::Level::warning, text);
  }
  late_warned_ = too_many;
}

void LiveModel::score(std::optional<double> squared_error) {
  if (!squared_error) return;
  snapshot_.error_norm = std::sqrt(*squared_error);
  sum_sq_error_ += *squared_error;
  ++scored_;
  snapshot_.rms_error = std::sqrt(sum_sq_error_ / static_cast<double>(scored_));
}

void LiveModel::note_own_request(std::uint64_t request_id, std::string source) {
  own_requests_[request_id] = std::move(source);
  while (own_requests_.size() > 1000) own_requests_.erase(own_requests_.begin());
}

bool LiveModel::add_link_status(const LinkStatus& status) {
  LinkView* view = link(status.sensor_id);
  if (!view) {
    raise(LiveEvent::Level::warning,
          "link status for sensor " + link_name(status.sensor_id) + ", which is not in the scenario (ignored)");
    return false;
  }
  const bool moved = !view->reported || !(status.link == view->link);
  const bool changed = view->reported && status.last_request_id != view->last_request_id;
  if (changed) {
    auto own = own_requests_.find(status.last_request_id);
    const std::string others = "netkf ctl or another client";
    const std::string& source = own != own_requests_.end() ? own->second : others;
    const auto text = [&](const std::string& from) {
      return status.rejection_reason.empty()
                 ? "link " + link_name(status.sensor_id) + ": " + describe_link(status.link) + " (from " + from + ")"
                 : "link " + link_name(status.sensor_id) + ": change refused by the channel (" +
                       status.rejection_reason + ", from " + from + ")";
    };
    LiveEvent event{status.rejection_reason.empty() ? LiveEvent::Level::info : LiveEvent::Level::error, text(source)};
    if (own != own_requests_.end()) event.unattributed_text = text(others);
    raise(std::move(event));
  }
  ObservedRateWindow& window = windows_[status.sensor_id];
  window.add(status);
  view->observed_rate_since_change = observed_rate_since_change(status);
  view->observed_rate_window = window.rate();
  view->observed_window_samples = window.samples();
  static_cast<LinkStatus&>(*view) = status;
  view->reported = true;
  return moved;
}

void LiveModel::add_link_change(const LinkChange& change) {
  // Requests are announced by the status that answers them; the timeline only here.
  if (change.origin != LinkChange::Origin::timeline) return;
  raise(LiveEvent::Level::info, "timeline: link " + link_name(change.sensor_id) + " from period " +
                                    std::to_string(change.at_period) + ": " + describe_link(change.link));
}

Scenario LiveModel::configured_scenario() const {
  Scenario s = scenario_;
  for (auto& sensor : s.sensors)
    if (const LinkView* l = find_link(sensor.id)) sensor.link = l->link;
  if (s.plant.control && s.plant.control->link)
    if (const LinkView* l = find_link(kControlLinkId)) s.plant.control->link = l->link;
  return s;
}

std::optional<std::vector<double>> LiveModel::observed_rates_since_change() const {
  std::vector<double> rates;
  for (const auto& l : snapshot_.links) {
    if (l.sensor_id == kControlLinkId) continue;  // observed_actuation_rate_since_change()
    if (!l.observed_rate_since_change) return std::nullopt;
    rates.push_back(*l.observed_rate_since_change);
  }
  if (rates.empty()) return std::nullopt;
  return rates;
}

std::optional<double> LiveModel::observed_actuation_rate_since_change() const {
  for (const auto& l : snapshot_.links)
    if (l.sensor_id == kControlLinkId) return l.observed_rate_since_change;
  return std::nullopt;
}

void LiveModel::set_theory(TheoryView theory) {
  const auto before = snapshot_.theory.ready ? snapshot_.theory.configured.result.stable : theory::Verdict::unknown;
  const auto now = theory.configured.result.stable;
  LiveEvent crossing{LiveEvent::Level::warning, {}};
  crossing.from_records = false;
  if (before == theory::Verdict::yes && now == theory::Verdict::no)
    crossing.text = "link change moved the network below the critical arrival rate: " + theory.configured.result.reason;
  if (before == theory::Verdict::no && now == theory::Verdict::yes)
    crossing.text = "links are back above the critical arrival rate";
  if (!crossing.text.empty()) raise(std::move(crossing));
  if (theory.region.empty()) theory.region = std::move(snapshot_.theory.region);
  snapshot_.theory = std::move(theory);
}

void LiveModel::raise(LiveEvent event) {
  // Nobody reads: nothing to keep (a reader sees the events raised after it subscribed).
  if (std::none_of(next_event_.begin(), next_event_.end(), [](const auto& next) { return next.has_value(); })) {
    ++first_event_;
    return;
  }
  events_.push_back(std::move(event));
}

LiveModel::Subscriber LiveModel::subscribe() {
  next_event_.emplace_back(first_event_ + events_.size());
  return next_event_.size() - 1;
}

void LiveModel::unsubscribe(Subscriber reader) {
  if (reader < next_event_.size()) next_event_[reader].reset();
  forget_taken_events();
}

std::vector<LiveEvent> LiveModel::take_events(Subscriber reader) {
  if (reader >= next_event_.size() || !next_event_[reader]) return {};
  auto& next = *next_event_[reader];
  const auto end = first_event_ + events_.size();
  std::vector<LiveEvent> out(events_.begin() + static_cast<std::ptrdiff_t>(next - first_event_), events_.end());
  next = end;
  forget_taken_events();
  return out;
}

void LiveModel::forget_taken_events() {
  std::optional<std::uint64_t> oldest;  // the oldest event a reader has still to take
  for (const auto& next : next_event_)
    if (next && (!oldest || *next < *oldest)) oldest = *next;
  const auto keep_from = oldest.value_or(first_event_ + events_.size());
  while (first_event_ < keep_from) {
    events_.pop_front();
    ++first_event_;
  }
}

}  // namespace netkf::cli
