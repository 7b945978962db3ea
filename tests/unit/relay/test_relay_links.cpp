// RelayLinks, the decisions of `netkf relay` (docs/relay.md). Expectations: a second, direct
// draw from the same seeded loss process (LinkLossProcess with derive_seed of the documented
// stream), the stationary loss and mean burst of the Gilbert-Elliott chain in closed form
// (π_B = p/(p+r), mean burst 1/r for the simple Gilbert channel), a trace's own rows.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "netkf/links/link_keys.hpp"
#include "netkf/links/link_trace.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/relay/relay_config.hpp"
#include "netkf/relay/relay_links.hpp"
#include "netkf/support/random.hpp"

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
  EXPECT_EQ(report.samples_in, static_cast<std::uint64_t>(n));
  const double expected_loss = p / (p + r);  // π_B
  // The chain's samples are correlated: allow 5 sd of the burst-inflated binomial spread.
  const double sd = std::sqrt(expected_loss * (1 - expected_loss) / n * (2.0 / r));
  EXPECT_NEAR(report.observed_loss, expected_loss, 5 * sd);
  EXPECT_NEAR(report.mean_burst_length, 1.0 / r, 0.1);
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
  EXPECT_EQ(links.reports().at(0).samples_in, expected.size()) << "a change restarts the statistics";
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
  netkf::fit::RecentArrivals independent;  // the channel's window, fed by hand from the fates
  for (int i = 0; i < 300; ++i) {
    const bool d = !links.on_sample("rt/a")->delivered;
    dropped += d ? 1 : 0;
    independent.record(d);
  }
  auto r = *links.report("rt/a");
  EXPECT_EQ(r.samples_in, 300u);
  EXPECT_EQ(r.dropped, dropped);
  EXPECT_EQ(r.dropped_total, dropped);
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
  EXPECT_EQ(r.samples_in, 10u) << "since the change";
  EXPECT_EQ(r.samples_total, 310u) << "not reset by a change";
  EXPECT_EQ(r.dropped_total, dropped);
  EXPECT_EQ(r.recent_fit->samples, 10u) << "the window restarts with the model";
  EXPECT_EQ(r.last_request_id, 77u);
  EXPECT_TRUE(r.rejection_reason.empty());
  links.note_request("rt/a", 78, "bad key");
  EXPECT_EQ(links.report("rt/a")->rejection_reason, "bad key");
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

// ---- the timeline, the journal and its replay --------------------------------------------

using netkf::LinkEvent;
using netkf::RelayEvent;
using netkf::RelayFate;

RelayEvent set_at(std::uint64_t n, const std::string& topic, netkf::LinkKeys keys) {
  return RelayEvent{n, topic, LinkEvent::Kind::set, std::move(keys), 0};
}

std::vector<RelayFate> fates(RelayLinks& links, const std::string& topic, int n) {
  std::vector<RelayFate> out;
  for (int i = 0; i < n; ++i) out.push_back(*links.on_sample(topic));
  return out;
}

void expect_same_fates(const std::vector<RelayFate>& a, const std::vector<RelayFate>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].index, b[i].index);
    EXPECT_EQ(a[i].delivered, b[i].delivered) << "sample " << i;
    EXPECT_EQ(a[i].delay_ms, b[i].delay_ms) << "sample " << i;
  }
}

