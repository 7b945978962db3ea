#pragma once
// Prometheus metrics of a running launch (GET /metrics on the dashboard's port), kept in a
// prometheus-cpp registry and serialized with its text serializer. Updated from the live
// snapshot (the same numbers as the terminal status and the page) and from events the
// snapshot does not keep (each estimate's pipeline latency, process restarts).
#include <map>
#include <memory>
#include <string>

#include "live_snapshot.hpp"

namespace prometheus {
class Registry;
class Counter;
class Gauge;
class Histogram;
template <typename T>
class Family;
}  // namespace prometheus

namespace netkf::cli {

class LiveMetrics {
 public:
  LiveMetrics();
  ~LiveMetrics();
  LiveMetrics(const LiveMetrics&) = delete;
  LiveMetrics& operator=(const LiveMetrics&) = delete;

  /// Bring every gauge and counter to the snapshot's values. Counters follow the
  /// channel's and estimator's running totals; when a total goes back (the process was
  /// restarted), counting resumes from the new total, so a counter never decreases.
  void update(const LiveSnapshot& snapshot);
  /// Sample publish -> estimate publish of one period, seconds (same machine's steady clock).
  void observe_pipeline_latency(double seconds);
  void count_restart(const std::string& process);

  /// The Prometheus text exposition format (version 0.0.4).
  std::string serialize() const;

 private:
  void advance(prometheus::Counter& counter, std::uint64_t total, std::uint64_t& last_total);
  void register_link_metrics();
  void set_observed_rates(const LinkView& link);

  std::shared_ptr<prometheus::Registry> registry_;
  prometheus::Family<prometheus::Counter>* link_samples_;
  prometheus::Family<prometheus::Counter>* link_delivered_;
  prometheus::Family<prometheus::Counter>* link_dropped_;
  prometheus::Family<prometheus::Counter>* link_late_;
  prometheus::Family<prometheus::Gauge>* link_configured_loss_;
  prometheus::Family<prometheus::Gauge>* link_delay_;
  prometheus::Family<prometheus::Gauge>* link_jitter_;
  prometheus::Family<prometheus::Gauge>* link_in_time_;
  prometheus::Family<prometheus::Gauge>* link_held_;
  prometheus::Family<prometheus::Gauge>* link_observed_loss_;
  prometheus::Family<prometheus::Gauge>* link_observed_rate_;
  prometheus::Family<prometheus::Gauge>* link_window_samples_;
  prometheus::Family<prometheus::Counter>* restarts_;
  prometheus::Gauge* period_;
  prometheus::Gauge* trace_P_;
  prometheus::Gauge* diverging_;
  prometheus::Gauge* fused_sensors_;
  prometheus::Counter* late_;
  prometheus::Counter* rejected_;
  prometheus::Histogram* latency_;
  struct LinkTotals {
    std::uint64_t samples = 0, delivered = 0, dropped = 0, late = 0;
  };
  std::map<int, LinkTotals> link_totals_;
  std::uint64_t late_total_ = 0;
  std::uint64_t rejected_total_ = 0;
};

}  // namespace netkf::cli
