#include "netkf/cli/live/theory_worker.hpp"

#include <exception>

#include "netkf/theory/operating_point.hpp"

namespace netkf::cli {

TheoryView compute_theory(const TheoryRequest& request) {
  TheoryView view;
  view.ready = true;
  view.k = request.k;
  view.configured.arrival_rates = theory::configured_arrival_rates(request.configured);
  try {
    view.configured.result = theory::assess_configured_links(request.configured);
  } catch (const std::exception& e) {
    view.configured.result.stable = theory::Verdict::unknown;
    view.configured.result.reason = std::string("theory unavailable: ") + e.what();
  }
  if (request.configured.estimator.fusable_delay_periods() > 0) {
    // The same assessment with each link's delay folded in at the final estimates' horizon.
    const Scenario at_horizon = with_effective_links(request.configured, request.configured.final_horizon_ms());
    AssessmentView final_estimate;
    final_estimate.arrival_rates = theory::configured_arrival_rates(at_horizon);
    try {
      final_estimate.result = theory::assess_configured_links(at_horizon);
    } catch (const std::exception& e) {
      final_estimate.result.stable = theory::Verdict::unknown;
      final_estimate.result.reason = std::string("theory unavailable: ") + e.what();
    }
    view.final_estimate = std::move(final_estimate);
  }
  if (request.observed_rates) {
    AssessmentView observed;
    observed.arrival_rates = *request.observed_rates;
    try {
      observed.result = theory::assess_operating_point(request.configured, *request.observed_rates,
                                                         request.observed_actuation_rate);
    } catch (const std::exception& e) {
      observed.result.stable = theory::Verdict::unknown;
      observed.result.reason = std::string("theory unavailable: ") + e.what();
    }
    view.observed = std::move(observed);
  }
  if (request.with_region && request.configured.sensors.size() == 2) {
    try {
      const auto& s = request.configured;
      view.region = theory::stability_region(s.plant.A, s.plant.Q, s.sensors);
    } catch (const std::exception&) {
      view.region.clear();  // the page then shows no region; the verdict above still stands
    }
  }
  return view;
}

TheoryWorker::TheoryWorker(Done done) : state_(std::make_shared<State>()) {
  state_->done = std::move(done);
  thread_ = std::thread(run, state_);
}

TheoryWorker::~TheoryWorker() {
  bool running = false;
  {
    const std::lock_guard lock(state_->mutex);
    state_->stop = true;
    state_->waiting.reset();
    running = state_->running;
  }
  state_->wake.notify_all();
  // A computation in progress cannot be interrupted; the thread owns its state through
  // the shared pointer and ends when it is done, reporting nothing.
  if (running) thread_.detach();
  else thread_.join();
}

void TheoryWorker::request(TheoryRequest request) {
  {
    const std::lock_guard lock(state_->mutex);
    state_->waiting = std::move(request);
  }
  state_->wake.notify_one();
}

bool TheoryWorker::busy() const {
  const std::lock_guard lock(state_->mutex);
  return state_->running || state_->waiting.has_value();
}

void TheoryWorker::run(std::shared_ptr<State> state) {
  std::unique_lock lock(state->mutex);
  while (true) {
    state->wake.wait(lock, [&] { return state->stop || state->waiting.has_value(); });
    if (state->stop) return;
    TheoryRequest request = std::move(*state->waiting);
    state->waiting.reset();
    state->running = true;
    lock.unlock();
    TheoryView view = compute_theory(request);
    lock.lock();
    state->running = false;
    // Under the lock: once the destructor has set `stop`, `done` is never called again.
    if (state->stop) return;
    state->done(std::move(view));
  }
}

}  // namespace netkf::cli
