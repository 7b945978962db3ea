#include "netkf/cli/live/live_metrics.hpp"

#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>

#include <cmath>
#include <sstream>

#include "netkf/cli/live/observed_rate.hpp"
#include "netkf/links/link_statistics.hpp"

namespace netkf::cli {

namespace {
// The window label's value: "last_1000_samples".
std::string window_label() { return "last_" + std::to_string(kWindowSamples) + "_samples"; }
}  // namespace

LiveMetrics::LiveMetrics(Scope scope) : registry_(std::make_shared<prometheus::Registry>()) {
  using namespace prometheus;
  auto& r = *registry_;
  register_link_metrics();
  if (scope == Scope::links) return;
  restarts_ = &BuildCounter()
                   .Name("netkf_process_restarts_total")
                   .Help("Restarts of a node process by the launch's supervisor")
                   .Register(r);
  period_ = &BuildGauge().Name("netkf_estimator_period").Help("Newest period k fused by the estimator").Register(r).Add({});
  trace_P_ = &BuildGauge()
                  .Name("netkf_estimator_trace_p")
                  .Help("Tr P_{k|k} of the newest estimate")
                  .Register(r)
                  .Add({});
  diverging_ = &BuildGauge()
                    .Name("netkf_estimator_diverging")
                    .Help("1 while the estimator's filter state is 'diverging', else 0")
                    .Register(r)
                    .Add({});
  fused_sensors_ = &BuildGauge()
                        .Name("netkf_estimator_fused_sensors")
                        .Help("Sensors fused in the newest period")
                        .Register(r)
                        .Add({});
  late_ = &BuildCounter()
               .Name("netkf_samples_late_total")
               .Help("Samples that arrived after their period was fused (counted, never fused)")
               .Register(r)
               .Add({});
  rejected_ = &BuildCounter()
                   .Name("netkf_samples_rejected_total")
                   .Help("Samples the estimator rejected (unknown id, wrong size, NaN, duplicate)")
                   .Register(r)
                   .Add({});
  // 50 µs .. ~100 ms: the measured pipeline runs from a few hundred µs to a few ms.
  latency_ = &BuildHistogram()
                  .Name("netkf_pipeline_latency_seconds")
                  .Help("Sample publish to estimate publish (newest sample fused in the period)")
                  .Register(r)
                  .Add({}, Histogram::BucketBoundaries{5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2, 1e-1});
}

// Per link (label link="ID"): the channel's counts, the link's configuration, the observed rates.
void LiveMetrics::register_link_metrics() {
  using namespace prometheus;
  auto& r = *registry_;
  link_samples_ = &BuildCounter()
                       .Name("netkf_link_samples_total")
                       .Help("Samples that entered the link's channel emulator")
                       .Register(r);
  link_delivered_ = &BuildCounter()
                         .Name("netkf_link_delivered_total")
                         .Help("Samples the link delivered to the estimator")
                         .Register(r);
  link_dropped_ =
      &BuildCounter().Name("netkf_link_dropped_total").Help("Samples the link dropped").Register(r);
  link_late_ = &BuildCounter()
                    .Name("netkf_link_late_total")
                    .Help("Samples the link delivered after the estimator had fused their period")
                    .Register(r);
  link_configured_loss_ = &BuildGauge()
                               .Name("netkf_link_configured_loss")
                               .Help("Stationary loss probability of the link's current model")
                               .Register(r);
  link_delay_ = &BuildGauge()
                     .Name("netkf_link_delay_seconds")
                     .Help("Base delay of the link's current configuration")
                     .Register(r);
  link_jitter_ = &BuildGauge()
                      .Name("netkf_link_jitter_seconds")
                      .Help("Delay spread of the link's current configuration (half-width, sd or scale)")
                      .Register(r);
  link_in_time_ = &BuildGauge()
                       .Name("netkf_link_in_time_probability")
                       .Help("P(delay <= the estimator's deadline) of the link's current configuration")
                       .Register(r);
  link_held_ = &BuildGauge()
                    .Name("netkf_link_held_samples")
                    .Help("Delivered samples the channel is holding for their delay")
                    .Register(r);
  link_observed_loss_ = &BuildGauge()
                             .Name("netkf_link_observed_loss")
                             .Help("Fraction of samples dropped since the link's model was set")
                             .Register(r);
  // One name, the window as a label: both are the same ratio (observed_rate.hpp).
  const std::string window = window_label();
  link_observed_rate_ = &BuildGauge()
                             .Name("netkf_link_observed_arrival_rate")
                             .Help("Samples delivered within the estimator's deadline per sample that entered the "
                                   "link; window=since_change: since the link's model was set; window=" + window +
                                   ": over the latest reports holding at least " + std::to_string(kWindowSamples) +
                                   " samples since then (span: netkf_link_observed_window_samples)")
                             .Register(r);
  link_window_samples_ = &BuildGauge()
                              .Name("netkf_link_observed_window_samples")
                              .Help("Samples the window of netkf_link_observed_arrival_rate{window=\"" + window +
                                    "\"} spans")
                              .Register(r);
}

LiveMetrics::~LiveMetrics() = default;

void LiveMetrics::advance(prometheus::Counter& counter, std::uint64_t total, std::uint64_t& last_total) {
  const std::uint64_t delta = total >= last_total ? total - last_total : total;
  if (delta > 0) counter.Increment(static_cast<double>(delta));
  last_total = total;
}

void LiveMetrics::update(const LiveSnapshot& s) {
  for (const auto& l : s.links) {
    const prometheus::Labels labels{{"link", l.name()}};  // a relayed link: its topic
    auto& totals = link_totals_[l.sensor_id];
    advance(link_samples_->Add(labels), l.samples_total, totals.samples);
    advance(link_delivered_->Add(labels), l.delivered_total, totals.delivered);
    advance(link_dropped_->Add(labels), l.dropped_total, totals.dropped);
    advance(link_late_->Add(labels), l.late_total, totals.late);
    link_configured_loss_->Add(labels).Set(stationary_loss(l.link.loss));
    link_delay_->Add(labels).Set(l.link.delay.delay_ms / 1000.0);
    link_jitter_->Add(labels).Set(l.link.delay.jitter_ms / 1000.0);
    link_in_time_->Add(labels).Set(l.in_time);
    link_held_->Add(labels).Set(static_cast<double>(l.held));
    link_observed_loss_->Add(labels).Set(l.observed_loss);
    set_observed_rates(l);
  }
  if (!period_) return;  // Scope::links
  if (s.period) {
    const Estimate& e = s.period->estimate;
    period_->Set(static_cast<double>(e.k));
    trace_P_->Set(e.trace_P());
    diverging_->Set(e.state == FilterState::diverging ? 1.0 : 0.0);
    fused_sensors_->Set(static_cast<double>(e.fused.size()));
  }
  advance(*late_, s.late_total, late_total_);
  advance(*rejected_, s.rejected_total, rejected_total_);
  for (const auto& p : s.processes) restarts_->Add({{"process", p.name}});
}

void LiveMetrics::set_observed_rates(const LinkView& l) {
  const std::string link = l.name();
  // A rate not known (no sample since the change) is no series rather than a made-up 0.
  const auto set = [&](prometheus::Family<prometheus::Gauge>& family, const prometheus::Labels& labels,
                       std::optional<double> value) {
    if (value) family.Add(labels).Set(*value);
    else if (family.Has(labels)) family.Remove(&family.Add(labels));
  };
  set(*link_observed_rate_, {{"link", link}, {"window", "since_change"}}, l.observed_rate_since_change);
  set(*link_observed_rate_, {{"link", link}, {"window", window_label()}},
      l.observed_rate_window);
  set(*link_window_samples_, {{"link", link}},
      l.observed_rate_window ? std::optional<double>(static_cast<double>(l.observed_window_samples)) : std::nullopt);
}

void LiveMetrics::observe_pipeline_latency(double seconds) {
  if (latency_ && std::isfinite(seconds) && seconds >= 0.0) latency_->Observe(seconds);
}

void LiveMetrics::update_dashboard(const DashboardStats& d) {
  using namespace prometheus;
  if (!dashboard_connections_) {
    auto& r = *registry_;
    dashboard_connections_ = &BuildGauge()
                                  .Name("netkf_dashboard_connections")
                                  .Help("Connections to the dashboard (HTTP and WebSocket): state=open now, "
                                        "state=max the limit (--dashboard-max-connections)")
                                  .Register(r);
    dashboard_closed_ = &BuildCounter()
                             .Name("netkf_dashboard_connections_closed_total")
                             .Help("Connections the dashboard closed or turned away: reason=refused at the limit "
                                   "(503, none idle), evicted (idle, closed at the limit for a new one), "
                                   "idle_timeout, request_timeout (not complete in time), accept_error")
                             .Register(r);
    dashboard_refused_ = &BuildCounter()
                              .Name("netkf_dashboard_refused_total")
                              .Help("Dashboard traffic refused: what=request (HTTP 4xx other than a plain 404, "
                                    "refused WebSocket handshakes), what=message (WebSocket client messages "
                                    "refused, bad frames)")
                              .Register(r);
  }
  dashboard_connections_->Add({{"state", "open"}}).Set(static_cast<double>(d.connections));
  dashboard_connections_->Add({{"state", "max"}}).Set(static_cast<double>(d.max_connections));
  auto& t = dashboard_totals_;
  advance(dashboard_closed_->Add({{"reason", "refused"}}), d.refused_connections, t.refused_connections);
  advance(dashboard_closed_->Add({{"reason", "evicted"}}), d.evicted_connections, t.evicted_connections);
  advance(dashboard_closed_->Add({{"reason", "idle_timeout"}}), d.idle_timeouts, t.idle_timeouts);
  advance(dashboard_closed_->Add({{"reason", "request_timeout"}}), d.request_timeouts, t.request_timeouts);
  advance(dashboard_closed_->Add({{"reason", "accept_error"}}), d.accept_errors, t.accept_errors);
  advance(dashboard_refused_->Add({{"what", "request"}}), d.refused_requests, t.refused_requests);
  advance(dashboard_refused_->Add({{"what", "message"}}), d.refused_messages, t.refused_messages);
}

void LiveMetrics::count_restart(const std::string& process) {
  if (restarts_) restarts_->Add({{"process", process}}).Increment();
}

std::string LiveMetrics::serialize() const {
  std::ostringstream out;
  prometheus::TextSerializer().Serialize(out, registry_->Collect());
  return out.str();
}

}  // namespace netkf::cli
