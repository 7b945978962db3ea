#include "netkf/nodes/estimator_core.hpp"

#include <algorithm>
#include <iterator>
#include <stdexcept>

namespace netkf::nodes {

EstimatorCore::EstimatorCore(const Scenario& scenario)
    : filter_(filter_model(scenario), prior_mean(scenario), prior_covariance(scenario), filter_options(scenario)),
      period_s_(scenario.period_s()),
      deadline_ns_(static_cast<std::int64_t>(scenario.deadline_ms()) * 1000000),
      max_delay_periods_(scenario.estimator.fusable_delay_periods()) {
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
    const ControlSpec& c = *scenario.plant.control;
    if (c.link && !c.acknowledged) {
      acknowledged_ = false;
      on_loss_ = c.on_loss;
      input_arrival_rate_ = actuation_arrival_rate(scenario);
      applied_mean_ = Vector::Zero(input_dim_);
      applied_second_moment_ = Matrix::Zero(input_dim_, input_dim_);
    }
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

void EstimatorCore::predict_next(const Vector& applied_input) {
  if (acknowledged_) {
    keep_input_after(predict_with(applied_input), std::nullopt);
  } else {
    auto [mean, covariance] = predict_with_expected_input();
    keep_input_after(std::move(mean), std::move(covariance));
  }
}

void EstimatorCore::keep_input_after(std::optional<Vector> input, std::optional<Matrix> input_covariance) {
  // A re-run predicts with the same input (the one applied: a re-run never changes the past).
  if (history_.empty() || !last_fused_ || history_.back().k != *last_fused_) return;
  history_.back().input_after = std::move(input);
  history_.back().input_covariance_after = std::move(input_covariance);
}

Vector EstimatorCore::predict_with(const Vector& applied_input) {
  Vector u;  // stays empty without B
  if (input_dim_ > 0) {
    // x̂_{k|k-1} = A x̂_{k-1|k-1} + B u_{k-1}: an absent input means the plant applied zero.
    u = applied_input.size() == input_dim_ ? applied_input : Vector(Vector::Zero(input_dim_));
    filter_.predict(&u);
  } else {
    filter_.predict(nullptr);
  }
  return u;
}

std::pair<Vector, Matrix> EstimatorCore::predict_with_expected_input() {
  // u^a_{k-1} = ν u_{k-1} + (1 − ν) h, ν ~ Bernoulli(ν̄) independent of the past, h = 0 (zero) or
  // u^a_{k-2} (hold): its mean and second moment follow by one step of that recursion. The
  // filter takes the spread as extra process noise B Σ_u B' (for zero Schenato et al. 2007,
  // Sec. VI; for hold the correlation of u^a_{k-2} with the estimation error is neglected).
  const Vector u = last_control_.value_or(Vector::Zero(input_dim_));
  const double nu = input_arrival_rate_;
  const Vector held = on_loss_ == OnLoss::hold ? applied_mean_ : Vector(Vector::Zero(input_dim_));
  const Matrix held_second = on_loss_ == OnLoss::hold ? applied_second_moment_ : Matrix(Matrix::Zero(input_dim_, input_dim_));
  const Vector mean = nu * u + (1.0 - nu) * held;
  const Matrix second = nu * u * u.transpose() + (1.0 - nu) * held_second;
  Matrix covariance = second - mean * mean.transpose();
  covariance = 0.5 * (covariance + covariance.transpose());
  applied_mean_ = mean;
  applied_second_moment_ = second;
  filter_.predict(mean, covariance);
  return {mean, covariance};
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

PeriodEstimate EstimatorCore::step(std::uint64_t k, double t, const std::map<int, SensorSample>& samples,
                                   std::int64_t last_stamp_ns, std::int64_t now_ns) {
  std::vector<SensorSample> batch;
  batch.reserve(samples.size());
  for (const auto& [id, s] : samples) batch.push_back(s);
  PeriodEstimate e;
  e.trace_P_pred = filter_.P().trace();  // Tr P_{k|k-1}, before the fused update
  const FusedUpdateResult result = filter_.update(batch);
  // Samples were checked on arrival (filter_.check): only a filter's own verdict can remain.
  for (const auto& [id, reason] : result.rejected) reject(reason);
  e.k = k;
  e.t = t;
  e.x_hat = filter_.x();
  e.P = filter_.P();
  e.fused = result.fused_ids;
  e.late_total = late_total_;
  e.rejected_total = rejected_total();
  e.state = filter_.state();
  e.fused_at_ns = now_ns;
  e.restarts = restarts_;
  e.last_sample_stamp_ns = last_stamp_ns;
  return e;
}

PeriodEstimate EstimatorCore::fuse(std::int64_t now_ns) {
  // The prior is kept for a re-run only (late fusion, D > 0): with D = 0 nothing reads it.
  const bool keep_prior = max_delay_periods_ > 0;
  Vector x_prior = keep_prior ? filter_.x() : Vector();
  Matrix P_prior = keep_prior ? filter_.P() : Matrix();
  PeriodEstimate e = step(open_->k, open_->t, open_->samples, open_->last_stamp_ns, now_ns);
  // One list is the count and the ids: `late` can never disagree with `late_sensors`.
  e.late_sensors = std::move(late_since_publish_);
  late_since_publish_.clear();
  e.late_periods = std::move(late_periods_since_publish_);
  late_periods_since_publish_.clear();
  e.late = static_cast<std::uint32_t>(e.late_sensors.size());
  if (gain_) {
    // LQG certainty equivalence: u_k = -L x̂_{k|k}.
    e.control = Vector(-(*gain_) * filter_.x());
    last_control_ = e.control;
  } else if (input_dim_ > 0) {
    last_control_ = Vector::Zero(input_dim_);
  }
  last_fused_ = open_->k;
  if (keep_prior) remember(e, std::move(x_prior), std::move(P_prior));
  open_.reset();
  return e;
}

void EstimatorCore::remember(const PeriodEstimate& e, Vector x_prior, Matrix P_prior) {
  FusedPeriod f;
  f.k = e.k;
  f.t = e.t;
  f.x_prior = std::move(x_prior);
  f.P_prior = std::move(P_prior);
  // Only the samples the update fused: a rejected one must not be fused by a re-run either.
  for (const int id : e.fused) f.samples.emplace(id, open_->samples.at(id));
  f.last_stamp_ns = open_->last_stamp_ns;
  f.deadline_ns = open_->deadline_ns;
  history_.push_back(std::move(f));
  // The ring: the oldest period a sample can still be fused into is last fused - D (until the
  // last fused period's deadline, see keep_late), so D + 1 fused periods.
  while (history_.size() > static_cast<std::size_t>(max_delay_periods_) + 1) history_.pop_front();
}

bool EstimatorCore::keep_late(int sensor_id, std::uint64_t k, const Vector& y, std::int64_t stamp_ns,
                              std::int64_t now_ns) {
  if (max_delay_periods_ == 0 || history_.empty() || k < history_.front().k || k > history_.back().k) return false;
  // k's window closes when period k + D is fused, or at k + D's deadline if it was fused before.
  const std::uint64_t closing = k + static_cast<std::uint64_t>(max_delay_periods_);
  if (closing <= history_.back().k && now_ns >= history_[static_cast<std::size_t>(closing - history_.front().k)].deadline_ns)
    return false;
  FusedPeriod& f = history_[static_cast<std::size_t>(k - history_.front().k)];  // consecutive periods
  if (!f.samples.emplace(sensor_id, SensorSample{sensor_id, y}).second) {
    reject(SampleRejection::duplicate);
    return true;
  }
  f.last_stamp_ns = std::max(f.last_stamp_ns, stamp_ns);
  ++late_fused_total_;
  rerun_from_ = std::min(rerun_from_.value_or(k), k);
  return true;
}

void EstimatorCore::flush_revisions(std::vector<PeriodEstimate>& out, std::int64_t now_ns) {
  if (!rerun_from_) return;
  std::vector<PeriodEstimate> revised = revise(now_ns);
  out.insert(out.end(), std::make_move_iterator(revised.begin()), std::make_move_iterator(revised.end()));
}

std::vector<PeriodEstimate> EstimatorCore::revise(std::int64_t now_ns) {
  std::vector<PeriodEstimate> out;
  if (!rerun_from_) return out;
  const std::uint64_t from = *rerun_from_;
  rerun_from_.reset();
  if (history_.empty() || from < history_.front().k) return out;  // cannot happen: the ring only drops after a flush
  // Re-run from the prior of period `from`: the same recursion as the in-time one (fuse, then
  // predict with the applied input), with the samples that have arrived since.
  auto i = static_cast<std::size_t>(from - history_.front().k);
  filter_.restore(history_[i].x_prior, history_[i].P_prior);
  out.reserve(history_.size() - i);
  for (; i < history_.size(); ++i) {
    FusedPeriod& f = history_[i];
    f.x_prior = filter_.x();
    f.P_prior = filter_.P();
    PeriodEstimate e = step(f.k, f.t, f.samples, f.last_stamp_ns, now_ns);
    e.revision = ++f.revision;
    out.push_back(std::move(e));
    // Into the next period (fused, or the open one): with the input the plant applied.
    if (f.input_after && f.input_covariance_after) filter_.predict(*f.input_after, *f.input_covariance_after);
    else if (f.input_after) filter_.predict(f.input_after->size() > 0 ? &*f.input_after : nullptr);
  }
  return out;
}

std::vector<PeriodEstimate> EstimatorCore::on_tick(std::uint64_t k, const Vector& applied_input, std::int64_t now_ns) {
  std::vector<PeriodEstimate> out;
  if (resumed_after_ && k <= *resumed_after_) return out;  // the tick history of a restart: already fused
  if ((last_fused_ && k <= *last_fused_) || (open_ && k <= open_->k)) {
    reject(SampleRejection::stale_tick);  // duplicate or reordered tick
    return out;
  }
  flush_revisions(out, now_ns);
  // A later tick closes the open period even before its deadline.
  if (open_) out.push_back(fuse(now_ns));
  if (last_fused_) {
    // Ticks k' in (last fused, k) never arrived: fuse those periods with whatever was
    // buffered for them, predicting with the input we sent (assumed applied).
    const std::uint64_t first_missing = *last_fused_ + 1;
    for (std::uint64_t j = first_missing; j < k; ++j) {
      predict_next(last_control_.value_or(Vector()));
      open(j, now_ns);
      PeriodEstimate e = fuse(now_ns);
      e.skipped_tick = true;
      e.control.reset();  // the plant has moved past period j: nothing to send
      out.push_back(std::move(e));
    }
    // Unacknowledged: what the tick says was applied is not used (the plant would not say).
    predict_next(applied_input);
  }
  // else: the first tick seen; the prior x0, P0 stands for this period.
  open(k, now_ns);
  if (complete()) out.push_back(fuse(now_ns));
  return out;
}

std::vector<PeriodEstimate> EstimatorCore::on_sample(int sensor_id, std::uint64_t k, const Vector& y,
                                                     std::int64_t stamp_ns, std::int64_t now_ns) {
  std::vector<PeriodEstimate> out;
  if (const auto reason = filter_.check(sensor_id, y)) {
    reject(*reason);
    return out;
  }
  // A sample for a fused period (or one before the first tick seen) is late: lost, unless
  // fuse_within keeps it for a re-run.
  if ((last_fused_ && k <= *last_fused_) || (open_ && k < open_->k)) {
    if (!keep_late(sensor_id, k, y, stamp_ns, now_ns)) count_late(sensor_id, k);
    return out;
  }
  if (open_ && k == open_->k) {
    if (!open_->samples.emplace(sensor_id, SensorSample{sensor_id, y}).second) {
      reject(SampleRejection::duplicate);
      return out;
    }
    open_->last_stamp_ns = std::max(open_->last_stamp_ns, stamp_ns);
    if (complete()) {
      flush_revisions(out, now_ns);
      out.push_back(fuse(now_ns));
    }
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
  if (open_ && now_ns >= open_->deadline_ns) {
    flush_revisions(out, now_ns);
    out.push_back(fuse(now_ns));
  }
  return out;
}

}  // namespace netkf::nodes
