// RelayLinks, the decisions of `netkf relay` (docs/relay.md). Expectations: a second, direct
// draw from the same seeded loss process (LinkLossProcess with derive_seed of the documented
// stream), the stationary loss and mean burst of the Gilbert-Elliott chain in closed form
// (π_B = p/(p+r), mean burst 1/r for the simple Gilbert channel), a trace's own rows.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "netkf/link_trace.hpp"
#include "netkf/random.hpp"
#include "netkf/relay_links.hpp"
#include "netkf/scenario.hpp"

namespace {

using netkf::BernoulliLink;
using netkf::GilbertElliottLink;
using netkf::LinkSpec;
using netkf::RelayLinks;

std::uint64_t fnv1a(const std::string& s) {
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

TEST(RelayLinks, EachTopicDrawsFromItsOwnDocumentedStream) {
  RelayLinks links({{"rt/scan", BernoulliLink{0.3}}, {"rt/odom", BernoulliLink{0.6}}}, 42);
  netkf::LinkLossProcess scan(BernoulliLink{0.3}, netkf::derive_seed(42, "relay-link", fnv1a("rt/scan")));
  netkf::LinkLossProcess odom(BernoulliLink{0.6}, netkf::derive_seed(42, "relay-link", fnv1a("rt/odom")));
  for (std::uint64_t i = 0; i < 2000; ++i) {
    // Interleaved unevenly: a topic's decisions do not depend on the other topic's traffic.
    const auto a = links.on_sample("rt/scan");
    ASSERT_TRUE(a);
    EXPECT_EQ(a->index, i);
    EXPECT_EQ(a->delivered, !scan.next_dropped()) << "rt/scan sample " << i;
    if (i % 3 == 0) {
      const auto b = links.on_sample("rt/odom");
      ASSERT_TRUE(b);
      EXPECT_EQ(b->delivered, !odom.next_dropped()) << "rt/odom sample " << i / 3;
    }
  }
  EXPECT_FALSE(links.on_sample("rt/other")) << "a topic that is not relayed has no link";
}

TEST(RelayLinks, GilbertElliottMatchesItsStationaryLossAndMeanBurst) {
  const double p = 0.05, r = 0.25;  // simple Gilbert channel: loss_good 0, loss_bad 1
  RelayLinks links({{"rt/chatter", GilbertElliottLink{p, r, 0.0, 1.0}}}, 7);
  const int n = 200000;
  for (int i = 0; i < n; ++i) ASSERT_TRUE(links.on_sample("rt/chatter"));
  const auto report = links.reports().at(0);
  EXPECT_EQ(report.stats.samples(), static_cast<std::uint64_t>(n));
  const double expected_loss = p / (p + r);  // π_B
  // The chain's samples are correlated: allow 5 sd of the burst-inflated binomial spread.
  const double sd = std::sqrt(expected_loss * (1 - expected_loss) / n * (2.0 / r));
  EXPECT_NEAR(report.stats.observed_loss(), expected_loss, 5 * sd);
  EXPECT_NEAR(report.stats.mean_burst_length(), 1.0 / r, 0.1);
}

TEST(RelayLinks, ATraceLinkReplaysItsRowsFromTheSampleItTookEffectAt) {
  auto trace = std::make_shared<netkf::LinkTrace>();
  trace->delivered = {1, 0, 0, 1, 1};
  LinkSpec spec(BernoulliLink{0.4});
  spec.trace = netkf::TraceLink{"five-rows.csv", true, 1, trace};  // loop, from row 1
  RelayLinks links({{"rt/chatter", BernoulliLink{0.0}}}, 3);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(links.on_sample("rt/chatter")->delivered);  // lossless first
  ASSERT_TRUE(links.set_link("rt/chatter", spec));
  const std::vector<bool> expected{false, false, true, true, true, false, false, true};  // rows 1,2,3,4,0,1,2,3
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const auto fate = links.on_sample("rt/chatter");
    EXPECT_EQ(fate->index, 3 + i);
    EXPECT_EQ(fate->delivered, expected[i]) << "sample " << i << " after the change";
  }
  EXPECT_EQ(links.reports().at(0).stats.samples(), expected.size()) << "a change restarts the statistics";
  EXPECT_FALSE(links.set_link("rt/unknown", spec));
}

TEST(RelayLinks, RefusesADuplicateOrNamelessTopicAndAnInvalidChange) {
  EXPECT_THROW(RelayLinks({{"rt/a", BernoulliLink{0.1}}, {"rt/a", BernoulliLink{0.2}}}, 1), std::invalid_argument);
  EXPECT_THROW(RelayLinks({{"", BernoulliLink{0.1}}}, 1), std::invalid_argument);
  RelayLinks links({{"rt/a", BernoulliLink{0.1}}}, 1);
  EXPECT_THROW(links.set_link("rt/a", LinkSpec(BernoulliLink{1.5})), std::invalid_argument);
  EXPECT_EQ(std::get<BernoulliLink>(links.reports().at(0).link.loss).loss, 0.1) << "nothing changed";
}

TEST(RelayLinks, ADelayedLinkHoldsDeliveredSamplesOnly) {
  LinkSpec spec(BernoulliLink{0.5});
  spec.delay = {20.0, 5.0, netkf::DelayDistribution::uniform};
  RelayLinks links({{"rt/a", spec}}, 9);
  for (int i = 0; i < 500; ++i) {
    const auto f = links.on_sample("rt/a");
    if (f->delivered) {
      EXPECT_GE(f->delay_ms, 15.0);
      EXPECT_LE(f->delay_ms, 25.0);
    } else {
      EXPECT_EQ(f->delay_ms, 0.0);
    }
  }
}

TEST(RelayLinks, ReportsLifetimeCountsTheRecentFitAndTheLastRequestAsAChannelLinkDoes) {
  RelayLinks links({{"rt/a", BernoulliLink{0.3}}}, 4);
  std::uint64_t dropped = 0;
  netkf::analysis::RecentArrivals independent;  // the channel's window, fed by hand from the fates
  for (int i = 0; i < 300; ++i) {
    const bool d = !links.on_sample("rt/a")->delivered;
    dropped += d ? 1 : 0;
    independent.record(d);
  }
  auto r = *links.report("rt/a");
  EXPECT_EQ(r.stats.samples(), 300u);
  EXPECT_EQ(r.stats.dropped(), dropped);
  EXPECT_EQ(r.lifetime.dropped(), dropped);
  EXPECT_EQ(r.next_sample, 300u);
  ASSERT_TRUE(r.recent_fit.has_value());
  EXPECT_EQ(r.recent_fit->samples, 300u);
  EXPECT_EQ(r.recent_fit->dropped, dropped);
  EXPECT_EQ(r.recent_fit->family, independent.fit()->family);
  EXPECT_EQ(r.last_request_id, 0u);

  ASSERT_TRUE(links.set_link("rt/a", LinkSpec(BernoulliLink{0.0})));
  links.note_request("rt/a", 77, "");
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(links.on_sample("rt/a")->delivered);
  r = *links.report("rt/a");
  EXPECT_EQ(r.stats.samples(), 10u) << "since the change";
  EXPECT_EQ(r.lifetime.samples(), 310u) << "not reset by a change";
  EXPECT_EQ(r.lifetime.dropped(), dropped);
  EXPECT_EQ(r.recent_fit->samples, 10u) << "the window restarts with the model";
  EXPECT_EQ(r.last_request_id, 77u);
  EXPECT_TRUE(r.reject_reason.empty());
  links.note_request("rt/a", 78, "bad key");
  EXPECT_EQ(links.report("rt/a")->reject_reason, "bad key");
  EXPECT_FALSE(links.report("rt/unknown").has_value());
}

TEST(RelayLinks, ATopicsLinkIdIsItsOwnStableNegativeId) {
  const int a = netkf::relay_topic_link_id("rt/chatter");
  EXPECT_EQ(a, netkf::relay_topic_link_id("rt/chatter"));
  EXPECT_NE(a, netkf::relay_topic_link_id("rt/scan"));
  for (const char* topic : {"rt/chatter", "rt/scan", "", "x"}) {
    const int id = netkf::relay_topic_link_id(topic);
    EXPECT_LE(id, -1000);
    EXPECT_TRUE(netkf::is_relay_topic_link_id(id));
  }
  EXPECT_FALSE(netkf::is_relay_topic_link_id(netkf::kControlLinkId));
  EXPECT_FALSE(netkf::is_relay_topic_link_id(netkf::kRelayTopicLinkId));
  EXPECT_FALSE(netkf::is_relay_topic_link_id(0));
}

}  // namespace
