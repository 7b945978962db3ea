#pragma once
// What `netkf launch` shows of its running network, and the steering that comes back: the
// launch's live model (one snapshot; the launch feeds it each record before the console gets
// the record, launch.hpp's recording_handlers), the theory computed off the loop, the terminal
// status, the dashboard (page + Foxglove WebSocket) and /metrics. Everything runs on the launch's
// io_context thread except the theory (TheoryWorker); link changes from the page go out
// through `send_link_control`, the same control path as `netkf ctl`.
#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/io_context.hpp>
#include <chrono>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "netkf/cli/dashboard/dashboard_server.hpp"
#include "netkf/cli/live/live_metrics.hpp"
#include "netkf/cli/live/live_model.hpp"
#include "netkf/cli/live/theory_worker.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/link_change.hpp"
#include "netkf/records/link_reply.hpp"
#include "netkf/records/link_status.hpp"
#include "netkf/records/truth.hpp"
#include "netkf/support/log_throttle.hpp"

namespace netkf::cli {

struct LiveConsoleOptions {
  std::optional<DashboardOptions> dashboard;  // nullopt: no dashboard, no port opened
  double status_interval = 1.0;               // seconds between terminal status updates (0: none)
  bool status_screen = false;                 // redraw in place (a terminal) instead of printing lines
  std::string header;                         // first line of the in-place screen
};

class LiveConsole {
 public:
  using SendLinkControl = std::function<bool(std::uint64_t request_id, int sensor_id, const LinkKeys& keys)>;
  using Clock = std::chrono::steady_clock;

  /// Throws std::runtime_error when the dashboard cannot listen (e.g. its port is taken).
  /// `model` must outlive the console; the console takes its events as its first reader.
  LiveConsole(boost::asio::io_context& io, LiveModel& model, LiveConsoleOptions options,
              SendLinkControl send_link_control);
  ~LiveConsole();

  // Each after the model was fed the record.
  void truth(const Truth& truth);
  void estimate(const Estimate& estimate);
  /// `link_moved`: what the model's add_link_status said.
  void link_status(const LinkStatus& status, bool link_moved);
  void link_reply(const LinkReply& reply);
  void link_change(const LinkChange& change);
  void invalid_sample(const std::string& what);

  /// A line of the launch's own log (supervisor events): printed, or kept on the screen.
  void log(LiveEvent::Level level, const std::string& line);
  /// log() and a status message to every dashboard client (e.g. a process restarted).
  void announce(LiveEvent::Level level, const std::string& line);
  void set_processes(std::vector<ProcessView> processes);
  void count_restart(const std::string& process);

  /// Called by the launch's loop (every few tens of ms): theory requests, status, timeouts.
  void tick(Clock::time_point now = Clock::now());
  void set_header(std::string header) { options_.header = std::move(header); }
  /// In-place screen on or off (off at the end of a run: the final lines stay readable).
  void set_screen(bool on) { options_.status_screen = on; }
  /// Close the dashboard's connections (end of run).
  void stop();

  std::optional<std::string> dashboard_url() const;
  const LiveModel& model() const { return model_; }

 private:
  void on_set_parameters(DashboardServer::ClientId client, const dashboard::SetParameters& request);
  /// A change of one link a client asked for, not sent to the channel yet.
  struct LinkRequest {
    DashboardServer::ClientId client = 0;
    std::optional<std::string> id;
    LinkKeys keys;
  };
  /// Send the waiting changes of links with none in flight (at most kChangesInFlight at once).
  void send_waiting_changes();
  void send_change(int sensor_id, const LinkRequest& request);
  /// The link as it is now: the snapshot's, or the one a change of ours made that the
  /// channel's status has not shown yet.
  LinkView current_link(int sensor_id) const;
  /// A status and, when the request had an id, parameterValues with the link's values.
  void answer(DashboardServer::ClientId client, const std::optional<std::string>& id, int sensor_id,
              LiveEvent::Level level, const std::string& message);
  void request_theory(bool with_region);
  void on_theory(TheoryView view);
  void emit_events();
  std::string render_metrics();
  static std::uint64_t wall_ns();

  boost::asio::io_context& io_;
  LiveConsoleOptions options_;
  SendLinkControl send_link_control_;
  LiveModel& model_;
  LiveMetrics metrics_;
  std::unique_ptr<DashboardServer> dashboard_;
  std::deque<std::string> screen_events_;
  LogThrottle invalid_log_;    // a rogue sender: a few warnings, then a count
  LogThrottle dashboard_log_;  // refused dashboard traffic: a few warnings, then a count
  // Link changes from dashboard clients go to the channel one per link at a time: the control
  // topic keeps the last 64 requests, and a burst beyond it was lost unanswered. The latest
  // change asked meanwhile waits for the answer; the one it replaces is answered "superseded".
  std::map<int, LinkRequest> waiting_;  // per link
  struct AppliedChange {
    std::uint64_t request_id;
    LinkSpec link;
    Clock::time_point until;  // the channel's status shows it by then
  };
  std::map<int, AppliedChange> applied_;  // per link: applied, not in the snapshot yet
  // A change sent to the channel: until its answer, then (applied) until it took effect on a
  // sample of the link, the channel's journal entry: a change replaced before any sample saw
  // it would be answered "applied" and logged but never journaled.
  struct PendingChange {
    DashboardServer::ClientId client;
    std::optional<std::string> id;
    int sensor_id;
    LinkSpec link;  // what the link becomes when the channel applies it
    Clock::time_point deadline;
    bool answered = false;     // applied, the client told
    bool took_effect = false;  // its journal entry came before the answer
  };
  std::map<std::uint64_t, PendingChange> pending_;
  std::uint64_t next_request_id_;
  Clock::time_point next_status_;
  Clock::time_point next_refresh_;
  bool region_requested_ = false;
  bool theory_due_ = true;
  std::unique_ptr<TheoryWorker> theory_;  // last: stopped first
};

}  // namespace netkf::cli