TEST(RelayTimeline, ASetAppliesFromItsSampleOnAndIsJournaled) {
  // Expectation: the documented stream drawn directly for samples 0..199, then loss 1.
  RelayLinks links({{"rt/chatter", BernoulliLink{0.3}}}, 5, {set_at(200, "rt/chatter", {{"loss", 1.0}})});
  netkf::LinkLossProcess direct(BernoulliLink{0.3}, netkf::derive_seed(5, "relay-link", fnv1a("rt/chatter")));
  for (std::uint64_t i = 0; i < 400; ++i) {
    const auto f = links.on_sample("rt/chatter");
    if (i < 200) {
      EXPECT_EQ(f->delivered, !direct.next_dropped()) << "sample " << i;
      EXPECT_FALSE(links.has_changes()) << "nothing changed before sample 200";
    } else {
      EXPECT_FALSE(f->delivered) << "sample " << i;
    }
  }
  const auto changes = links.take_changes();
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].topic, "rt/chatter");
  EXPECT_EQ(changes[0].at_period, 200);
  EXPECT_EQ(changes[0].origin, netkf::LinkChange::Origin::timeline);
  EXPECT_EQ(changes[0].request_id, 0u);
  EXPECT_EQ(changes[0].link, LinkSpec(BernoulliLink{1.0}));
  ASSERT_TRUE(changes[0].replay);
  EXPECT_EQ(*changes[0].replay, set_at(200, "rt/chatter", netkf::link_keys(LinkSpec(BernoulliLink{1.0}))))
      << "the journal sets the whole link";
  EXPECT_EQ(links.report("rt/chatter")->samples_in, 200u) << "statistics restart at the change";
  EXPECT_EQ(links.report("rt/chatter")->samples_total, 400u);
  EXPECT_TRUE(links.take_changes().empty());
}

TEST(RelayTimeline, ALiveChangeIsJournaledAtTheTopicsNextSample) {
  RelayLinks links({{"rt/a", BernoulliLink{0.3}}, {"rt/b", BernoulliLink{0.3}}}, 5);
  fates(links, "rt/a", 17);
  fates(links, "rt/b", 4);
  ASSERT_TRUE(links.set_link("rt/a", LinkSpec(BernoulliLink{0.0}), 41));
  const auto changes = links.take_changes();
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].at_period, 17) << "rt/a's samples 0..16 went before it";
  EXPECT_EQ(changes[0].origin, netkf::LinkChange::Origin::request);
  EXPECT_EQ(changes[0].request_id, 41u);
  EXPECT_EQ(changes[0].replay->at_sample, 17u);
  EXPECT_EQ(fates(links, "rt/a", 1).at(0).index, 17u);
}

TEST(RelayTimeline, ARampMovesTheLinkOneStepPerSampleAndIsJournaledOnce) {
  RelayEvent ramp{100, "rt/a", LinkEvent::Kind::ramp, {{"loss", 1.0}}, 50};
  RelayLinks links({{"rt/a", BernoulliLink{0.0}}}, 2, {ramp});
  for (std::uint64_t i = 0; i < 200; ++i) {
    const auto f = links.on_sample("rt/a");
    const double loss = std::get<BernoulliLink>(links.report("rt/a")->link.loss).loss;
    // At sample n in [100, 150] the loss is (n − 100)/50, its value for that sample's draw.
    const double expected = i < 100 ? 0.0 : std::min(1.0, static_cast<double>(i - 100) / 50.0);
    EXPECT_DOUBLE_EQ(loss, expected) << "sample " << i;
    if (i < 100) {
      EXPECT_TRUE(f->delivered);
    } else if (i >= 150) {
      EXPECT_FALSE(f->delivered) << "sample " << i;
    }
  }
  const auto changes = links.take_changes();
  ASSERT_EQ(changes.size(), 2u) << "its start and its end";
  EXPECT_EQ(changes[0].at_period, 100);
  ASSERT_TRUE(changes[0].replay);
  EXPECT_EQ(*changes[0].replay, ramp) << "the journal holds the ramp as it started";
  EXPECT_EQ(changes[1].at_period, 150);
  EXPECT_FALSE(changes[1].replay) << "a replay reaches the ramp's end by itself";
  EXPECT_EQ(links.report("rt/a")->samples_in, 200u) << "a ramp does not restart the statistics (as a channel link)";
}

