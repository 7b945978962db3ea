// Wire <-> core conversions (the only place they happen). Validation first: a sample
// from the network is untrusted input.
#include "netkf/dds/conversions.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

namespace netkf::dds {

std::int64_t steady_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

bool all_finite(const std::vector<double>& values) {
  return std::all_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); });
}

Vector to_vector(const std::vector<double>& values, int expected_size, const char* what) {
  if (expected_size >= 0 && values.size() != static_cast<std::size_t>(expected_size)) {
    throw ConversionError(std::string(what) + ": expected " + std::to_string(expected_size) + " values, got " +
                          std::to_string(values.size()));
  }
  if (!all_finite(values)) throw ConversionError(std::string(what) + ": non-finite value");
  Vector v(static_cast<Eigen::Index>(values.size()));
  for (std::size_t i = 0; i < values.size(); ++i) v(static_cast<Eigen::Index>(i)) = values[i];
  return v;
}

std::vector<double> to_wire(const Vector& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

Matrix to_matrix(const std::vector<double>& row_major, int rows, int cols, const char* what) {
  if (rows < 0 || cols < 0 || row_major.size() != static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols)) {
    throw ConversionError(std::string(what) + ": expected " + std::to_string(rows) + "x" + std::to_string(cols) +
                          " values, got " + std::to_string(row_major.size()));
  }
  if (!all_finite(row_major)) throw ConversionError(std::string(what) + ": non-finite value");
  Matrix m(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) m(r, c) = row_major[static_cast<std::size_t>(r) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(c)];
  return m;
}

std::vector<double> to_wire_row_major(const Matrix& m) {
  std::vector<double> out;
  out.reserve(static_cast<std::size_t>(m.size()));
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) out.push_back(m(r, c));
  return out;
}

wire::Measurement make_measurement(int sensor_id, std::uint64_t k, std::int64_t stamp_ns, const Vector& y) {
  wire::Measurement m;
  m.sensor_id(sensor_id);
  m.k(k);
  m.stamp_ns(stamp_ns);
  m.y(to_wire(y));
  return m;
}

SensorSample to_sensor_sample(const wire::Measurement& m, int expected_size) {
  SensorSample s;
  s.sensor_id = m.sensor_id();
  s.y = to_vector(m.y(), expected_size, "measurement y");
  return s;
}

wire::Truth make_truth(std::uint64_t k, double t, const Vector& x, const Vector& applied_input) {
  wire::Truth w;
  w.k(k);
  w.t(t);
  w.x(to_wire(x));
  w.applied_input(to_wire(applied_input));
  return w;
}

wire::Tick make_tick(std::uint64_t k, double t, const Vector& applied_input, bool final_tick) {
  wire::Tick w;
  w.k(k);
  w.t(t);
  w.applied_input(to_wire(applied_input));
  w.final_tick(final_tick);
  return w;
}

Vector truth_state(const wire::Truth& truth, int state_dim) { return to_vector(truth.x(), state_dim, "truth x"); }

Vector tick_applied_input(const wire::Tick& tick, int input_dim) {
  if (tick.applied_input().empty()) return Vector();
  return to_vector(tick.applied_input(), input_dim, "tick applied_input");
}

wire::ControlInput make_control_input(std::uint64_t k, const Vector& u) {
  wire::ControlInput c;
  c.k(k);
  c.u(to_wire(u));
  return c;
}

Vector control_input_u(const wire::ControlInput& c, int input_dim) { return to_vector(c.u(), input_dim, "control u"); }

FilterState filter_state_from_string(const std::string& s) {
  if (s == "ok") return FilterState::ok;
  if (s == "diverging") return FilterState::diverging;
  throw ConversionError("unknown filter state '" + s + "'");
}

wire::Estimate to_wire(const EstimateRecord& e) {
  const auto n = e.x_hat.size();
  if (e.P.rows() != n || e.P.cols() != n) throw ConversionError("estimate: P is not n x n for n = size of x_hat");
  if (!e.x_hat.allFinite()) throw ConversionError("estimate: non-finite x_hat");
  if (!e.P.allFinite()) throw ConversionError("estimate: non-finite P");
  wire::Estimate w;
  w.k(e.k);
  w.t(e.t);
  w.x_hat(to_wire(e.x_hat));
  w.P(to_wire_row_major(e.P));
  w.fused(std::vector<int32_t>(e.fused.begin(), e.fused.end()));
  if (e.late != e.late_sensors.size())
    throw ConversionError("estimate: late (" + std::to_string(e.late) + ") is not the number of late_sensors (" +
                          std::to_string(e.late_sensors.size()) + ")");
  w.late(e.late);
  w.late_sensors(std::vector<int32_t>(e.late_sensors.begin(), e.late_sensors.end()));
  w.late_total(e.late_total);
  w.rejected_total(e.rejected_total);
  w.state(to_string(e.state));
  w.trace_P(e.P.trace());
  if (!std::isfinite(e.trace_P_pred)) throw ConversionError("estimate: non-finite Tr P_{k|k-1}");
  w.trace_P_pred(e.trace_P_pred);
  w.fused_at_ns(e.fused_at_ns);
  w.stamp_ns(e.stamp_ns);
  w.last_sample_stamp_ns(e.last_sample_stamp_ns);
  return w;
}

