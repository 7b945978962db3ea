// Scenario `events:` (docs/scenario-format.md, "events"): parsing, errors at FILE:LINE:COL, events
// files and their replay, the YAML round trip. Expectations written out by hand from the text.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <limits>
#include <ostream>
#include <string>
#include <unistd.h>
#include <variant>
#include <vector>

#include "netkf/links/link.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/model/scenario.hpp"

#include "support/events_scenario.hpp"
#include "support/link_printers.hpp"

namespace {

namespace fs = std::filesystem;
using netkf::BernoulliLink;
using netkf::DelayDistribution;
using netkf::GilbertElliottLink;
using netkf::LinkDelay;
using netkf::LinkEvent;
using netkf::LinkSpec;
using ::testing::HasSubstr;
using ::testing::StartsWith;

using netkf_test::num;
using netkf_test::word;

using netkf_test::scenario_error_of;

// ======================================================================================
// Scenario events: parsing, errors, files, replay.

using netkf_test::base_scenario;
using netkf_test::kFirstEventLine;
using netkf_test::kScenarioHead;
using netkf_test::with_events;

TEST(LinkEvents, AtPeriodAtSetAndRampsAreRead) {
  const netkf::Scenario s = netkf::parse_scenario(
      with_events({
          "  - { at_period: 300, link: 1, set: { loss: 1.0 } }",
          "  - { at_s: 2.5, link: 1, set: { delay_ms: 20, model: bernoulli, loss: 0.1 } }",
          "  - { at_s: 0.026, link: 3, ramp: { to: { p: 0.2, jitter_ms: 3 }, over_s: 0.37 } }",
          "  - { at_s: 0.024, link: 1, ramp: { to: { loss: 0.5 }, over_periods: 7 } }",
          "  - { at_period: 0, link: 3, set: { delay_distribution: pareto, delay_ms: 2, jitter_ms: 1 } }",
          "  - { at_s: 0, link: 2, ramp: { to: { mean_burst: 2 }, over_s: 0 } }",
      }),
      "ev.yaml");
  ASSERT_EQ(s.events.size(), 6u);
  const std::vector<LinkEvent> expected = {
      {300, 1, LinkEvent::Kind::set, {num("loss", 1.0)}, 0},
      // Keys come back in the documented order (model, loss, ..., delay_ms, ...), not the file's.
      {250, 1, LinkEvent::Kind::set, {word("model", "bernoulli"), num("loss", 0.1), num("delay_ms", 20.0)}, 0},
      // at_s and over_s are rounded to whole periods: 2.6 -> 3, 2.4 -> 2, 37.
      {3, 3, LinkEvent::Kind::ramp, {num("p", 0.2), num("jitter_ms", 3.0)}, 37},
      {2, 1, LinkEvent::Kind::ramp, {num("loss", 0.5)}, 7},
      {0, 3, LinkEvent::Kind::set, {num("delay_ms", 2.0), num("jitter_ms", 1.0), word("delay_distribution", "pareto")}, 0},
      {0, 2, LinkEvent::Kind::ramp, {num("mean_burst", 2.0)}, 0},
  };
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_EQ(s.events[i], expected[i]) << "events[" << i << "]";
  // The order they apply: by period, ties in list order.
  EXPECT_EQ(netkf::event_application_order(s.events), (std::vector<std::size_t>{4, 5, 3, 2, 1, 0}));
}

TEST(LinkEvents, KeysAreCheckedForTheLinkAsItIsWhenTheEventApplies) {
  // Link 1 is Bernoulli until period 100. mean_burst applies to it only from then on,
  // whatever the order of the list.
  EXPECT_NO_THROW(netkf::parse_scenario(
      with_events({"  - { at_period: 200, link: 1, set: { mean_burst: 3 } }",
                   "  - { at_period: 100, link: 1, set: { model: gilbert_elliott, p: 0.1, r: 0.5 } }"}),
      "ev.yaml"));
  const std::string message = scenario_error_of([] {
    netkf::parse_scenario(
        with_events({"  - { at_period: 100, link: 1, set: { model: gilbert_elliott, p: 0.1, r: 0.5 } }",
                     "  - { at_period: 50, link: 1, set: { mean_burst: 3 } }"}),
        "ev.yaml");
  });
  EXPECT_THAT(message, StartsWith("ev.yaml:" + std::to_string(kFirstEventLine + 1) + ":"));
  EXPECT_THAT(message, HasSubstr("events[1].set.mean_burst is a gilbert_elliott key"));
}

// "FILE:LINE:COL: " of `token` in the `index`th event line (1-based line and column).
std::string at(const std::vector<std::string>& lines, std::size_t index, const std::string& token) {
  const std::size_t col = lines[index].find(token);
  EXPECT_NE(col, std::string::npos) << token;
  return "ev.yaml:" + std::to_string(kFirstEventLine + static_cast<int>(index)) + ":" + std::to_string(col + 1) + ": ";
}

TEST(LinkEvents, ErrorsGiveFileLineColumnAndWhatIsWrong) {
  struct Case {
    std::vector<std::string> lines;
    std::size_t index;  // the line the error is on
    std::string token;  // where on it
    std::vector<std::string> words;
  };
  const std::vector<Case> cases = {
      {{"  - { at_period: -1, link: 1, set: { loss: 0.5 } }"}, 0, "-1",
       {"events[0].at_period: the event is before period 0, got -1"}},
      {{"  - { at_period: 5, link: 1, set: { loss: 0.5 } }", "  - { at_s: -0.5, link: 1, set: { loss: 0.5 } }"}, 1,
       "-0.5", {"events[1].at_s: the event is before the start (period 0), got -0.5"}},
      {{"  - { at_period: 1.5, link: 1, set: { loss: 0.5 } }"}, 0, "1.5", {"events[0].at_period must be an integer"}},
      {{"  - { at_period: 5, link: 9, set: { loss: 0.5 } }"}, 0, "link",
       {"events[0].link: unknown link 9 (the scenario's links: 1, 2, 3)"}},
      {{"  - { at_period: 5, set: { loss: 0.5 } }"}, 0, "{", {"missing required key 'events[0].link'"}},
      {{"  - { at_period: 5, link: 1, set: { los: 0.5 } }"}, 0, "los", {"unknown key 'los' in events[0].set"}},
      {{"  - { at_period: 5, link: 1, set: { loss: 1.5 } }"}, 0, "loss",
       {"events[0].set.loss must be a probability in [0, 1], got 1.5"}},
      {{"  - { at_period: 5, link: 1, set: { loss: high } }"}, 0, "high", {"events[0].set.loss must be a number"}},
      {{"  - { at_period: 5, link: 1, set: { loss: .nan } }"}, 0, ".nan", {"events[0].set.loss must be a finite number"}},
      {{"  - { at_period: 5, link: 1, set: { delay_ms: -3 } }"}, 0, "delay_ms",
       {"events[0].set.delay_ms must be in [0, 60000] ms, got -3"}},
      {{"  - { at_period: 5, link: 1, set: { model: 2 } }"}, 0, "model",
       {"events[0].set: unknown link model '2' (expected bernoulli, gilbert_elliott or trace)"}},
      {{"  - { at_period: 5, link: 2, set: { loss: 0.9 } }"}, 0, "loss",
       {"events[0].set.loss 0.9 with mean_burst 5 needs p = 1.8 > 1"}},
      // A key that does not apply to the link at that point.
      {{"  - { at_period: 5, link: 1, set: { mean_burst: 3 } }"}, 0, "mean_burst",
       {"events[0].set.mean_burst is a gilbert_elliott key; a bernoulli link has only loss"}},
      {{"  - { at_period: 5, link: 3, set: { loss: 0.2, r: 0.5 } }"}, 0, "r: 0.5",
       {"events[0].set: a gilbert_elliott link is given by", "not both (r given with loss)"}},
      {{"  - { at_period: 5, link: 1, ramp: { to: { p: 0.5 }, over_periods: 3 } }"}, 0, "p: 0.5",
       {"events[0].ramp.to: link key 'p' does not apply to a bernoulli link"}},
      // Ramps move numbers.
      {{"  - { at_period: 5, link: 1, ramp: { to: { model: gilbert_elliott }, over_s: 1 } }"}, 0, "model",
       {"events[0].ramp.to.model: a ramp moves numbers; change model with set"}},
      {{"  - { at_period: 5, link: 1, ramp: { to: { delay_distribution: normal }, over_s: 1 } }"}, 0,
       "delay_distribution", {"a ramp moves numbers; change delay_distribution with set"}},
      {{"  - { at_period: 5, link: 1, ramp: { to: { loss: 0.5 } } }"}, 0, "ramp",
       {"events[0].ramp needs exactly one of over_s (seconds) or over_periods"}},
      {{"  - { at_period: 5, link: 1, ramp: { to: { loss: 0.5 }, over_s: 1, over_periods: 3 } }"}, 0, "ramp",
       {"events[0].ramp needs exactly one of over_s"}},
      {{"  - { at_period: 5, link: 1, ramp: { to: { loss: 0.5 }, over_periods: -2 } }"}, 0, "-2",
       {"events[0].ramp.over_periods must be >= 0, got -2"}},
      {{"  - { at_period: 5, link: 1, ramp: { to: { loss: 0.5 }, over_s: -1 } }"}, 0, "-1",
       {"events[0].ramp.over_s must be >= 0, got -1"}},
      // (This one used to escape as std::out_of_range "map::at".)
      {{"  - { at_period: 5, link: 1, ramp: { over_s: 1 } }"}, 0, "ramp", {"missing required key 'events[0].ramp.to'"}},
      // When and what: exactly one of each.
      {{"  - { at_period: 5, at_s: 1, link: 1, set: { loss: 0.5 } }"}, 0, "{",
       {"events[0] needs exactly one of at_period (a period index) or at_s (seconds from the start)"}},
      {{"  - { link: 1, set: { loss: 0.5 } }"}, 0, "{", {"events[0] needs exactly one of at_period"}},
      {{"  - { at_period: 5, link: 1 }"}, 0, "{",
       {"events[0] needs exactly one of set: { LINK KEYS } or ramp: { to: { LINK KEYS }, over_s: S }"}},
      {{"  - { at_period: 5, link: 1, set: { loss: 0.5 }, ramp: { to: { loss: 0.5 }, over_s: 1 } }"}, 0, "{",
       {"events[0] needs exactly one of set"}},
      {{"  - { at_period: 5, link: 1, when: 3, set: { loss: 0.5 } }"}, 0, "when",
       {"unknown key 'when' in events[0] (expected one of: at_period, at_s, link, set, ramp)"}},
      {{"  - { at_period: 5, link: 1, set: [ 0.5 ] }"}, 0, "set", {"events[0].set must be a mapping"}},
  };
  for (const Case& c : cases) {
    const std::string message = scenario_error_of([&] { netkf::parse_scenario(with_events(c.lines), "ev.yaml"); });
    EXPECT_THAT(message, StartsWith(at(c.lines, c.index, c.token))) << c.lines[c.index];
    for (const auto& w : c.words) EXPECT_THAT(message, HasSubstr(w)) << c.lines[c.index];
  }
  // `events` itself must be a list.
  const std::string not_a_list =
      scenario_error_of([] { netkf::parse_scenario(std::string(kScenarioHead) + "  at_period: 3\n", "ev.yaml"); });
  EXPECT_THAT(not_a_list, StartsWith("ev.yaml:8:1: events must be a list")) << not_a_list;
}

// A temporary file, removed at the end of the test.
class TempFile {
 public:
  explicit TempFile(const std::string& stem)
      : path_(fs::temp_directory_path() / (stem + "-" + std::to_string(::getpid()) + ".yaml")) {}
  ~TempFile() {
    std::error_code ec;
    fs::remove(path_, ec);
  }
  const fs::path& path() const { return path_; }
  void write(const std::string& text) const { std::ofstream(path_, std::ios::trunc) << text; }