TEST(RelayTimeline, ATimelineEventThatNoLongerAppliesChangesNothing) {
  // A live change to Bernoulli makes the timeline's Gilbert-Elliott key p inapplicable.
  RelayLinks links({{"rt/a", GilbertElliottLink{0.1, 0.5, 0.0, 1.0}}}, 2, {set_at(10, "rt/a", {{"p", 0.2}})});
  fates(links, "rt/a", 5);
  links.set_link("rt/a", LinkSpec(BernoulliLink{0.25}));
  fates(links, "rt/a", 10);
  const auto changes = links.take_changes();
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[1].at_period, 10);
  EXPECT_FALSE(changes[1].failure.empty());
  EXPECT_FALSE(changes[1].replay);
  EXPECT_EQ(links.report("rt/a")->link, LinkSpec(BernoulliLink{0.25}));
}

TEST(RelayTimeline, RefusesAnEventOfATopicThatIsNotRelayed) {
  EXPECT_THROW(RelayLinks({{"rt/a", BernoulliLink{0.1}}}, 1, {set_at(0, "rt/b", {{"loss", 1.0}})}),
               std::invalid_argument);
}

// The reproducibility claim: a session's journal, written as YAML and read back as a relay's
// --events, replayed over the same number of samples with the same seed, makes the same
// decisions and delays sample for sample (the live changes' streams keep their state; the
// replay's sets do the same at the same samples).
TEST(RelayTimeline, TheJournalOfASessionReplaysItSampleForSample) {
  LinkSpec scan(GilbertElliottLink{0.05, 0.25, 0.0, 1.0});
  scan.delay = {10.0, 4.0, netkf::DelayDistribution::normal};
  const std::vector<netkf::RelayTopic> topics{{"rt/scan", scan}, {"rt/odom", BernoulliLink{0.2}}};
  const std::vector<RelayEvent> timeline{
      set_at(300, "rt/scan", {{"mean_burst", 4.0}, {"loss", 0.4}}),
      RelayEvent{200, "rt/odom", LinkEvent::Kind::ramp, {{"loss", 0.9}}, 200},
  };
  RelayLinks session(topics, 11, timeline);
  std::vector<RelayFate> scan_fates, odom_fates;
  std::vector<RelayEvent> journal;
  auto take = [&] {
    for (const auto& c : session.take_changes())
      if (c.replay) journal.push_back(*c.replay);
  };
  for (int i = 0; i < 1200; ++i) {
    // Live changes between samples, as ctl and the dashboard make them.
    if (i == 150) session.set_link("rt/scan", netkf::apply_link_keys(*session.link("rt/scan"), {{"jitter_ms", 9.0}}), 7);
    // rt/odom's sample 350: in the middle of its ramp (samples 200..400), which it ends.
    if (i == 700) session.set_link("rt/odom", LinkSpec(GilbertElliottLink{0.3, 0.3, 0.1, 0.9}), 8);
    if (i == 900) session.set_link("rt/scan", LinkSpec(BernoulliLink{0.5}), 0);
    scan_fates.push_back(*session.on_sample("rt/scan"));
    if (i % 2 == 0) odom_fates.push_back(*session.on_sample("rt/odom"));
    take();
  }
  ASSERT_EQ(journal.size(), 5u) << "three live changes, the timeline's set and its ramp";

  netkf::RelayConfig config;
  config.topics = topics;
  const auto replayed = netkf::parse_relay_events(netkf::relay_events_to_yaml(journal), config, "journal.yaml");
  EXPECT_EQ(replayed, journal) << "the journal's YAML reads back exactly";
  RelayLinks replay(topics, 11, replayed);
  std::vector<RelayFate> scan_again, odom_again;
  for (int i = 0; i < 1200; ++i) {
    scan_again.push_back(*replay.on_sample("rt/scan"));
    if (i % 2 == 0) odom_again.push_back(*replay.on_sample("rt/odom"));
  }
  expect_same_fates(scan_fates, scan_again);
  expect_same_fates(odom_fates, odom_again);
  // And the decisions did change: without the journal the same seed decides otherwise.
  RelayLinks plain(topics, 11);
  std::size_t differ = 0;
  for (int i = 0; i < 1200; ++i) differ += plain.on_sample("rt/scan")->delivered != scan_fates[i].delivered;
  EXPECT_GT(differ, 0u);
}