EstimateRecord from_wire(const wire::Estimate& e, int state_dim) {
  EstimateRecord r;
  r.k = e.k();
  r.t = e.t();
  r.x_hat = to_vector(e.x_hat(), state_dim, "estimate x_hat");
  const int n = static_cast<int>(r.x_hat.size());
  r.P = to_matrix(e.P(), n, n, "estimate P");
  if (!std::isfinite(e.trace_P_pred())) throw ConversionError("estimate: non-finite trace_P_pred");
  r.trace_P_pred = e.trace_P_pred();
  r.fused.assign(e.fused().begin(), e.fused().end());
  // One entry per late sample: a count that disagrees with its list is a broken sender.
  if (e.late() != e.late_sensors().size())
    throw ConversionError("estimate: late (" + std::to_string(e.late()) + ") is not the number of late_sensors (" +
                          std::to_string(e.late_sensors().size()) + ")");
  r.late = e.late();
  r.late_sensors.assign(e.late_sensors().begin(), e.late_sensors().end());
  r.late_total = e.late_total();
  r.rejected_total = e.rejected_total();
  r.state = filter_state_from_string(e.state());
  r.fused_at_ns = e.fused_at_ns();
  r.stamp_ns = e.stamp_ns();
  r.last_sample_stamp_ns = e.last_sample_stamp_ns();
  return r;
}

wire::LinkControl make_link_control(std::uint64_t request_id, int sensor_id, const LinkModel& model) {
  wire::LinkControl c;
  c.request_id(request_id);
  c.sensor_id(sensor_id);
  c.model(link_model_name(model));
  if (const auto* b = std::get_if<BernoulliLink>(&model)) {
    c.loss(b->loss);
  } else {
    const auto& g = std::get<GilbertElliottLink>(model);
    c.p(g.p);
    c.r(g.r);
    c.loss_good(g.loss_good);
    c.loss_bad(g.loss_bad);
  }
  return c;
}

namespace {
void check_probability(double v, const char* name) {
  if (!std::isfinite(v) || v < 0.0 || v > 1.0) {
    throw ConversionError(std::string(name) + " must be a probability in [0,1], got " + std::to_string(v));
  }
}
}  // namespace

LinkModel to_link_model(const wire::LinkControl& c) {
  if (c.model() == "bernoulli") {
    check_probability(c.loss(), "loss");
    return BernoulliLink{c.loss()};
  }
  if (c.model() == "gilbert_elliott") {
    check_probability(c.p(), "p");
    check_probability(c.r(), "r");
    check_probability(c.loss_good(), "loss_good");
    check_probability(c.loss_bad(), "loss_bad");
    return GilbertElliottLink{c.p(), c.r(), c.loss_good(), c.loss_bad()};
  }
  throw ConversionError("unknown link model '" + c.model() + "' (expected bernoulli or gilbert_elliott)");
}

void set_link_model(wire::LinkStatus& status, const LinkModel& model) {
  status.model(link_model_name(model));
  status.loss(0.0);
  status.p(0.0);
  status.r(0.0);
  status.loss_good(0.0);
  status.loss_bad(0.0);
  if (const auto* b = std::get_if<BernoulliLink>(&model)) {
    status.loss(b->loss);
  } else {
    const auto& g = std::get<GilbertElliottLink>(model);
    status.p(g.p);
    status.r(g.r);
    status.loss_good(g.loss_good);
    status.loss_bad(g.loss_bad);
  }
  status.stationary_loss(stationary_loss(model));
}

wire::LinkStatus make_link_status(int sensor_id, const LinkModel& model, const LinkStatistics& stats,
                                  const LinkStatistics& lifetime, std::uint64_t last_request_id, bool last_request_rejected,
                                  const std::string& reject_reason, std::int64_t stamp_ns) {
  wire::LinkStatus s;
  s.sensor_id(sensor_id);
  set_link_model(s, model);
  s.samples_in(stats.samples());
  s.delivered(stats.delivered());
  s.dropped(stats.dropped());
  s.observed_loss(stats.observed_loss());
  s.mean_burst_length(stats.mean_burst_length());
  s.samples_total(lifetime.samples());
  s.delivered_total(lifetime.delivered());
  s.dropped_total(lifetime.dropped());
  s.last_request_id(last_request_id);
  s.last_request_rejected(last_request_rejected);
  s.reject_reason(reject_reason);
  s.stamp_ns(stamp_ns);
  return s;
}

wire::LinkControlReply make_link_control_reply(std::uint64_t request_id, int sensor_id, bool applied,
                                               const std::string& reason) {
  wire::LinkControlReply r;
  r.request_id(request_id);
  r.sensor_id(sensor_id);
  r.applied(applied);
  r.reason(reason);
  return r;
}

LinkModel link_model_of(const wire::LinkStatus& status) {
  if (status.model() == "bernoulli") return BernoulliLink{status.loss()};
  if (status.model() == "gilbert_elliott")
    return GilbertElliottLink{status.p(), status.r(), status.loss_good(), status.loss_bad()};
  throw ConversionError("unknown link model '" + status.model() + "'");
}

}  // namespace netkf::dds
