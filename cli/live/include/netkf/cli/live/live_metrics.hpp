#pragma once
// Prometheus metrics of a running launch (GET /metrics on the dashboard's port), kept in a
// prometheus-cpp registry and serialized with its text serializer. Updated from the live
// snapshot (the same numbers as the terminal status and the page) and from events the
// snapshot does not keep (each estimate's pipeline latency, process restarts).
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "netkf/cli/live/live_snapshot.hpp"

namespace prometheus {
class Registry;
class Counter;
class Gauge;
class Histogram;
template <typename T>
class Family;
}  // namespace prometheus

namespace netkf::cli {

/// What the dashboard's server counted since it started (dashboard_server.hpp fills it).
struct DashboardStats {
  std::size_t connections = 0;             // open now, HTTP and WebSocket
  std::size_t max_connections = 0;
  std::uint64_t refused_connections = 0;   // refused at the cap (503)
  std::uint64_t evicted_connections = 0;   // idle ones closed at the cap for a new one
  std::uint64_t idle_timeouts = 0;         // closed with no request begun for the idle timeout
  std::uint64_t request_timeouts = 0;      // a request not complete in time after its first byte
  std::uint64_t refused_requests = 0;      // answered 4xx (not a plain 404), refused handshakes
  std::uint64_t refused_messages = 0;      // WebSocket client messages refused, bad frames
  std::uint64_t accept_errors = 0;         // accept failed (e.g. out of descriptors)
};

class LiveMetrics {
 public:
  /// launch: the links, the estimator, the processes; links: the links only (`netkf relay`,
  /// whose links are its topics', labelled by topic).
  enum class Scope { launch, links };
  explicit LiveMetrics(Scope scope = Scope::launch);
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
  /// The dashboard's connections and what it refused (netkf_dashboard_*).
  void update_dashboard(const DashboardStats& stats);

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
  // The launch's own (nullptr for Scope::links).
  prometheus::Family<prometheus::Counter>* restarts_ = nullptr;
  prometheus::Gauge* period_ = nullptr;
  prometheus::Gauge* trace_P_ = nullptr;
  prometheus::Gauge* diverging_ = nullptr;
  prometheus::Gauge* fused_sensors_ = nullptr;
  prometheus::Counter* late_ = nullptr;
  prometheus::Counter* rejected_ = nullptr;
  prometheus::Histogram* latency_ = nullptr;
  prometheus::Family<prometheus::Gauge>* dashboard_connections_ = nullptr;  // registered on first use
  prometheus::Family<prometheus::Counter>* dashboard_closed_ = nullptr;
  prometheus::Family<prometheus::Counter>* dashboard_refused_ = nullptr;
  DashboardStats dashboard_totals_;
  struct LinkTotals {
    std::uint64_t samples = 0, delivered = 0, dropped = 0, late = 0;
  };
  std::map<int, LinkTotals> link_totals_;
  std::uint64_t late_total_ = 0;
  std::uint64_t rejected_total_ = 0;
};

}  // namespace netkf::cli
