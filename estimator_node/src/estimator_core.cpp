#include "netkf/nodes/estimator_core.hpp"

#include <algorithm>
#include <stdexcept>

namespace netkf::nodes {

const char* to_string(SampleRejection r) {
  switch (r) {
    case SampleRejection::unknown_sensor: return "unknown_sensor";
    case SampleRejection::wrong_size: return "wrong_size";
    case SampleRejection::non_finite: return "non_finite";
    case SampleRejection::duplicate: return "duplicate";
    case SampleRejection::buffer_full: return "buffer_full";
    case SampleRejection::stale_tick: return "stale_tick";
    case SampleRejection::count_: break;
  }
  return "?";
}

namespace {
FilterModel filter_model(const Scenario& s) {
  FilterModel m;
  m.A = s.plant.A;
  m.Q = s.plant.Q;
  m.B = s.plant.B;
  for (const auto& sensor : s.sensors) m.sensors.push_back(SensorModel{sensor.id, sensor.C, sensor.R});
  return m;
}
Vector prior_mean(const Scenario& s) {
  return s.plant.x0.size() == s.plant.A.rows() ? s.plant.x0 : Vector(Vector::Zero(s.plant.A.rows()));
}
Matrix prior_covariance(const Scenario& s) {
  return s.plant.P0.rows() == s.plant.A.rows() ? s.plant.P0 : Matrix(Matrix::Identity(s.plant.A.rows(), s.plant.A.rows()));
}
FilterOptions filter_options(const Scenario& s) {
  FilterOptions o;
  o.divergence_trace_bound = s.estimator.divergence_trace_bound;
  return o;
}
}  // namespace

EstimatorCore::EstimatorCore(const Scenario& scenario)
    : filter_(filter_model(scenario), prior_mean(scenario), prior_covariance(scenario), filter_options(scenario)),
      period_s_(scenario.period_s()),
      deadline_ns_(static_cast<std::int64_t>(scenario.deadline_ms()) * 1000000) {
  for (const auto& s : scenario.sensors) sensor_dims_[s.id] = static_cast<int>(s.C.rows());
  if (scenario.plant.B) input_dim_ = static_cast<int>(scenario.plant.B->cols());
  if (scenario.plant.control) {
    if (!scenario.plant.B) throw std::invalid_argument("plant.control needs plant.B");
    const Matrix& L = scenario.plant.control->gain;
    if (L.rows() != input_dim_ || L.cols() != scenario.plant.A.rows()) {
      throw std::invalid_argument("control gain L must be " + std::to_string(input_dim_) + " x " +
                                  std::to_string(scenario.plant.A.rows()));
    }
    gain_ = L;
  }
}

std::uint64_t EstimatorCore::rejected_total() const {
  std::uint64_t total = rejected_before_restart_;
  for (auto r : rejected_) total += r;
  return total;
}

std::size_t EstimatorCore::buffered_samples() const {
  std::size_t n = 0;
  for (const auto& [k, samples] : future_) n += samples.size();
  return n;
}

std::optional<std::int64_t> EstimatorCore::pending_deadline_ns() const {
  if (!open_) return std::nullopt;
  return open_->deadline_ns;
}

std::optional<std::uint64_t> EstimatorCore::open_period() const {
  if (!open_) return std::nullopt;
  return open_->k;
}

void EstimatorCore::resume(const Estimate& last_published) {
  if (open_ || last_fused_) throw std::invalid_argument("resume: the estimator has already started");
  filter_.restore(last_published.x_hat, last_published.P);
  last_fused_ = last_published.k;
  resumed_after_ = last_published.k;
  late_total_ = last_published.late_total;
  rejected_before_restart_ = last_published.rejected_total;
  restarts_ = last_published.restarts + 1;  // this life is one restart more
  // The input sent for period k (a tick that never arrives is predicted with it, as in on_tick).
  if (gain_) last_control_ = Vector(-(*gain_) * filter_.x());
  else if (input_dim_ > 0) last_control_ = Vector::Zero(input_dim_);
}

void EstimatorCore::count_rejection(SampleRejection reason) { reject(reason); }

void EstimatorCore::count_late(int sensor_id, std::uint64_t k) {
  ++late_total_;
  late_since_publish_.push_back(sensor_id);
  late_periods_since_publish_.push_back(k);
}

void EstimatorCore::predict_with(const Vector& applied_input) {
  if (input_dim_ > 0) {
    // x̂_{k|k-1} = A x̂_{k-1|k-1} + B u_{k-1}: an absent input means the plant applied zero.
    const Vector u = applied_input.size() == input_dim_ ? applied_input : Vector(Vector::Zero(input_dim_));
    filter_.predict(&u);
  } else {
    filter_.predict(nullptr);
  }
}

void EstimatorCore::open(std::uint64_t k, std::int64_t now_ns) {
  OpenPeriod p;
  p.k = k;
  p.t = static_cast<double>(k) * period_s_;
  p.deadline_ns = now_ns + deadline_ns_;
  if (auto it = future_.find(k); it != future_.end()) {
    for (auto& [id, b] : it->second) {
      p.samples.emplace(id, std::move(b.sample));
      p.last_stamp_ns = std::max(p.last_stamp_ns, b.stamp_ns);
    }
    future_.erase(it);
  }
  // Buffered samples of periods before k can no longer be fused: they count as late.
  for (auto it = future_.begin(); it != future_.end() && it->first < k;) {
    for (const auto& [id, b] : it->second) count_late(id, it->first);
    it = future_.erase(it);
  }
  open_ = std::move(p);
}

bool EstimatorCore::complete() const { return open_ && open_->samples.size() == sensor_dims_.size(); }

PeriodEstimate EstimatorCore::fuse(std::int64_t now_ns) {
  std::vector<SensorSample> samples;
  samples.reserve(open_->samples.size());
  for (auto& [id, s] : open_->samples) samples.push_back(s);
  const double trace_P_pred = filter_.P().trace();  // Tr P_{k|k-1}, before the fused update
  const FusedUpdateResult result = filter_.update(samples);
  for (const auto& [id, reason] : result.rejected) {
    switch (reason) {
      case RejectReason::unknown_sensor: reject(SampleRejection::unknown_sensor); break;
      case RejectReason::wrong_size: reject(SampleRejection::wrong_size); break;
      case RejectReason::non_finite: reject(SampleRejection::non_finite); break;
      default: reject(SampleRejection::duplicate); break;
    }
  }
  PeriodEstimate e;
  e.k = open_->k;
  e.t = open_->t;
  e.x_hat = filter_.x();
  e.P = filter_.P();
  e.trace_P_pred = trace_P_pred;
  e.fused = result.fused_ids;
  // One list is the count and the ids: `late` can never disagree with `late_sensors`.
  e.late_sensors = std::move(late_since_publish_);
  late_since_publish_.clear();
  e.late_periods = std::move(late_periods_since_publish_);
  late_periods_since_publish_.clear();
  e.late = static_cast<std::uint32_t>(e.late_sensors.size());
  e.late_total = late_total_;
  e.rejected_total = rejected_total();
  e.state = filter_.state();
  if (gain_) {
    // LQG certainty equivalence: u_k = -L x̂_{k|k}.
    e.control = Vector(-(*gain_) * filter_.x());
    last_control_ = e.control;
  } else if (input_dim_ > 0) {
    last_control_ = Vector::Zero(input_dim_);
  }
  e.fused_at_ns = now_ns;
  e.restarts = restarts_;
  e.last_sample_stamp_ns = open_->last_stamp_ns;
  last_fused_ = open_->k;
  open_.reset();
  return e;
}

std::vector<PeriodEstimate> EstimatorCore::on_tick(std::uint64_t k, const Vector& applied_input, std::int64_t now_ns) {
  std::vector<PeriodEstimate> out;
  if (resumed_after_ && k <= *resumed_after_) return out;  // the tick history of a restart: already fused
  if ((last_fused_ && k <= *last_fused_) || (open_ && k <= open_->k)) {
    reject(SampleRejection::stale_tick);  // duplicate or reordered tick
    return out;
  }
  // A later tick closes the open period even before its deadline.
  if (open_) out.push_back(fuse(now_ns));
  if (last_fused_) {
    // Ticks k' in (last fused, k) never arrived: fuse those periods with whatever was
    // buffered for them, predicting with the input we sent (assumed applied).
    const std::uint64_t first_missing = *last_fused_ + 1;
    for (std::uint64_t j = first_missing; j < k; ++j) {
      predict_with(last_control_.value_or(Vector()));
      open(j, now_ns);
      PeriodEstimate e = fuse(now_ns);
      e.skipped_tick = true;
      e.control.reset();  // the plant has moved past period j: nothing to send
      out.push_back(std::move(e));
    }
    predict_with(applied_input);
  }
  // else: the first tick seen; the prior x0, P0 stands for this period.
  open(k, now_ns);
  if (complete()) out.push_back(fuse(now_ns));
  return out;
}

std::vector<PeriodEstimate> EstimatorCore::on_sample(int sensor_id, std::uint64_t k, const Vector& y,
                                                     std::int64_t stamp_ns, std::int64_t now_ns) {
  std::vector<PeriodEstimate> out;
  auto dim = sensor_dims_.find(sensor_id);
  if (dim == sensor_dims_.end()) {
    reject(SampleRejection::unknown_sensor);
    return out;
  }
  if (y.size() != dim->second) {
    reject(SampleRejection::wrong_size);
    return out;
  }
  if (!y.allFinite()) {
    reject(SampleRejection::non_finite);
    return out;
  }
  // A sample for a fused period (or one before the first tick seen) is late: lost.
  if ((last_fused_ && k <= *last_fused_) || (open_ && k < open_->k)) {
    count_late(sensor_id, k);
    return out;
  }
  if (open_ && k == open_->k) {
    if (!open_->samples.emplace(sensor_id, SensorSample{sensor_id, y}).second) {
      reject(SampleRejection::duplicate);
      return out;
    }
    open_->last_stamp_ns = std::max(open_->last_stamp_ns, stamp_ns);
    if (complete()) out.push_back(fuse(now_ns));
    return out;
  }
  // A future period: keep it until its tick (bounded, so a flood cannot grow memory).
  const std::uint64_t base = open_ ? open_->k : (last_fused_ ? *last_fused_ : k);
  const bool too_far = k > base + kMaxFuturePeriods;
  const bool too_many = !future_.contains(k) && future_.size() >= kMaxFuturePeriods;
  if (too_far || too_many) {
    reject(SampleRejection::buffer_full);
    return out;
  }
  if (!future_[k].emplace(sensor_id, Buffered{SensorSample{sensor_id, y}, stamp_ns}).second) {
    reject(SampleRejection::duplicate);
  }
  return out;
}

std::vector<PeriodEstimate> EstimatorCore::on_deadline(std::int64_t now_ns) {
  std::vector<PeriodEstimate> out;
  if (open_ && now_ns >= open_->deadline_ns) out.push_back(fuse(now_ns));
  return out;
}

}  // namespace netkf::nodes
