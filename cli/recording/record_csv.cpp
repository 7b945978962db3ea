#include "record_csv.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "period_join.hpp"

namespace netkf::cli {

namespace {
// A period whose partner record never comes (recording started mid-period, or a
// process restarted) is dropped after this many newer periods, bounding memory.
constexpr std::int64_t kJoinWindow = PeriodJoin::kWindow;
}  // namespace

std::string format_double(double value) {
  if (std::isnan(value)) return "nan";  // never expected: the estimator publishes no NaN
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", value);
  return buf;
}

PeriodCsvRecorder::PeriodCsvRecorder(int state_dim, int max_delay_periods)
    : n_(state_dim), max_delay_periods_(max_delay_periods) {}

std::string PeriodCsvRecorder::header(int state_dim, int max_delay_periods) {
  std::string h = "k,t";
  for (int i = 0; i < state_dim; ++i) h += ",x" + std::to_string(i);
  for (int i = 0; i < state_dim; ++i) h += ",xhat" + std::to_string(i);
  h += ",trace_P,fused,late,state,late_samples";
  if (max_delay_periods > 0) {
    h += ",revisions";
    for (int i = 0; i < state_dim; ++i) h += ",xhat_final" + std::to_string(i);
    h += ",trace_P_final,fused_final";
  }
  return h;
}

void PeriodCsvRecorder::add_truth(const TruthRecord& truth) {
  if (static_cast<int>(truth.x.size()) != n_) {
    ++rejected_;
    return;
  }
  truth_[truth.k] = truth;
  try_complete(truth.k);
}

void PeriodCsvRecorder::add_estimate(const Estimate& estimate) {
  if (estimate.x_hat.size() != n_) {
    ++rejected_;
    return;
  }
  const auto k = static_cast<std::int64_t>(estimate.k);
  if (max_delay_periods_ == 0) {
    estimates_[k] = estimate;
  } else {
    if (estimate.revision == 0) {
      estimates_.emplace(k, estimate);  // the first in-time estimate is kept
      newest_in_time_ = std::max(newest_in_time_.value_or(k), k);
    }
    auto f = finals_.find(k);
    if (f == finals_.end()) finals_.emplace(k, estimate);
    else if (estimate.revision >= f->second.revision) f->second = estimate;
  }
  try_complete(k);
}

namespace {
void write_fused(std::ostream& row, const std::vector<int>& fused) {
  for (std::size_t i = 0; i < fused.size(); ++i) row << (i ? ";" : "") << fused[i];
}
}  // namespace

bool PeriodCsvRecorder::write_row(std::int64_t k) {
  auto t = truth_.find(k);
  auto e = estimates_.find(k);
  if (t == truth_.end() || e == estimates_.end()) return false;
  std::ostringstream row;
  // t is the plant's time of period k (the truth's clock).
  row << k << ',' << format_double(t->second.t);
  for (double v : t->second.x) row << ',' << format_double(v);
  for (double v : e->second.x_hat) row << ',' << format_double(v);
  row << ',' << format_double(e->second.trace_P()) << ',';
  write_fused(row, e->second.fused);
  row << ',' << e->second.late << ',' << to_string(e->second.state) << ',';
  // Which samples `late` counts: each is for an earlier period, so a reader can tell which
  // periods lost a sample to its deadline (docs/recording.md).
  const Estimate& late = e->second;
  for (std::size_t i = 0; i < late.late_sensors.size() && i < late.late_periods.size(); ++i)
    row << (i ? ";" : "") << late.late_periods[i] << ':' << late.late_sensors[i];
  if (max_delay_periods_ > 0) {
    auto f = finals_.find(k);
    const Estimate& fin = f != finals_.end() ? f->second : e->second;
    row << ',' << fin.revision;
    for (double v : fin.x_hat) row << ',' << format_double(v);
    row << ',' << format_double(fin.trace_P()) << ',';
    write_fused(row, fin.fused);
    if (f != finals_.end()) finals_.erase(f);
  }
  row << '\n';
  ready_[k] = row.str();
  truth_.erase(t);
  estimates_.erase(e);
  return true;
}

void PeriodCsvRecorder::complete_final() {
  if (!newest_in_time_) return;
  // Period k is final once the in-time estimate of k + D + 1 is out: k's late samples are taken
  // until k + D is fused or its deadline passes, whichever is later (estimator_core.hpp), and
  // k + D + 1 is fused after that (its tick comes a period after k + D's).
  const std::int64_t last_final = *newest_in_time_ - max_delay_periods_ - 1;
  for (auto it = estimates_.begin(); it != estimates_.end() && it->first <= last_final;) {
    const std::int64_t k = (it++)->first;
    write_row(k);
  }
}

void PeriodCsvRecorder::finish_pending() {
  for (auto it = estimates_.begin(); it != estimates_.end();) {
    const std::int64_t k = (it++)->first;
    write_row(k);
  }
}

void PeriodCsvRecorder::try_complete(std::int64_t k) {
  if (max_delay_periods_ == 0) write_row(k);
  else complete_final();
  // Forget unmatched old halves.
  while (!truth_.empty() && truth_.begin()->first < k - kJoinWindow) truth_.erase(truth_.begin());
  while (!estimates_.empty() && estimates_.begin()->first < k - kJoinWindow) estimates_.erase(estimates_.begin());
  while (!finals_.empty() && finals_.begin()->first < k - kJoinWindow) finals_.erase(finals_.begin());
}

std::size_t PeriodCsvRecorder::flush(std::ostream& out) {
  const std::size_t n = ready_.size();
  for (const auto& [k, line] : ready_) out << line;
  rows_written_ += n;
  ready_.clear();
  return n;
}

SampleCsvRecorder::SampleCsvRecorder(int max_measurement_dim, int max_delay_periods)
    : m_(max_measurement_dim), max_delay_periods_(max_delay_periods) {}

std::string SampleCsvRecorder::header(int max_measurement_dim, int max_delay_periods) {
  std::string h = max_delay_periods > 0 ? "k,sensor_id,stamp,fused,fused_in_time" : "k,sensor_id,stamp,fused";
  for (int i = 0; i < max_measurement_dim; ++i) h += ",y" + std::to_string(i);
  return h;
}

void SampleCsvRecorder::write_row(const DeliveredRecord& sample, bool fused, bool fused_in_time) {
  std::ostringstream row;
  row << sample.k << ',' << sample.sensor_id << ',' << format_double(sample.stamp) << ',' << (fused ? 1 : 0);
  if (max_delay_periods_ > 0) row << ',' << (fused_in_time ? 1 : 0);
  for (int i = 0; i < m_; ++i) row << ',' << (i < static_cast<int>(sample.y.size()) ? format_double(sample.y[i]) : "");
  row << '\n';
  ready_.push_back(row.str());
}

void SampleCsvRecorder::add_delivered(const DeliveredRecord& sample) {
  auto f = fused_.find(sample.k);
  if (max_delay_periods_ > 0 || f == fused_.end()) {
    pending_[sample.k].push_back(sample);  // D > 0: until k is final
  } else {
    // Estimate already seen: this sample arrived after k was fused (late).
    write_row(sample, f->second.count(sample.sensor_id) > 0, false);
  }
}

void SampleCsvRecorder::write_final(std::int64_t k) {
  auto p = pending_.find(k);
  if (p == pending_.end()) return;
  const auto& fused = fused_[k];
  const auto& in_time = fused_in_time_[k];
  for (const auto& s : p->second) write_row(s, fused.count(s.sensor_id) > 0, in_time.count(s.sensor_id) > 0);
  pending_.erase(p);
}

void SampleCsvRecorder::add_estimate(const Estimate& estimate) {
  const auto k = static_cast<std::int64_t>(estimate.k);
  auto& ids = fused_[k];
  ids.insert(estimate.fused.begin(), estimate.fused.end());  // a revision only adds samples
  if (max_delay_periods_ > 0) {
    if (estimate.revision == 0) {
      fused_in_time_[k].insert(estimate.fused.begin(), estimate.fused.end());
      // k - D - 1 is final now (see PeriodCsvRecorder), and so is everything before it.
      while (!pending_.empty() && pending_.begin()->first <= k - max_delay_periods_ - 1)
        write_final(pending_.begin()->first);
    }
  } else {
    auto p = pending_.find(k);
    if (p != pending_.end()) {
      auto samples = std::move(p->second);
      pending_.erase(p);
      for (const auto& s : samples) add_delivered(s);
    }
  }
  while (!fused_.empty() && fused_.begin()->first < k - kJoinWindow) fused_.erase(fused_.begin());
  while (!fused_in_time_.empty() && fused_in_time_.begin()->first < k - kJoinWindow)
    fused_in_time_.erase(fused_in_time_.begin());
  while (!pending_.empty() && pending_.begin()->first < k - kJoinWindow) pending_.erase(pending_.begin());
}

void SampleCsvRecorder::finish_pending() {
  while (!pending_.empty()) write_final(pending_.begin()->first);
}

std::size_t SampleCsvRecorder::flush(std::ostream& out) {
  const std::size_t n = ready_.size();
  for (const auto& line : ready_) out << line;
  ready_.clear();
  return n;
}

}  // namespace netkf::cli
