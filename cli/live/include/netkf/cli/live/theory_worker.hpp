#pragma once
// The theory beside the live network, computed off the launch's loop: the loop owns
// signals, the clock and the views, and an assessment can take long (seconds for a large
// plant), so it runs on this worker's own thread. Requests coalesce: while one is being
// computed, only the newest waiting request is kept. The result is handed to `done` on the
// worker thread; the caller posts it back to its loop.
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "netkf/cli/live/live_snapshot.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::cli {

struct TheoryRequest {
  Scenario configured;                        // the scenario with the links as configured now
  std::optional<std::vector<double>> observed_rates;  // per sensor: the observed arrival rate since change
  std::optional<double> observed_actuation_rate;      // the actuation link's, since its change
  std::int64_t k = -1;
  bool with_region = false;                   // two sensors: compute the (λ1, λ2) region too
};

/// The assessment itself (synchronous; what the worker runs). Never throws: a failure is
/// reported as Verdict::unknown with the reason.
TheoryView compute_theory(const TheoryRequest& request);

class TheoryWorker {
 public:
  using Done = std::function<void(TheoryView)>;
  explicit TheoryWorker(Done done);
  /// Stops at once: a computation still running is abandoned (its thread finishes it
  /// alone and reports nothing), so stopping never waits for the theory.
  ~TheoryWorker();
  TheoryWorker(const TheoryWorker&) = delete;
  TheoryWorker& operator=(const TheoryWorker&) = delete;

  void request(TheoryRequest request);
  /// True while a computation runs or waits (the views show "pending").
  bool busy() const;

 private:
  struct State {
    std::mutex mutex;
    std::condition_variable wake;
    std::optional<TheoryRequest> waiting;
    bool running = false;
    bool stop = false;
    Done done;
  };
  static void run(std::shared_ptr<State> state);
  std::shared_ptr<State> state_;
  std::thread thread_;
};

}  // namespace netkf::cli
