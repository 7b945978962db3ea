// Link changes in the channel (ChannelLinks): ramps of a link's keys, moving linearly and reaching
// their target exactly, and replayed events applied before the scenario's at the same period.

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
#include "netkf/links/loss_model.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/nodes/channel_links.hpp"

#include "support/events_scenario.hpp"
#include "support/link_printers.hpp"

namespace {

using netkf::BernoulliLink;
using netkf::GilbertElliottLink;
using netkf::LinkEvent;
using netkf::LinkSpec;
using ::testing::HasSubstr;

using netkf_test::num;
using netkf_test::word;

const GilbertElliottLink& ge(const LinkSpec& l) { return std::get<GilbertElliottLink>(l.loss); }

using netkf_test::scenario_error_of;

using netkf_test::base_scenario;
using netkf_test::kScenarioHead;
using netkf_test::with_events;

TEST(LinkEvents, ReplayedEventsApplyBeforeTheScenariosAtTheSamePeriod) {
  netkf::Scenario s = base_scenario();
  s.events = {{100, 1, LinkEvent::Kind::set, {num("loss", 0.5)}, 0},
              {300, 2, LinkEvent::Kind::set, {num("mean_burst", 2.0)}, 0}};
  const std::vector<LinkEvent> replayed = {
      {100, 1, LinkEvent::Kind::set, {word("model", "bernoulli"), num("loss", 0.9)}, 0},
      {40, 2, LinkEvent::Kind::set, {num("loss", 0.1)}, 0},
  };
  netkf::add_replayed_events(s, replayed);
  ASSERT_EQ(s.events.size(), 4u);
  // Replayed first in the list, so first among equals in the order of application.
  EXPECT_EQ(s.events[0], replayed[0]);
  EXPECT_EQ(s.events[1], replayed[1]);
  const std::vector<std::size_t> order = netkf::event_application_order(s.events);
  EXPECT_EQ(order, (std::vector<std::size_t>{1, 0, 2, 3}));

  // In the channel: at period 100 the replayed change applies, then the scenario's.
  netkf::nodes::ChannelLinks links(s);
  for (std::int64_t k = 0; k <= 100; ++k) links.on_sample(1, k);
  const auto changes = links.take_changes();
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].at_period, 100);
  EXPECT_EQ(changes[0].link.loss, netkf::LinkModel(BernoulliLink{0.9}));
  EXPECT_EQ(changes[1].link.loss, netkf::LinkModel(BernoulliLink{0.5}));
  EXPECT_EQ(links.status(1)->link, LinkSpec(BernoulliLink{0.5}, {4.0, 2.0}));  // the delay kept

  // The result is validated.
  netkf::Scenario t = base_scenario();
  EXPECT_THAT(scenario_error_of([&] {
                netkf::add_replayed_events(t, {{5, 42, LinkEvent::Kind::set, {num("loss", 0.1)}, 0}});
              }),
              HasSubstr("events[0].link: unknown link 42"));
  netkf::Scenario u = base_scenario();
  EXPECT_THAT(scenario_error_of([&] {
                netkf::add_replayed_events(u, {{5, 1, LinkEvent::Kind::set, {num("mean_burst", 2.0)}, 0}});
              }),
              HasSubstr("events[0].set.mean_burst is a gilbert_elliott key"));
}

// ======================================================================================
// Ramps in the channel (ChannelLinks).

TEST(LinkRamp, GilbertElliottRampOfPMovesLinearlyAndReachesTheTargetExactly) {
  const netkf::Scenario s = netkf::parse_scenario(
      with_events({"  - { at_period: 100, link: 3, ramp: { to: { p: 0.25 }, over_periods: 8 } }"}), "ramp.yaml");
  netkf::nodes::ChannelLinks links(s);
  const GilbertElliottLink start{0.1, 0.3, 0.02, 0.7};
  std::uint64_t samples = 0;
  for (std::int64_t k = 0; k < 150; ++k) {
    links.on_sample(3, k);
    ++samples;
    const LinkSpec now = links.status(3)->link;
    const GilbertElliottLink& g = ge(now);
    // Only p moves.
    EXPECT_EQ(g.r, start.r);
    EXPECT_EQ(g.loss_good, start.loss_good);
    EXPECT_EQ(g.loss_bad, start.loss_bad);
    if (k < 100) {
      EXPECT_EQ(g.p, start.p) << k;
    } else if (k < 108) {
      EXPECT_NEAR(g.p, 0.1 + 0.15 * static_cast<double>(k - 100) / 8.0, 1e-15) << k;
    } else {
      EXPECT_EQ(g.p, 0.25) << k;  // exactly the target, from period 108 on
    }
    // A ramp's steps do not reset the link's statistics.
    EXPECT_EQ(links.status(3)->samples_in, samples);
  }
  // Journal: the ramp's start (100) and its end (108).
  const auto changes = links.take_changes();
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].at_period, 100);
  EXPECT_EQ(changes[1].at_period, 108);
  EXPECT_EQ(ge(changes[1].link).p, 0.25);
}

