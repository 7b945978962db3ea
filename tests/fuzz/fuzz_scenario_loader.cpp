// Fuzzes the scenario loader (core/src/model/scenario_loader.cpp) on arbitrary text, as a
// scenario file and as an events file: it must return a valid scenario or throw
// ScenarioError, never crash, hang or throw anything else. A scenario it accepts must
// survive the trip to a child process (scenario_to_yaml, parsed again).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "netkf/model/scenario.hpp"

namespace {

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_scenario_loader: %s: %s\n", what, detail.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const netkf::Scenario scenario = netkf::parse_scenario(text, "fuzz.yaml");
    // Launch hands the scenario to every node as YAML: what was accepted must load again.
    netkf::Scenario again;
    try {
      again = netkf::parse_scenario(netkf::scenario_to_yaml(scenario), "again.yaml");
    } catch (const netkf::ScenarioError& e) {
      finding("an accepted scenario does not load from its own YAML", e.what());
    }
    if (again.plant.A != scenario.plant.A || again.sensors.size() != scenario.sensors.size() ||
        again.events != scenario.events || again.period_ms != scenario.period_ms)
      finding("an accepted scenario changed on its trip through YAML", scenario.name);
    (void)netkf::with_effective_links(scenario);
  } catch (const netkf::ScenarioError&) {
  }

  // The same text as an events file (--replay) for the built-in scenario's links.
  static const netkf::Scenario base = netkf::default_scenario();
  try {
    const auto events = netkf::parse_events(text, base, "fuzz-events.yaml");
    netkf::Scenario replayed = base;
    netkf::add_replayed_events(replayed, events);
  } catch (const netkf::ScenarioError&) {
  }
  return 0;
}
