// Wire <-> core conversions (the only place they happen). Validation first: a sample
// from the network is untrusted input.
#include "netkf/dds/conversions.hpp"

#include "netkf/links/link_delay.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_text.hpp"
#include "netkf/relay/relay_links.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <stdexcept>
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

std::vector<wire::MeasurementBatch> make_measurement_batches(std::vector<wire::Measurement> samples) {
  std::vector<wire::MeasurementBatch> batches;
  for (std::size_t first = 0; first < samples.size(); first += kMaxBatchSamples) {
    const std::size_t end = std::min(samples.size(), first + kMaxBatchSamples);
    wire::MeasurementBatch batch;
    batch.samples().assign(std::make_move_iterator(samples.begin() + static_cast<std::ptrdiff_t>(first)),
                           std::make_move_iterator(samples.begin() + static_cast<std::ptrdiff_t>(end)));
    batches.push_back(std::move(batch));
  }
  return batches;
}

SensorSample to_sensor_sample(const wire::Measurement& m, int expected_size) {
  SensorSample s;
  s.sensor_id = m.sensor_id();
  s.y = to_vector(m.y(), expected_size, "measurement y");
  return s;
}

wire::Truth make_truth(std::uint64_t k, double t, const Vector& x, const Vector& applied_input, bool input_arrived) {
  wire::Truth w;
  w.k(k);
  w.t(t);
  w.x(to_wire(x));
  w.applied_input(to_wire(applied_input));
  w.input_arrived(input_arrived);
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

Truth from_wire(const wire::Truth& w) {
  if (!all_finite(w.x()) || !all_finite(w.applied_input())) throw ConversionError("truth with a non-finite value");
  return Truth{static_cast<std::int64_t>(w.k()), w.t(), w.x(), w.applied_input(), w.input_arrived()};
}

DeliveredMeasurement delivered_of(const wire::Measurement& w) {
  if (!all_finite(w.y())) throw ConversionError("measurement with a non-finite value");
  return DeliveredMeasurement{w.sensor_id(), static_cast<std::int64_t>(w.k()),
                              static_cast<double>(w.stamp_ns()) * 1e-9, w.y()};
}

FilterState filter_state_from_string(const std::string& s) {
  if (s == "ok") return FilterState::ok;
  if (s == "diverging") return FilterState::diverging;
  throw ConversionError("unknown filter state '" + s + "'");
}

wire::Estimate to_wire(const Estimate& e) {
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
  if (e.late_periods.size() != e.late_sensors.size())
    throw ConversionError("estimate: " + std::to_string(e.late_periods.size()) + " late_periods for " +
                          std::to_string(e.late_sensors.size()) + " late_sensors");
  w.late(e.late);
  w.late_sensors(std::vector<int32_t>(e.late_sensors.begin(), e.late_sensors.end()));
  w.late_periods(std::vector<uint64_t>(e.late_periods.begin(), e.late_periods.end()));
  w.late_total(e.late_total);
  w.rejected_total(e.rejected_total);
  w.state(to_string(e.state));
  w.trace_P(e.P.trace());
  if (!std::isfinite(e.trace_P_pred)) throw ConversionError("estimate: non-finite Tr P_{k|k-1}");
  w.trace_P_pred(e.trace_P_pred);
  w.fused_at_ns(e.fused_at_ns);
  w.stamp_ns(e.stamp_ns);
  w.last_sample_stamp_ns(e.last_sample_stamp_ns);
  w.restarts(e.restarts);
  w.revision(e.revision);
  return w;
}

Estimate from_wire(const wire::Estimate& e, int state_dim) {
  Estimate r;
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
  if (e.late_periods().size() != e.late_sensors().size())
    throw ConversionError("estimate: " + std::to_string(e.late_periods().size()) + " late_periods for " +
                          std::to_string(e.late_sensors().size()) + " late_sensors");
  r.late = e.late();
  r.late_sensors.assign(e.late_sensors().begin(), e.late_sensors().end());
  r.late_periods.assign(e.late_periods().begin(), e.late_periods().end());
  r.late_total = e.late_total();
  r.rejected_total = e.rejected_total();
  r.state = filter_state_from_string(e.state());
  r.fused_at_ns = e.fused_at_ns();
  r.stamp_ns = e.stamp_ns();
  r.last_sample_stamp_ns = e.last_sample_stamp_ns();
  r.restarts = e.restarts();
  r.revision = e.revision();
  return r;
}

namespace {
// The loss models' parameters on the wire, by their names in link_parameters() and the link
// keys: the one place the wire knows them. A model's parameter needs its field here (and in
// idl/netkf.idl); the other models' fields stay 0.
struct WireParameter {
  const char* name;
  void (*set)(wire::LinkSpec&, double);
  double (*get)(const wire::LinkSpec&);
};
constexpr WireParameter kWireParameters[] = {
    {"loss", [](wire::LinkSpec& w, double v) { w.loss(v); }, [](const wire::LinkSpec& w) { return w.loss(); }},
    {"p", [](wire::LinkSpec& w, double v) { w.p(v); }, [](const wire::LinkSpec& w) { return w.p(); }},
    {"r", [](wire::LinkSpec& w, double v) { w.r(v); }, [](const wire::LinkSpec& w) { return w.r(); }},
    {"loss_good", [](wire::LinkSpec& w, double v) { w.loss_good(v); },
     [](const wire::LinkSpec& w) { return w.loss_good(); }},
    {"loss_bad", [](wire::LinkSpec& w, double v) { w.loss_bad(v); },
     [](const wire::LinkSpec& w) { return w.loss_bad(); }},
};

const WireParameter& wire_parameter(const std::string& name) {
  for (const auto& field : kWireParameters)
    if (name == field.name) return field;
  throw std::logic_error("link parameter '" + name + "' has no field in the wire's LinkSpec (idl/netkf.idl)");
}
}  // namespace

wire::LinkSpec to_wire(const LinkSpec& link) {
  wire::LinkSpec w;
  w.model(link_kind(link));
  if (link.trace) {
    w.trace(link.trace->path);
    w.loop(link.trace->loop);
    w.offset(link.trace->offset);
  }
  for (const auto& [name, value] : link_parameters(link.loss)) wire_parameter(name).set(w, value);
  if (link.trace && iid_arrival_rate(link.loss)) {
    // A trace's empirical model is a chain on the wire, whatever its form: i.i.d. drops with
    // loss q are the chain p = q, r = 1 − q.
    const double q = stationary_loss(link.loss);
    w.p(q);
    w.r(1.0 - q);
    w.loss_good(0.0);
    w.loss_bad(1.0);
  }
  w.delay_ms(link.delay.delay_ms);
  w.jitter_ms(link.delay.jitter_ms);
  w.delay_distribution(delay_distribution_name(link.delay.distribution));
  return w;
}

namespace {
// A trace link as the wire describes it: its file's path (not read here: a status or journal
// entry describes a link, the channel alone replays it) and its empirical model.
LinkSpec trace_link_from_wire(const wire::LinkSpec& w) {
  constexpr std::size_t kMaxTracePath = 4096;
  if (w.trace().empty() || w.trace().size() > kMaxTracePath)
    throw ConversionError("link: a trace link needs its trace path (1 to 4096 characters), got " +
                          std::to_string(w.trace().size()) + " characters");
  LinkSpec link;
  link.trace = TraceLink{w.trace(), w.loop(), w.offset(), nullptr};
  link.loss = GilbertElliottLink{w.p(), w.r(), w.loss_good(), w.loss_bad()};
  link.delay.delay_ms = w.delay_ms();
  link.delay.jitter_ms = w.jitter_ms();
  try {
    link.delay.distribution = parse_delay_distribution(w.delay_distribution());
    validate_link(link);
  } catch (const LinkError& e) {
    throw ConversionError(std::string("link: ") + e.what());
  }
  return link;
}
}  // namespace

LinkSpec from_wire(const wire::LinkSpec& w) {
  if (w.model() == "trace") return trace_link_from_wire(w);
  // Through the link's keys: the same names, checks and messages as a file or `ctl`.
  LinkKeys keys{{"model", w.model()}};
  // The named model's parameters (none for an unknown name, which the keys then refuse).
  if (const auto model = link_model_named(w.model()))
    for (const auto& parameter : link_parameters(*model))
      keys.push_back({parameter.first, wire_parameter(parameter.first).get(w)});
  keys.push_back({"delay_ms", w.delay_ms()});
  keys.push_back({"jitter_ms", w.jitter_ms()});
  keys.push_back({"delay_distribution", w.delay_distribution()});
  try {
    return link_from_keys(keys);
  } catch (const LinkError& e) {
    throw ConversionError(std::string("link: ") + e.what());
  }
}

wire::LinkControl make_link_control(std::uint64_t request_id, int sensor_id, const LinkKeys& keys) {
  wire::LinkControl c;
  c.request_id(request_id);
  c.sensor_id(sensor_id);
  std::vector<wire::LinkKey> out;
  for (const auto& k : keys) {
    wire::LinkKey w;
    w.name(k.name);
    if (const auto* word = std::get_if<std::string>(&k.value)) {
      w.word(*word);
    } else {
      w.number(std::get<double>(k.value));
    }
    out.push_back(std::move(w));
  }
  c.keys(std::move(out));
  return c;
}

LinkKeys link_keys_of(const wire::LinkControl& control) {
  LinkKeys keys;
  for (const auto& w : control.keys()) {
    // The key's own kind decides which field counts: a word key with an empty word is
    // reported as such by the link's validation, never read as the number 0.
    if (link_key_is_word(w.name()) || w.name() == kRelayTopicKey) {
      keys.push_back({w.name(), w.word()});
    } else {
      keys.push_back({w.name(), w.number()});
    }
  }
  return keys;
}

wire::LinkStatus to_wire(const LinkStatus& f, std::int64_t stamp_ns) {
  wire::LinkStatus s;
  s.sensor_id(f.sensor_id);
  s.link(to_wire(f.link));
  s.stationary_loss(stationary_loss(f.link.loss));
  s.theory_mean_burst(mean_burst_length(f.link.loss));
  s.in_time(f.in_time);
  s.samples_in(f.samples_in);
  s.delivered(f.delivered);
  s.dropped(f.dropped);
  s.observed_loss(f.observed_loss);
  s.mean_burst_length(f.mean_burst_length);
  s.samples_total(f.samples_total);
  s.delivered_total(f.delivered_total);
  s.dropped_total(f.dropped_total);
  s.last_request_id(f.last_request_id);
  s.last_request_rejected(!f.rejection_reason.empty());
  s.reject_reason(f.rejection_reason);
  s.held(f.held);
  s.past_deadline(f.past_deadline);
  if (f.recent_fit) {
    const fit::RecentLossFit& fit = *f.recent_fit;
    s.fit_samples(fit.samples);
    s.fit_dropped(fit.dropped);
    s.fit_family(fit::to_string(fit.family));
    // As a simple Gilbert chain (the recent fit's link is bernoulli or one): a Bernoulli loss q
    // is the chain p = q, r = 1 − q.
    if (iid_arrival_rate(fit.link)) {
      const double q = stationary_loss(fit.link);
      s.fit_p(q);
      s.fit_r(1.0 - q);
    } else {
      for (const auto& [name, value] : link_parameters(fit.link)) {
        if (name == "p") s.fit_p(value);
        if (name == "r") s.fit_r(value);
      }
    }
    s.fit_has_chain(fit.aic_gain.has_value());
    s.fit_aic_gain(fit.aic_gain.value_or(0.0));
  }
  s.stamp_ns(stamp_ns);
  s.topic(f.topic);
  return s;
}

LinkStatus from_wire(const wire::LinkStatus& w) {
  LinkStatus r;
  r.sensor_id = w.sensor_id();
  r.link = link_of(w);  // validated
  r.samples_in = w.samples_in();
  r.delivered = w.delivered();
  r.dropped = w.dropped();
  r.observed_loss = w.observed_loss();
  r.mean_burst_length = w.mean_burst_length();
  r.samples_total = w.samples_total();
  r.delivered_total = w.delivered_total();
  r.dropped_total = w.dropped_total();
  r.last_request_id = w.last_request_id();
  r.rejection_reason = w.last_request_rejected() ? w.reject_reason() : std::string();
  r.in_time = std::isfinite(w.in_time()) ? std::clamp(w.in_time(), 0.0, 1.0) : 1.0;
  r.held = w.held();
  r.past_deadline = w.past_deadline();
  r.recent_fit = recent_fit_of(w);
  r.topic = relayed_topic_of(w.sensor_id(), w.topic());
  return r;
}

std::optional<fit::RecentLossFit> recent_fit_of(const wire::LinkStatus& s) {
  if (s.fit_family().empty() && s.fit_samples() == 0) return std::nullopt;
  const auto family = fit::parse_loss_family(s.fit_family());
  const auto probability = [](double v) { return std::isfinite(v) && v >= 0.0 && v <= 1.0; };
  if (!family || (*family != fit::LossFamily::bernoulli && *family != fit::LossFamily::simple_gilbert))
    throw ConversionError("link status: unknown fit_family '" + s.fit_family() + "'");
  if (s.fit_samples() == 0 || s.fit_dropped() > s.fit_samples() || !probability(s.fit_p()) ||
      !probability(s.fit_r()) || !std::isfinite(s.fit_aic_gain()))
    throw ConversionError("link status: malformed recent-samples fit");
  fit::RecentLossFit fit;
  fit.samples = s.fit_samples();
  fit.dropped = s.fit_dropped();
  fit.family = *family;
  if (*family == fit::LossFamily::simple_gilbert)
    fit.link = GilbertElliottLink{s.fit_p(), s.fit_r(), 0.0, 1.0};
  else
    fit.link = BernoulliLink{s.fit_p()};
  if (s.fit_has_chain()) fit.aic_gain = s.fit_aic_gain();
  return fit;
}

wire::LinkControlReply to_wire(const LinkReply& reply) {
  wire::LinkControlReply r;
  r.request_id(reply.request_id);
  r.sensor_id(reply.sensor_id);
  r.applied(reply.applied);
  r.reason(reply.reason);
  return r;
}

LinkReply from_wire(const wire::LinkControlReply& w) { return LinkReply{w.request_id(), w.sensor_id(), w.applied(), w.reason()}; }

LinkSpec link_of(const wire::LinkStatus& status) { return from_wire(status.link()); }

std::string relayed_topic_of(int sensor_id, const std::string& topic) {
  if (topic.empty() ? is_relay_topic_link_id(sensor_id) : sensor_id != relay_topic_link_id(topic))
    throw ConversionError("link " + std::to_string(sensor_id) + " does not name relayed topic '" + topic + "'");
  return topic;
}

wire::LinkChange to_wire(const LinkChange& change, std::int64_t stamp_ns) {
  wire::LinkChange c;
  c.sensor_id(change.sensor_id);
  c.at_period(static_cast<std::uint64_t>(std::max<std::int64_t>(change.at_period, 0)));
  c.origin(to_string(change.origin));
  c.request_id(change.request_id);
  c.link(to_wire(change.link));
  c.stamp_ns(stamp_ns);
  c.topic(change.topic);
  return c;
}

LinkChange from_wire(const wire::LinkChange& w) {
  LinkChange r;
  r.sensor_id = w.sensor_id();
  r.at_period = static_cast<std::int64_t>(w.at_period());
  const auto origin = parse_link_change_origin(w.origin());
  if (!origin) throw ConversionError("link change: unknown origin '" + w.origin() + "'");
  r.origin = *origin;
  r.request_id = w.request_id();
  r.link = from_wire(w.link());
  r.topic = relayed_topic_of(w.sensor_id(), w.topic());
  return r;
}

}  // namespace netkf::dds
