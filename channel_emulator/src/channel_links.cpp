#include "netkf/nodes/channel_links.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "netkf/links/link_delay.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_trace.hpp"

namespace netkf::nodes {

ChannelLinks::ChannelLinks(const Scenario& scenario) {
  auto add = [&](int id, const LinkSpec& spec, std::uint64_t loss_seed, std::uint64_t delay_seed, double deadline_ms) {
    Link link(id, spec, LinkLossProcess(spec.loss, loss_seed), LinkDelayProcess(delay_seed));
    link.deadline_ms = deadline_ms;
    links_.emplace(id, std::move(link));
  };
  for (const auto& s : scenario.sensors) {
    const auto id = static_cast<std::uint64_t>(s.id);
    add(s.id, s.link, derive_seed(scenario.seed, "link", id), derive_seed(scenario.seed, "link-delay", id),
        scenario.deadline_ms());
  }
  // The actuation link: streams of its own, so adding it changes no sensor's decisions. An
  // input is in time when it reaches the plant before the next tick.
  if (const LinkSpec* control = scenario.actuation_link()) {
    add(kControlLinkId, *control, derive_seed(scenario.seed, kActuationLinkStream, 0),
        derive_seed(scenario.seed, kActuationLinkDelayStream, 0), scenario.actuation_deadline_ms());
  }
  for (const std::size_t i : event_application_order(scenario.events)) {
    const LinkEvent& e = scenario.events[i];
    if (auto it = links_.find(e.link); it != links_.end()) it->second.timeline.push_back(e);
    read_event_traces(e.keys, timeline_traces_);
  }
}

void ChannelLinks::set_link(Link& link, const LinkSpec& spec, bool reset_statistics) {
  // A link that becomes a trace link, or another trace/offset/loop, replays from its offset
  // again, starting with the next sample's period; a delay change on a trace link does not.
  if (spec.trace && spec.trace != link.spec.trace) link.trace_restart = true;
  link.loss.set_model(spec.loss);  // keeps a Gilbert-Elliott chain's state (unlike netem)
  link.spec = spec;
  if (reset_statistics) {
    link.stats = LinkStatistics{};
    link.past_deadline = 0;
    link.recent.clear();
  }
}

void ChannelLinks::apply_due(Link& link, std::int64_t k) {
  const int id = link.id;
  if (link.unjournaled_request) {
    // The request was applied between the previous sample and this one: it took effect here.
    changes_.push_back({id, k, LinkChange::Origin::request, *link.unjournaled_request, link.spec, {}, {}});
    link.unjournaled_request.reset();
  }
  while (link.next_event < link.timeline.size() && link.timeline[link.next_event].at_period <= k) {
    const LinkEvent& e = link.timeline[link.next_event++];
    LinkChange change{id, k, LinkChange::Origin::timeline, 0, link.spec, {}, {}};
    try {
      if (e.kind == LinkEvent::Kind::set || e.ramp_periods == 0) {
        change.link = apply_link_keys(link.spec, e.keys, &timeline_traces_);
        set_link(link, change.link, true);
        link.ramp.reset();  // a set ends a running ramp: the latest instruction wins
      } else {
        Ramp ramp{k, e.ramp_periods, {}, e.keys};
        for (const auto& key : e.keys) ramp.from.emplace_back(key.name, link_key_value(link.spec, key.name));
        (void)apply_link_keys(link.spec, e.keys);  // the target must be a valid link now
        link.ramp = std::move(ramp);
      }
    } catch (const LinkError& err) {
      // Only a live change can make a checked timeline inapplicable (e.g. another model).
      change.failure = err.what();
    }
    changes_.push_back(std::move(change));
  }
}

void ChannelLinks::step_ramp(Link& link, std::int64_t k) {
  if (!link.ramp) return;
  const Ramp& ramp = *link.ramp;
  const double fraction =
      std::min(1.0, static_cast<double>(k - ramp.start_period) / static_cast<double>(ramp.periods));
  LinkKeys keys;
  for (std::size_t i = 0; i < ramp.to.size(); ++i) {
    const double from = ramp.from[i].second;
    const double to = std::get<double>(ramp.to[i].value);
    keys.push_back({ramp.to[i].name, fraction >= 1.0 ? to : from + (to - from) * fraction});
  }
  const int id = link.id;
  try {
    set_link(link, apply_link_keys(link.spec, keys), false);
  } catch (const LinkError& err) {
    changes_.push_back({id, k, LinkChange::Origin::timeline, 0, link.spec, {}, err.what()});
    link.ramp.reset();
    return;
  }
  if (fraction >= 1.0) {
    changes_.push_back({id, k, LinkChange::Origin::timeline, 0, link.spec, {}, {}});
    link.ramp.reset();
  }
}

SampleFate ChannelLinks::on_sample(int sensor_id, std::int64_t k) {
  auto it = links_.find(sensor_id);
  if (it == links_.end()) {
    ++unknown_sensor_samples_;
    return {Verdict::unknown_sensor, 0.0};
  }
  Link& link = it->second;
  apply_due(link, k);
  step_ramp(link, k);
  ++link.samples_seen;
  bool dropped = false;
  double trace_delay_ms = std::nan("");
  if (const auto& trace = link.spec.trace) {
    if (link.trace_restart) {
      link.trace_start = k;
      link.trace_restart = false;
    }
    // A sample of a period before the start (out of order) gets the first row.
    const TraceSample s = trace_sample(*trace, static_cast<std::uint64_t>(std::max<std::int64_t>(0, k - link.trace_start)));
    dropped = !s.delivered;
    trace_delay_ms = s.delay_ms;
  } else {
    dropped = link.loss.next_dropped();
  }
  link.stats.record(dropped);
  link.lifetime.record(dropped);
  link.recent.record(dropped);
  if (dropped) return {Verdict::dropped, 0.0};
  const double delay_ms =
      std::isnan(trace_delay_ms) ? link.delay.next_delay_ms(link.spec.delay) : trace_delay_ms;
  if (delay_ms > link.deadline_ms) ++link.past_deadline;
  return {Verdict::delivered, delay_ms};
}

ChannelLinks::Verdict ChannelLinks::on_sample(int sensor_id) {
  const auto it = links_.find(sensor_id);
  return on_sample(sensor_id, it == links_.end() ? 0 : it->second.samples_seen).verdict;
}

LinkReply ChannelLinks::request(std::uint64_t request_id, int sensor_id, const LinkKeys& keys,
                                const TraceRows* preloaded) {
  auto it = links_.find(sensor_id);
  if (it == links_.end()) return reject(request_id, sensor_id, "unknown sensor id " + std::to_string(sensor_id));
  Link& link = it->second;
  LinkSpec next;
  try {
    next = apply_link_keys(link.spec, keys, preloaded);  // validates; throws and changes nothing when invalid
  } catch (const LinkError& e) {
    return reject(request_id, sensor_id, e.what());
  }
  set_link(link, next, true);
  link.ramp.reset();  // the operator's word ends a ramp in progress
  link.unjournaled_request = request_id;
  link.last_request_id = request_id;
  link.reject_reason.clear();
  return LinkReply{request_id, sensor_id, true, {}};
}

LinkReply ChannelLinks::reject(std::uint64_t request_id, int sensor_id, const std::string& reason) {
  if (auto it = links_.find(sensor_id); it != links_.end()) {
    it->second.last_request_id = request_id;
    it->second.reject_reason = reason;
  }
  return LinkReply{request_id, sensor_id, false, reason};
}

std::vector<LinkChange> ChannelLinks::take_changes() {
  std::vector<LinkChange> out;
  out.swap(changes_);
  return out;
}

LinkStatus ChannelLinks::status_of(const Link& link) {
  LinkStatus s;
  s.sensor_id = link.id;
  s.link = link.spec;
  s.in_time = probability_within(link.spec.delay, link.deadline_ms);
  s.past_deadline = link.past_deadline;
  s.count(link.stats, link.lifetime);
  s.last_request_id = link.last_request_id;
  s.rejection_reason = link.reject_reason;
  s.recent_fit = link.recent.fit();
  return s;
}

std::vector<LinkStatus> ChannelLinks::statuses() const {
  std::vector<LinkStatus> out;
  out.reserve(links_.size());
  for (const auto& [id, link] : links_) out.push_back(status_of(link));
  return out;
}

std::optional<LinkStatus> ChannelLinks::status(int sensor_id) const {
  const auto it = links_.find(sensor_id);
  if (it == links_.end()) return std::nullopt;
  return status_of(it->second);
}

std::optional<LinkSpec> ChannelLinks::link(int sensor_id) const {
  const auto it = links_.find(sensor_id);
  if (it == links_.end()) return std::nullopt;
  return it->second.spec;
}

std::optional<double> ChannelLinks::deadline_ms(int sensor_id) const {
  const auto it = links_.find(sensor_id);
  if (it == links_.end()) return std::nullopt;
  return it->second.deadline_ms;
}

}  // namespace netkf::nodes
