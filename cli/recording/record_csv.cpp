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

PeriodCsvRecorder::PeriodCsvRecorder(int state_dim) : n_(state_dim) {}

std::string PeriodCsvRecorder::header(int state_dim) {
  std::string h = "k,t";
  for (int i = 0; i < state_dim; ++i) h += ",x" + std::to_string(i);
  for (int i = 0; i < state_dim; ++i) h += ",xhat" + std::to_string(i);
  h += ",trace_P,fused,late,state,late_samples";
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
  estimates_[k] = estimate;
  try_complete(k);
}

void PeriodCsvRecorder::try_complete(std::int64_t k) {
  auto t = truth_.find(k);
  auto e = estimates_.find(k);
  if (t != truth_.end() && e != estimates_.end()) {
    std::ostringstream row;
    // t is the plant's time of period k (the truth's clock).
    row << k << ',' << format_double(t->second.t);
    for (double v : t->second.x) row << ',' << format_double(v);
    for (double v : e->second.x_hat) row << ',' << format_double(v);
    row << ',' << format_double(e->second.trace_P()) << ',';
    for (std::size_t i = 0; i < e->second.fused.size(); ++i) row << (i ? ";" : "") << e->second.fused[i];
    row << ',' << e->second.late << ',' << to_string(e->second.state) << ',';
    // Which samples `late` counts: each is for an earlier period, so a reader can tell which
    // periods lost a sample to its deadline (docs/recording.md).
    const auto& late = e->second;
    for (std::size_t i = 0; i < late.late_sensors.size() && i < late.late_periods.size(); ++i)
      row << (i ? ";" : "") << late.late_periods[i] << ':' << late.late_sensors[i];
    row << '\n';
    ready_[k] = row.str();
    truth_.erase(t);
    estimates_.erase(e);
  }
  // Forget unmatched old halves.
  while (!truth_.empty() && truth_.begin()->first < k - kJoinWindow) truth_.erase(truth_.begin());
  while (!estimates_.empty() && estimates_.begin()->first < k - kJoinWindow) estimates_.erase(estimates_.begin());
}

std::size_t PeriodCsvRecorder::flush(std::ostream& out) {
  const std::size_t n = ready_.size();
  for (const auto& [k, line] : ready_) out << line;
  rows_written_ += n;
  ready_.clear();
  return n;
}

SampleCsvRecorder::SampleCsvRecorder(int max_measurement_dim) : m_(max_measurement_dim) {}

std::string SampleCsvRecorder::header(int max_measurement_dim) {
  std::string h = "k,sensor_id,stamp,fused";
  for (int i = 0; i < max_measurement_dim; ++i) h += ",y" + std::to_string(i);
  return h;
}

void SampleCsvRecorder::add_delivered(const DeliveredRecord& sample) {
  auto f = fused_.find(sample.k);
  if (f == fused_.end()) {
    pending_[sample.k].push_back(sample);
  } else {
    // Estimate already seen: this sample arrived after k was fused (late).
    std::ostringstream row;
    row << sample.k << ',' << sample.sensor_id << ',' << format_double(sample.stamp) << ','
        << (f->second.count(sample.sensor_id) ? 1 : 0);
    for (int i = 0; i < m_; ++i)
      row << ',' << (i < static_cast<int>(sample.y.size()) ? format_double(sample.y[i]) : "");
    row << '\n';
    ready_.push_back(row.str());
  }
}

void SampleCsvRecorder::add_estimate(const Estimate& estimate) {
  const auto k = static_cast<std::int64_t>(estimate.k);
  auto& ids = fused_[k];
  ids.insert(estimate.fused.begin(), estimate.fused.end());
  auto p = pending_.find(k);
  if (p != pending_.end()) {
    auto samples = std::move(p->second);
    pending_.erase(p);
    for (const auto& s : samples) add_delivered(s);
  }
  while (!fused_.empty() && fused_.begin()->first < k - kJoinWindow) fused_.erase(fused_.begin());
  while (!pending_.empty() && pending_.begin()->first < k - kJoinWindow) pending_.erase(pending_.begin());
}

std::size_t SampleCsvRecorder::flush(std::ostream& out) {
  const std::size_t n = ready_.size();
  for (const auto& line : ready_) out << line;
  ready_.clear();
  return n;
}

}  // namespace netkf::cli