TEST(LinkRamp, ARampOfLossOnTheUserFormKeepsTheMeanBurst) {
  // over_s 0.1 at period_ms 10: 10 periods.
  const netkf::Scenario s = netkf::parse_scenario(
      with_events({"  - { at_s: 1, link: 2, ramp: { to: { loss: 0.4, delay_ms: 10 }, over_s: 0.1 } }"}), "ramp.yaml");
  netkf::nodes::ChannelLinks links(s);
  for (std::int64_t k = 0; k < 130; ++k) {
    links.on_sample(2, k);
    const LinkSpec now = links.status(2)->link;
    const double f = std::clamp(static_cast<double>(k - 100) / 10.0, 0.0, 1.0);
    EXPECT_NEAR(netkf::stationary_loss(now.loss), 0.2 + 0.2 * f, 1e-12) << k;
    EXPECT_NEAR(netkf::mean_burst_length(now.loss), 5.0, 1e-9) << k;
    EXPECT_NEAR(now.delay.delay_ms, 10.0 * f, 1e-12) << k;
  }
  EXPECT_EQ(links.status(2)->link.delay.delay_ms, 10.0);
}

TEST(LinkRamp, ARampOverZeroPeriodsIsASet) {
  const netkf::Scenario ramp = netkf::parse_scenario(
      with_events({"  - { at_period: 100, link: 3, ramp: { to: { p: 0.25, delay_ms: 3 }, over_periods: 0 } }"}),
      "ramp.yaml");
  const netkf::Scenario set = netkf::parse_scenario(
      with_events({"  - { at_period: 100, link: 3, set: { p: 0.25, delay_ms: 3 } }"}), "set.yaml");
  netkf::nodes::ChannelLinks a(ramp), b(set);
  for (std::int64_t k = 0; k < 400; ++k) {
    const auto fa = a.on_sample(3, k);
    const auto fb = b.on_sample(3, k);
    ASSERT_EQ(fa.verdict, fb.verdict) << k;
    ASSERT_EQ(fa.delay_ms, fb.delay_ms) << k;
    ASSERT_EQ(a.status(3)->link, b.status(3)->link) << k;
    if (k == 100) {
      EXPECT_EQ(ge(a.status(3)->link).p, 0.25);
      EXPECT_EQ(a.status(3)->link.delay.delay_ms, 3.0);
    }
  }
  const auto ca = a.take_changes();
  const auto cb = b.take_changes();
  ASSERT_EQ(ca.size(), 1u);
  ASSERT_EQ(cb.size(), 1u);
  EXPECT_EQ(ca[0].at_period, 100);
  EXPECT_EQ(ca[0].link, cb[0].link);
  EXPECT_TRUE(ca[0].failure.empty());
}

// "Start clean, then ramp up bursty loss" keeps the burst length
// (see AUserFormLinkWithLossZeroKeepsItsMeanBurst).
TEST(LinkRamp, ARampOfLossFromZeroKeepsTheMeanBurst) {
  const netkf::Scenario s = netkf::parse_scenario(
      std::string(kScenarioHead).replace(std::string(kScenarioHead).find("loss: 0.2, mean_burst: 5"), 24,
                                         "loss: 0.0, mean_burst: 5") +
          "  - { at_period: 10, link: 2, ramp: { to: { loss: 0.2 }, over_periods: 10 } }\n",
      "ramp.yaml");
  netkf::nodes::ChannelLinks links(s);
  for (std::int64_t k = 0; k <= 30; ++k) links.on_sample(2, k);
  EXPECT_NEAR(netkf::stationary_loss(links.status(2)->link.loss), 0.2, 1e-12);
  EXPECT_NEAR(netkf::mean_burst_length(links.status(2)->link.loss), 5.0, 1e-9);
}

}  // namespace