// Per-writer links (RelayTopic::per_writer): each writer's link is added at run time under the
// name topic@writer, its streams derived from that name as a topic's are from the topic's.
netkf::RelayTopic per_writer(const std::string& topic, LinkSpec link) {
  return {topic, std::move(link), std::nullopt, true};
}

std::vector<bool> delivered_by(RelayLinks& links, const std::string& name, int n) {
  std::vector<bool> out;
  for (int i = 0; i < n; ++i) {
    const auto fate = links.on_sample(name);
    EXPECT_TRUE(fate) << name;
    if (!fate) break;
    EXPECT_EQ(fate->index, static_cast<std::uint64_t>(i)) << name << ": its own sample numbers from 0";
    out.push_back(fate->delivered);
  }
  return out;
}

TEST(RelayLinks, AWritersLinkDrawsFromTheStreamOfItsName) {
  RelayLinks links({per_writer("rt/scan", BernoulliLink{0.3})}, 42);
  EXPECT_TRUE(links.per_writer("rt/scan"));
  EXPECT_FALSE(links.on_sample("rt/scan")) << "a per-writer topic has no link of its own";
  EXPECT_TRUE(links.reports().empty()) << "nor a report before a writer is added";
  EXPECT_EQ(links.add_writer_link("rt/scan", "robot1"), "rt/scan@robot1");
  EXPECT_EQ(links.add_writer_link("rt/scan", "robot2"), "rt/scan@robot2");
  netkf::LinkLossProcess robot1(BernoulliLink{0.3}, netkf::derive_seed(42, "relay-link", fnv1a("rt/scan@robot1")));
  netkf::LinkLossProcess robot2(BernoulliLink{0.3}, netkf::derive_seed(42, "relay-link", fnv1a("rt/scan@robot2")));
  const int n = 4000;
  int agree = 0;
  for (int i = 0; i < n; ++i) {
    const auto a = links.on_sample("rt/scan@robot1");
    const auto b = links.on_sample("rt/scan@robot2");
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->delivered, !robot1.next_dropped()) << "robot1 sample " << i;
    EXPECT_EQ(b->delivered, !robot2.next_dropped()) << "robot2 sample " << i;
    agree += a->delivered == b->delivered;
  }
  // Independent streams agree with probability p² + (1-p)² = 0.58 (identical ones always).
  const double p_agree = 0.3 * 0.3 + 0.7 * 0.7, sd = std::sqrt(p_agree * (1 - p_agree) / n);
  EXPECT_NEAR(agree / static_cast<double>(n), p_agree, 5 * sd);
  const auto reports = links.reports();
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[0].topic, "rt/scan@robot1");
  EXPECT_EQ(reports[0].samples_in, static_cast<std::uint64_t>(n));
  EXPECT_EQ(links.writer_links("rt/scan"), (std::vector<std::string>{"rt/scan@robot1", "rt/scan@robot2"}));
}

TEST(RelayLinks, AWritersDecisionsDoNotDependOnOtherWritersOrTheOrderTheyCame) {
  RelayLinks first({per_writer("rt/scan", BernoulliLink{0.4})}, 9);
  RelayLinks second({per_writer("rt/scan", BernoulliLink{0.4})}, 9);
  first.add_writer_link("rt/scan", "robot1");
  const auto alone = delivered_by(first, "rt/scan@robot1", 500);
  second.add_writer_link("rt/scan", "robot2");  // another writer first, and its traffic
  delivered_by(second, "rt/scan@robot2", 123);
  second.add_writer_link("rt/scan", "robot1");
  EXPECT_EQ(delivered_by(second, "rt/scan@robot1", 500), alone);
  RelayLinks other_seed({per_writer("rt/scan", BernoulliLink{0.4})}, 10);
  other_seed.add_writer_link("rt/scan", "robot1");
  EXPECT_NE(delivered_by(other_seed, "rt/scan@robot1", 500), alone) << "the relay's seed is part of the stream";
}

