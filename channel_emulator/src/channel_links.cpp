#include "netkf/nodes/channel_links.hpp"

#include <stdexcept>

namespace netkf::nodes {

ChannelLinks::ChannelLinks(const Scenario& scenario) {
  for (const auto& s : scenario.sensors) {
    LinkReport r;
    r.sensor_id = s.id;
    r.model = s.link;
    links_.emplace(s.id, Link{LinkLossProcess(s.link, derive_seed(scenario.seed, "link", static_cast<std::uint64_t>(s.id))),
                              std::move(r)});
  }
}

ChannelLinks::Verdict ChannelLinks::on_sample(int sensor_id) {
  auto it = links_.find(sensor_id);
  if (it == links_.end()) {
    ++unknown_sensor_samples_;
    return Verdict::unknown_sensor;
  }
  const bool dropped = it->second.process.next_dropped();
  it->second.report.stats.record(dropped);
  it->second.report.lifetime.record(dropped);
  return dropped ? Verdict::dropped : Verdict::delivered;
}

LinkChangeResult ChannelLinks::apply(std::uint64_t request_id, int sensor_id, const LinkModel& model) {
  auto it = links_.find(sensor_id);
  if (it == links_.end()) return reject(request_id, sensor_id, "unknown sensor id " + std::to_string(sensor_id));
  try {
    it->second.process.set_model(model);  // validates; throws and changes nothing when invalid
  } catch (const std::exception& e) {
    return reject(request_id, sensor_id, e.what());
  }
  LinkReport& r = it->second.report;
  r.model = model;
  r.stats = LinkStatistics{};
  r.last_request_id = request_id;
  r.last_request_rejected = false;
  r.reject_reason.clear();
  return LinkChangeResult{request_id, sensor_id, true, {}};
}

LinkChangeResult ChannelLinks::reject(std::uint64_t request_id, int sensor_id, const std::string& reason) {
  if (auto it = links_.find(sensor_id); it != links_.end()) {
    LinkReport& r = it->second.report;
    r.last_request_id = request_id;
    r.last_request_rejected = true;
    r.reject_reason = reason;
  }
  return LinkChangeResult{request_id, sensor_id, false, reason};
}

std::vector<LinkReport> ChannelLinks::reports() const {
  std::vector<LinkReport> out;
  out.reserve(links_.size());
  for (const auto& [id, link] : links_) out.push_back(link.report);
  return out;
}

const LinkReport* ChannelLinks::report(int sensor_id) const {
  auto it = links_.find(sensor_id);
  return it == links_.end() ? nullptr : &it->second.report;
}

}  // namespace netkf::nodes
