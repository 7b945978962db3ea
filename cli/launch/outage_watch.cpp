#include "outage_watch.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace netkf::cli {

std::optional<char> process_state(int pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!stat || !std::getline(stat, line)) return std::nullopt;
  // "pid (comm) S ...": comm may hold spaces and parentheses, the state follows the last ')'.
  const auto close = line.rfind(')');
  if (close == std::string::npos || close + 2 >= line.size()) return std::nullopt;
  return line[close + 2];
}

std::string OutageWatch::Outage::describe() const {
  char when[64];
  std::snprintf(when, sizeof when, " for %.1f s%s", seconds(), ongoing ? " (until the end)" : "");
  std::string text = what + when;
  if (first_period && last_period && *last_period >= *first_period)
    text += " (periods " + std::to_string(*first_period) + "-" + std::to_string(*last_period) + ")";
  return text;
}

OutageWatch::OutageWatch(std::chrono::milliseconds period, int min_gap_periods)
    : min_gap_(std::max<Clock::duration>(period * min_gap_periods, std::chrono::milliseconds(200))),
      min_gap_periods_(min_gap_periods) {}

void OutageWatch::open(const std::string& key, const std::string& what, Clock::time_point from,
                       std::optional<std::int64_t> first_period) {
  if (open_.count(key)) return;
  outages_.push_back({what, from, from, true, first_period, std::nullopt});
  open_[key] = outages_.size() - 1;
}

void OutageWatch::close(const std::string& key, Clock::time_point to, std::optional<std::int64_t> last_period) {
  auto it = open_.find(key);
  if (it == open_.end()) return;
  auto& o = outages_[it->second];
  o.to = to;
  o.ongoing = false;
  if (last_period) o.last_period = last_period;
  open_.erase(it);
}

void OutageWatch::child(const std::string& name, int pid, ChildState state, Clock::time_point now) {
  const std::string stopped_key = "stopped:" + name, down_key = "down:" + name;
  if (state != ChildState::running || pid <= 0) {
    close(stopped_key, now);
    if (state == ChildState::restarting) open(down_key, name + " was down (waiting for its restart)", now);
    else close(down_key, now);  // ended (the run's end, or given up: the supervisor says why)
    return;
  }
  close(down_key, now);
  const auto seen = process_state(pid);
  if (seen && (*seen == 'T' || *seen == 't')) open(stopped_key, name + " was stopped (SIGSTOP)", now);
  else close(stopped_key, now);
}

void OutageWatch::truth(std::int64_t k, Clock::time_point now) {
  if (last_truth_ && k > last_truth_->first && now - last_truth_->second > min_gap_) {
    outages_.push_back({"the plant published no period after period " + std::to_string(last_truth_->first),
                        last_truth_->second, now, false, std::nullopt, std::nullopt});
  }
  if (!last_truth_ || k > last_truth_->first) last_truth_ = {k, now};
  // The estimator's lag behind the plant, in periods.
  const std::int64_t newest_estimate = last_estimate_ ? last_estimate_->first : -1;
  if (last_estimate_ && k - newest_estimate > min_gap_periods_)
    open("lag:estimator", "no estimate arrived (the estimator fell behind the plant)", now, newest_estimate + 1);
}

void OutageWatch::estimate(std::int64_t k, std::size_t fused_count, Clock::time_point now) {
  if (!last_estimate_ || k > last_estimate_->first) last_estimate_ = {k, now};
  if (last_truth_ && last_truth_->first - k <= min_gap_periods_) close("lag:estimator", now, last_truth_->first - 1);
  if (fused_count == 0) {
    if (nothing_fused_since_ < 0) {
      nothing_fused_since_ = k;
      nothing_fused_from_ = now;
    }
    return;
  }
  if (nothing_fused_since_ >= 0 && k - nothing_fused_since_ >= 5 * min_gap_periods_) {
    outages_.push_back({"no sample reached the estimator (the channel emulator or every sensor stalled, or every "
                        "link dropped)",
                        nothing_fused_from_, now, false, nothing_fused_since_, k - 1});
  }
  nothing_fused_since_ = -1;
}

void OutageWatch::finish(Clock::time_point now) {
  if (nothing_fused_since_ >= 0 && last_estimate_ && last_estimate_->first - nothing_fused_since_ >= 5 * min_gap_periods_) {
    outages_.push_back({"no sample reached the estimator (the channel emulator or every sensor stalled, or every "
                        "link dropped)",
                        nothing_fused_from_, now, true, nothing_fused_since_, last_estimate_->first});
    nothing_fused_since_ = -1;
  }
  for (auto& [key, index] : open_) {
    outages_[index].to = now;
    outages_[index].ongoing = true;
    if (key == "lag:estimator" && last_truth_) outages_[index].last_period = last_truth_->first;
  }
  open_.clear();
  std::stable_sort(outages_.begin(), outages_.end(), [](const Outage& a, const Outage& b) { return a.from < b.from; });
}

std::string OutageWatch::describe_between(Clock::time_point from, Clock::time_point to) const {
  std::string text;
  for (const auto& o : outages_) {
    if (o.to < from || o.from > to) continue;
    text += (text.empty() ? "" : "; ") + o.describe();
  }
  return text;
}

}  // namespace netkf::cli