TEST(RelayLinks, AddsWritersLinksOnlyToPerWriterTopicsOnceEach) {
  RelayLinks links({per_writer("rt/scan", BernoulliLink{0.1}), {"rt/odom", BernoulliLink{0.1}},
                    {"rt/scan@robot9", BernoulliLink{0.1}}},
                   1);
  EXPECT_EQ(links.add_writer_link("rt/scan", "robot1"), "rt/scan@robot1");
  links.on_sample("rt/scan@robot1");
  EXPECT_EQ(links.add_writer_link("rt/scan", "robot1"), "rt/scan@robot1") << "the existing link";
  EXPECT_EQ(links.report("rt/scan@robot1")->next_sample, 1u) << "kept, not restarted";
  EXPECT_EQ(links.writer_links("rt/scan").size(), 1u);
  EXPECT_FALSE(links.add_writer_link("rt/odom", "robot1")) << "rt/odom has one link for all writers";
  EXPECT_FALSE(links.add_writer_link("rt/unknown", "robot1"));
  EXPECT_FALSE(links.per_writer("rt/odom"));
  EXPECT_THROW(links.add_writer_link("rt/scan", ""), std::invalid_argument);
  EXPECT_THROW(links.add_writer_link("rt/scan", "robot9"), std::invalid_argument) << "a topic's name";
}

TEST(RelayLinks, AWritersChangeIsItsOwnATopicsChangeIsEveryWritersAndTheirsToCome) {
  RelayLinks links({per_writer("rt/scan", BernoulliLink{0.3})}, 5);
  links.add_writer_link("rt/scan", "robot1");
  links.add_writer_link("rt/scan", "robot2");
  netkf::LinkLossProcess robot2(BernoulliLink{0.3}, netkf::derive_seed(5, "relay-link", fnv1a("rt/scan@robot2")));
  delivered_by(links, "rt/scan@robot1", 10);
  ASSERT_TRUE(links.set_link("rt/scan@robot1", BernoulliLink{1.0}));
  links.note_request("rt/scan@robot1", 17, "");
  for (int i = 0; i < 200; ++i) {
    EXPECT_FALSE(links.on_sample("rt/scan@robot1")->delivered) << "robot1 at loss 1";
    EXPECT_EQ(links.on_sample("rt/scan@robot2")->delivered, !robot2.next_dropped()) << "robot2 untouched, sample " << i;
  }
  EXPECT_EQ(links.report("rt/scan@robot2")->last_request_id, 0u);
  EXPECT_EQ(std::get<BernoulliLink>(links.link("rt/scan")->loss).loss, 0.3) << "the topic's model is unchanged";
  EXPECT_THROW(links.set_link("rt/scan", BernoulliLink{1.5}), netkf::LinkError);
  EXPECT_EQ(std::get<BernoulliLink>(links.link("rt/scan@robot2")->loss).loss, 0.3)
      << "an invalid change changes nothing";
  ASSERT_TRUE(links.set_link("rt/scan", BernoulliLink{0.0}));
  links.note_request("rt/scan", 18, "");
  links.add_writer_link("rt/scan", "robot3");  // after the change: a copy of the topic's current link
  for (const std::string name : {"rt/scan@robot1", "rt/scan@robot2", "rt/scan@robot3"}) {
    for (int i = 0; i < 50; ++i) EXPECT_TRUE(links.on_sample(name)->delivered) << name << " at loss 0";
    const auto report = links.report(name);
    EXPECT_EQ(report->samples_in, 50u) << name << ": statistics since the change";
    if (name != "rt/scan@robot3") {
      EXPECT_EQ(report->last_request_id, 18u) << name;
    }
  }
  EXPECT_EQ(links.report("rt/scan@robot1")->samples_total, 260u);
  EXPECT_FALSE(links.report("rt/scan")) << "the topic's model is not a link";
}

