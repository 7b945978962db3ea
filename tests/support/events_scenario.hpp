#pragma once
// What the tests of scenario events (their parsing, model/) and of their replay by the channel
// share: a three-link scenario to which a test appends its `events:` lines, and the error a
// scenario load throws.
#include <exception>
#include <functional>
#include <string>
#include <vector>

#include "netkf/model/scenario.hpp"

namespace netkf_test {

/// The ScenarioError's message of `f`, or a text that says it threw another or none.
inline std::string scenario_error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const netkf::ScenarioError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("<not a ScenarioError: ") + e.what() + ">";
  }
  return "<no ScenarioError thrown>";
}

inline const char* const kScenarioHead =
    "period_ms: 10\n"
    "seed: 7\n"
    "plant: { A: [[0.5]], Q: [[1.0]] }\n"
    "sensors:\n"
    "  - { id: 1, C: [[1.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.3, delay_ms: 4, jitter_ms: 2 } }\n"
    "  - { id: 2, C: [[1.0]], R: [[1.0]], link: { model: gilbert_elliott, loss: 0.2, mean_burst: 5 } }\n"
    "  - { id: 3, C: [[1.0]], R: [[1.0]], link: { model: gilbert_elliott, p: 0.1, r: 0.3, loss_good: 0.02, "
    "loss_bad: 0.7 } }\n"
    "events:\n";
/// The line of kScenarioHead's first event.
inline constexpr int kFirstEventLine = 9;

/// kScenarioHead with these `events:` lines.
inline std::string with_events(const std::vector<std::string>& lines) {
  std::string text = kScenarioHead;
  for (const auto& l : lines) text += l + "\n";
  return text;
}

/// kScenarioHead without events.
inline netkf::Scenario base_scenario() {
  std::string text = kScenarioHead;
  text.resize(text.size() - std::string("events:\n").size());
  return netkf::parse_scenario(text, "base.yaml");
}

}  // namespace netkf_test