 private:
  fs::path path_;
};

std::vector<LinkEvent> sample_events() {
  // Keys in the documented order (what a reader returns), awkward doubles included.
  return {
      {0, 3, LinkEvent::Kind::set, {num("delay_ms", 0.1 + 0.2), word("delay_distribution", "paretonormal")}, 0},
      {12, 1, LinkEvent::Kind::set, netkf::link_keys(LinkSpec(BernoulliLink{1.0 / 3.0}, {6.0, 4.0})), 0},
      {12, 2, LinkEvent::Kind::ramp, {num("loss", 0.05), num("mean_burst", 2.5)}, 40},
      {700, 3, LinkEvent::Kind::ramp, {num("p", 0.123456789012345), num("jitter_ms", 1e-7)}, 0},
      {900, 2, LinkEvent::Kind::set,
       netkf::link_keys(LinkSpec(GilbertElliottLink{0.07, 0.31, 0.011, 0.93}, {2.0, 1.0, DelayDistribution::normal})), 0},
  };
}

TEST(LinkEvents, EventsToYamlAndBackGiveEqualEvents) {
  const netkf::Scenario s = base_scenario();
  const std::vector<LinkEvent> events = sample_events();
  const TempFile file("netkf-test-link-events");
  file.write(netkf::events_to_yaml(events));
  EXPECT_EQ(netkf::load_events_file(file.path(), s), events);
  // No events: a valid file with none.
  file.write(netkf::events_to_yaml({}));
  EXPECT_TRUE(netkf::load_events_file(file.path(), s).empty());
  // A bare list is accepted too; its errors carry the file, line and column.
  file.write("- { at_period: 3, link: 1, set: { loss: 0.5 } }\n- { at_period: 4, link: 1, set: { p: 0.5 } }\n");
  const std::string message = scenario_error_of([&] { netkf::load_events_file(file.path(), s); });
  EXPECT_THAT(message, StartsWith(file.path().string() + ":2:35: events[1].set.p is a gilbert_elliott key")) << message;
  file.write("events:\n  - { at_period: -4, link: 1, set: { loss: 0.5 } }\n");
  EXPECT_THAT(scenario_error_of([&] { netkf::load_events_file(file.path(), s); }),
              StartsWith(file.path().string() + ":2:18: events[0].at_period: the event is before period 0"));
}

// An empty events file (0 bytes, or comments only) is a mistake more likely than a replay of
// no change, which --record writes as `events: []`: refused, not taken as "no changes".
TEST(LinkEvents, AnEmptyEventsFileIsRefused) {
  const netkf::Scenario s = base_scenario();
  const TempFile file("netkf-test-link-events-empty");
  for (const std::string text : {"", "# only a comment\n", "{}\n"}) {
    SCOPED_TRACE(text);
    file.write(text);
    EXPECT_THAT(scenario_error_of([&] { netkf::load_events_file(file.path(), s); }),
                testing::AnyOf(HasSubstr("the events file is empty"), HasSubstr("missing required key 'events'")));
  }
  file.write("events: []\n");
  EXPECT_TRUE(netkf::load_events_file(file.path(), s).empty());
}

// load_events_file checks the file's events together with the scenario's own timeline, as
// they are replayed (add_replayed_events): a hand-written file may rely on the scenario's
// timeline (a Gilbert-Elliott key after the timeline made the link Gilbert-Elliott).
TEST(LinkEvents, AnEventsFileIsCheckedTogetherWithTheScenariosTimeline) {
  netkf::Scenario s = base_scenario();
  s.events = {{100, 1, LinkEvent::Kind::set, {word("model", "gilbert_elliott"), num("p", 0.1), num("r", 0.5)}, 0}};
  netkf::validate_scenario(s);
  const TempFile file("netkf-test-link-events-timeline");
  file.write("events:\n  - { at_period: 200, link: 1, set: { mean_burst: 3 } }\n");
  std::vector<LinkEvent> replayed;
  EXPECT_NO_THROW(replayed = netkf::load_events_file(file.path(), s));
  EXPECT_NO_THROW(netkf::add_replayed_events(s, replayed));
}

TEST(LinkEvents, ScenarioYamlRoundTripKeepsLinksWithDelayAndEventsExactly) {
  netkf::Scenario s = base_scenario();
  const std::vector<LinkSpec> links = {
      LinkSpec(BernoulliLink{0.1 + 0.2}, LinkDelay{1.0 / 3.0, 2.0 / 7.0, DelayDistribution::normal}),
      LinkSpec(GilbertElliottLink{0.07, 1.0 / 3.0, 0.0, 1.0}, LinkDelay{6.000000000000001, 4.0, DelayDistribution::pareto}),
      netkf::apply_link_keys(LinkSpec{}, {word("model", "gilbert_elliott"), num("loss", 0.123), num("mean_burst", 3.7),
                                          num("delay_ms", 0.5), num("jitter_ms", 59999.99),
                                          word("delay_distribution", "paretonormal")}),
  };
  for (std::size_t i = 0; i < links.size(); ++i) s.sensors[i].link = links[i];
  s.events = sample_events();
  netkf::validate_scenario(s);
  const netkf::Scenario back = netkf::parse_scenario(netkf::scenario_to_yaml(s), "round-trip.yaml");
  ASSERT_EQ(back.sensors.size(), s.sensors.size());
  for (std::size_t i = 0; i < s.sensors.size(); ++i) EXPECT_EQ(back.sensors[i].link, s.sensors[i].link) << i;
  EXPECT_EQ(back.events, s.events);
}

}  // namespace