// A per-writer topic's timeline applies to each writer's link at that writer's own samples; a
// writer's link made after a live change of its topic is journaled at its sample 0; the
// journal (writers' links by name, through its YAML) replays every writer's fates, whatever
// order the writers come in.
TEST(RelayTimeline, APerWriterSessionReplaysFromItsJournal) {
  const std::vector<netkf::RelayTopic> topics{per_writer("rt/scan", BernoulliLink{0.3})};
  RelayLinks session(topics, 5, {set_at(10, "rt/scan", {{"loss", 0.8}})});
  std::vector<RelayEvent> journal;
  std::vector<netkf::RelayLinkChange> entries;
  auto take = [&] {
    for (auto& c : session.take_changes()) {
      if (c.replay) journal.push_back(*c.replay);
      entries.push_back(std::move(c));
    }
  };
  std::map<std::string, std::vector<RelayFate>> fates;
  ASSERT_EQ(session.add_writer_link("rt/scan", "robot1"), "rt/scan@robot1");
  for (int i = 0; i < 30; ++i) fates["rt/scan@robot1"].push_back(*session.on_sample("rt/scan@robot1"));
  take();
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ((std::pair{entries[0].topic, entries[0].at_period}), (std::pair{std::string("rt/scan@robot1"), std::int64_t{10}}))
      << "the topic's event, at robot1's sample 10";
  session.set_link("rt/scan", LinkSpec(BernoulliLink{0.1}), 4);  // every writer's, and those to come
  session.add_writer_link("rt/scan", "robot2");
  take();
  ASSERT_EQ(entries.size(), 3u) << "robot1's change, and robot2's link at its sample 0";
  EXPECT_EQ(entries[1].topic, "rt/scan@robot1");
  EXPECT_EQ(entries[1].at_period, 30);
  EXPECT_EQ((std::tuple{entries[2].topic, entries[2].at_period, entries[2].origin}),
            (std::tuple{std::string("rt/scan@robot2"), std::int64_t{0}, netkf::LinkChange::Origin::request}));
  for (int i = 0; i < 40; ++i)
    for (const char* w : {"rt/scan@robot1", "rt/scan@robot2"}) fates[w].push_back(*session.on_sample(w));
  take();
  EXPECT_EQ(entries.back().topic, "rt/scan@robot2") << "the topic's event at robot2's own sample 10";
  EXPECT_EQ(entries.back().at_period, 10);

  // Replayed (--events replaces the file's timeline), the writers coming in the other order.
  netkf::RelayConfig config;
  config.topics = topics;
  const auto replayed = netkf::parse_relay_events(netkf::relay_events_to_yaml(journal), config, "journal.yaml");
  EXPECT_EQ(replayed, journal) << "writers' links by name read back";
  RelayLinks replay(topics, 5, replayed);
  replay.add_writer_link("rt/scan", "robot2");
  replay.add_writer_link("rt/scan", "robot1");
  std::map<std::string, std::vector<RelayFate>> again;
  for (int i = 0; i < 30; ++i) again["rt/scan@robot1"].push_back(*replay.on_sample("rt/scan@robot1"));
  for (int i = 0; i < 40; ++i)
    for (const char* w : {"rt/scan@robot2", "rt/scan@robot1"}) again[w].push_back(*replay.on_sample(w));
  expect_same_fates(fates["rt/scan@robot1"], again["rt/scan@robot1"]);
  expect_same_fates(fates["rt/scan@robot2"], again["rt/scan@robot2"]);
  // A writer's link of a topic that is not per writer is not relayed.
  EXPECT_THROW(RelayLinks(topics, 5, {set_at(1, "rt/odom@robot1", {{"loss", 0.5}})}), std::invalid_argument);
}

}  // namespace
