// The observed arrival rate (observed_rate.hpp): since the change and over the window.
#include "netkf/cli/live/observed_rate.hpp"

namespace netkf::cli {

std::uint64_t delivered_in_time(const LinkStatus& status) {
  return status.delivered >= status.past_deadline ? status.delivered - status.past_deadline : 0;
}

std::optional<double> observed_rate_since_change(const LinkStatus& status) {
  if (status.samples_in == 0) return std::nullopt;
  return static_cast<double>(delivered_in_time(status)) / static_cast<double>(status.samples_in);
}

void ObservedRateWindow::add(const LinkStatus& status) {
  const Counts now{status.samples_in, delivered_in_time(status)};
  // The channel counts every sample both since the change and over its lifetime; the counts
  // since the change started again (a model was set, by request or timeline, or the channel
  // restarted) when they did not grow as much as the lifetime count did.
  const bool restarted = !seen_ || status.samples_total < samples_total_ || now.samples < reports_.back().samples ||
                         now.samples - reports_.back().samples != status.samples_total - samples_total_;
  if (restarted) reports_.assign(1, Counts{});  // the change itself: nothing counted yet
  seen_ = true;
  samples_total_ = status.samples_total;
  if (now.samples == reports_.back().samples) return;  // no sample since the last report
  reports_.push_back(now);
  // Keep the window's start first: the newest report at least kWindowSamples before now (else
  // the change); older reports can never start a window again, since the counts only grow.
  while (reports_.size() > 2 && now.samples - reports_[1].samples >= kWindowSamples) reports_.pop_front();
}

std::optional<double> ObservedRateWindow::rate() const {
  if (reports_.size() < 2) return std::nullopt;
  const Counts& start = reports_.front();
  const Counts& now = reports_.back();
  const std::uint64_t in_time = now.in_time >= start.in_time ? now.in_time - start.in_time : 0;
  return static_cast<double>(in_time) / static_cast<double>(now.samples - start.samples);
}

std::uint64_t ObservedRateWindow::samples() const {
  return reports_.size() < 2 ? 0 : reports_.back().samples - reports_.front().samples;
}

}  // namespace netkf::cli
