#include "record_csv.hpp"

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <limits>
#include <sstream>

#include "netkf/cli/live/period_join.hpp"

namespace netkf::cli {

namespace {
// A sample's period whose estimate never comes is dropped after this many newer periods.
constexpr std::int64_t kJoinWindow = PeriodJoin::kWindow;
}  // namespace

std::string format_double(double value) {
  if (std::isnan(value)) return "nan";  // never expected: the estimator publishes no NaN
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", value);
  return buf;
}

PeriodCsvRecorder::PeriodCsvRecorder(int state_dim, int max_delay_periods, int input_dim, bool actuation_link)
    : n_(state_dim), max_delay_periods_(max_delay_periods), m_(input_dim), actuation_link_(actuation_link) {}

std::string PeriodCsvRecorder::header(int state_dim, int max_delay_periods, int input_dim, bool actuation_link) {
  std::string h = "k,t";
  for (int i = 0; i < state_dim; ++i) h += ",x" + std::to_string(i);
  for (int i = 0; i < state_dim; ++i) h += ",xhat" + std::to_string(i);
  h += ",trace_P,fused,late,state,late_samples";
  if (max_delay_periods > 0) {
    h += ",revisions";
    for (int i = 0; i < state_dim; ++i) h += ",xhat_final" + std::to_string(i);
    h += ",trace_P_final,fused_final";
  }
  for (int i = 0; i < input_dim; ++i) h += ",u" + std::to_string(i);
  if (actuation_link) h += ",nu";
  return h;
}

void PeriodCsvRecorder::add_truth(const Truth& truth) {
  if (static_cast<int>(truth.x.size()) != n_ || (m_ > 0 && static_cast<int>(truth.u.size()) != m_)) {
    ++rejected_;
    return;
  }
  if (last_written_ && truth.k <= *last_written_) return;  // its row is written (a duplicate)
  truth_[truth.k] = truth;
  newest_truth_ = std::max(newest_truth_.value_or(truth.k), truth.k);
  emit(false);
}

void PeriodCsvRecorder::add_estimate(const Estimate& estimate) {
  if (estimate.x_hat.size() != n_) {
    ++rejected_;
    return;
  }
  const auto k = static_cast<std::int64_t>(estimate.k);
  if (last_written_ && k <= *last_written_) return;  // after its row was written without it
  if (estimate.revision == 0) newest_in_time_ = std::max(newest_in_time_.value_or(k), k);
  if (max_delay_periods_ == 0) {
    estimates_[k] = estimate;
  } else {
    if (estimate.revision == 0) estimates_.emplace(k, estimate);  // the first in-time estimate is kept
    auto f = finals_.find(k);
    if (f == finals_.end()) finals_.emplace(k, estimate);
    else if (estimate.revision >= f->second.revision) f->second = estimate;
  }
  emit(false);
}

namespace {
void write_fused(std::ostream& row, const std::vector<int>& fused) {
  for (std::size_t i = 0; i < fused.size(); ++i) row << (i ? ";" : "") << fused[i];
}
}  // namespace

void PeriodCsvRecorder::emit(bool finishing) {
  while (!truth_.empty() || !estimates_.empty() || !finals_.empty()) {
    std::int64_t k = std::numeric_limits<std::int64_t>::max();
    if (!truth_.empty()) k = std::min(k, truth_.begin()->first);
    if (!estimates_.empty()) k = std::min(k, estimates_.begin()->first);
    if (!finals_.empty()) k = std::min(k, finals_.begin()->first);
    const auto t = truth_.find(k);
    if (t == truth_.end()) {
      // The plant publishes its periods in order: once a newer one is here, k's truth is lost
      // (or the recorder joined after it).
      if (!finishing && (!newest_truth_ || *newest_truth_ < k)) return;
      estimates_.erase(k);
      finals_.erase(k);
      continue;
    }
    const auto e = estimates_.find(k);
    const bool final = e != estimates_.end() &&
                       (max_delay_periods_ == 0 || finishing || newest_in_time_.value_or(k) >= k + max_delay_periods_ + 1);
    const bool estimate_lost = e == estimates_.end() && newest_in_time_.value_or(k) > k;
    if (!final && !finishing && !estimate_lost && *newest_truth_ < k + kGiveUpPeriods) return;
    write_row(k, t->second, e != estimates_.end() ? &e->second : nullptr);
    truth_.erase(t);
    estimates_.erase(k);
    finals_.erase(k);
    last_written_ = k;
  }
}

void PeriodCsvRecorder::write_row(std::int64_t k, const Truth& truth, const Estimate* e) {
  std::ostringstream row;
  // t is the plant's time of period k (the truth's clock).
  row << k << ',' << format_double(truth.t);
  for (double v : truth.x) row << ',' << format_double(v);
  if (e == nullptr) {
    // No estimate: empty estimate cells, state `none`.
    for (int i = 0; i < n_; ++i) row << ',';
    row << ",,,,none,";
    if (max_delay_periods_ > 0) row << std::string(static_cast<std::size_t>(n_) + 3, ',');
    ++rows_without_estimate_;
  } else {
    for (double v : e->x_hat) row << ',' << format_double(v);
    row << ',' << format_double(e->trace_P()) << ',';
    write_fused(row, e->fused);
    row << ',' << e->late << ',' << to_string(e->state) << ',';
    // Which samples `late` counts: each is for an earlier period, so a reader can tell which
    // periods lost a sample to its deadline (docs/recording.md).
    for (std::size_t i = 0; i < e->late_sensors.size() && i < e->late_periods.size(); ++i)
      row << (i ? ";" : "") << e->late_periods[i] << ':' << e->late_sensors[i];
    if (max_delay_periods_ > 0) {
      auto f = finals_.find(k);
      const Estimate& fin = f != finals_.end() ? f->second : *e;
      row << ',' << fin.revision;
      for (double v : fin.x_hat) row << ',' << format_double(v);
      row << ',' << format_double(fin.trace_P()) << ',';
      write_fused(row, fin.fused);
    }
  }
  for (double v : truth.u) row << ',' << format_double(v);
  if (actuation_link_) row << ',' << (truth.input_arrived ? 1 : 0);
  row << '\n';
  ready_[k] = row.str();
}

void PeriodCsvRecorder::finish_pending() { emit(true); }

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

void SampleCsvRecorder::write_row(const DeliveredMeasurement& sample, bool fused, bool fused_in_time) {
  std::ostringstream row;
  row << sample.k << ',' << sample.sensor_id << ',' << format_double(sample.stamp) << ',' << (fused ? 1 : 0);
  if (max_delay_periods_ > 0) row << ',' << (fused_in_time ? 1 : 0);
  for (int i = 0; i < m_; ++i) row << ',' << (i < static_cast<int>(sample.y.size()) ? format_double(sample.y[i]) : "");
  row << '\n';
  ready_.push_back(row.str());
}

void SampleCsvRecorder::add_delivered(const DeliveredMeasurement& sample) {
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
