// A `netkf relay` file (netkf/relay/relay_config.hpp, docs/relay.md): what it reads, and each mistake
// named at its line and column, as the scenario loader names a scenario's.
#include <gtest/gtest.h>

#include <string>

#include "netkf/links/link_keys.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/relay/relay_config.hpp"

namespace {

using netkf::parse_relay_config;

std::string error_of(const std::string& text) {
  try {
    parse_relay_config(text, "relay.yaml");
  } catch (const netkf::ScenarioError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(RelayConfig, ReadsTheDomainsAndALinkPerTopic) {
  const auto c = parse_relay_config(R"(relay:
  from_domain: 3
  to_domain: 4
  seed: 99
  depth: 250
  topics:
    - name: rt/scan
      type: sensor_msgs::msg::dds_::LaserScan_
      link: { model: gilbert_elliott, p: 0.05, r: 0.25 }
    - name: rt/odom
      link: { model: bernoulli, loss: 0.1, delay_ms: 5, jitter_ms: 2 }
)",
                                    "relay.yaml");
  EXPECT_EQ(c.from_domain, 3);
  EXPECT_EQ(c.to_domain, 4);
  EXPECT_EQ(c.seed, 99u);
  EXPECT_EQ(c.depth, 250);
  ASSERT_EQ(c.topics.size(), 2u);
  EXPECT_EQ(c.topics[0].name, "rt/scan");
  EXPECT_EQ(c.topics[0].type, "sensor_msgs::msg::dds_::LaserScan_");
  const auto& ge = std::get<netkf::GilbertElliottLink>(c.topics[0].link.loss);
  EXPECT_EQ(ge.p, 0.05);
  EXPECT_EQ(ge.r, 0.25);
  EXPECT_FALSE(c.topics[1].type);
  EXPECT_EQ(std::get<netkf::BernoulliLink>(c.topics[1].link.loss).loss, 0.1);
  EXPECT_EQ(c.topics[1].link.delay.delay_ms, 5.0);
  EXPECT_EQ(c.topics[1].link.delay.jitter_ms, 2.0);
}

TEST(RelayConfig, DefaultsSeedAndDepth) {
  const auto c = parse_relay_config("relay: {from_domain: 1, to_domain: 2, topics: [{name: a, link: {model: bernoulli, "
                                    "loss: 0}}]}",
                                    "relay.yaml");
  EXPECT_EQ(c.seed, 1u);
  EXPECT_EQ(c.depth, 100);
}

TEST(RelayConfig, NamesEachMistakeWhereItIs) {
  EXPECT_EQ(error_of(""), "relay.yaml: a relay file is a mapping with 'relay:' (from_domain, to_domain, topics), got nothing");
  EXPECT_NE(error_of("relay:\n  from_domain: 1\n  to_domain: 1\n  topics: [{name: a, link: {model: bernoulli, loss: 0}}]\n")
                .find("relay.yaml:3:3: relay.to_domain must differ from relay.from_domain"),
            std::string::npos);
  EXPECT_NE(error_of("relay:\n  from_domain: 1\n  to_domain: 2\n  topic: []\n").find("relay.yaml:4:3: unknown key 'topic' in relay"),
            std::string::npos);
  EXPECT_NE(error_of("relay:\n  from_domain: 300\n  to_domain: 2\n  topics: []\n")
                .find("relay.yaml:2:3: relay.from_domain must be a DDS domain id in [0, 232], got 300"),
            std::string::npos);
  EXPECT_NE(error_of("relay:\n  from_domain: 1\n  to_domain: 2\n  topics: []\n").find("relay.topics must be a non-empty list"),
            std::string::npos);
  const std::string twice = error_of(
      "relay:\n  from_domain: 1\n  to_domain: 2\n  topics:\n    - {name: a, link: {model: bernoulli, loss: 0}}\n"
      "    - {name: a, link: {model: bernoulli, loss: 0.5}}\n");
  EXPECT_NE(twice.find("relay.yaml:6:"), std::string::npos) << twice;
  EXPECT_NE(twice.find("topic a is relayed twice (also relay.topics[0])"), std::string::npos) << twice;
  const std::string bad_loss = error_of(
      "relay:\n  from_domain: 1\n  to_domain: 2\n  topics:\n    - name: a\n      link:\n        model: bernoulli\n"
      "        loss: 1.5\n");
  EXPECT_NE(bad_loss.find("relay.yaml:8:"), std::string::npos) << bad_loss;
  EXPECT_NE(bad_loss.find("relay.topics[0].link.loss"), std::string::npos) << bad_loss;
  EXPECT_NE(error_of("relay:\n  from_domain: 1\n  to_domain: 2\n  topics:\n    - name: a\n").find(
                "missing required key 'relay.topics[0].link'"),
            std::string::npos);
}


// ---- events: the relay's timeline, and a journal to replay ---------------------------------

const char* kTwoTopics = R"(relay:
  from_domain: 1
  to_domain: 2
  topics:
    - name: rt/scan
      link: { model: gilbert_elliott, p: 0.05, r: 0.25 }
    - name: rt/odom
      link: { model: bernoulli, loss: 0.1 }
)";

TEST(RelayEvents, ReadsSetsAndRampsBesideTheRelay) {
  const auto c = parse_relay_config(std::string(kTwoTopics) + R"(events:
  - { at_sample: 200, topic: rt/odom, set: { loss: 1.0 } }
  - at_sample: 50
    topic: rt/scan
    ramp: { to: { p: 0.2 }, over_samples: 100 }
)",
                                    "relay.yaml");
  ASSERT_EQ(c.events.size(), 2u);
  EXPECT_EQ(c.events[0], (netkf::RelayEvent{200, "rt/odom", netkf::LinkEvent::Kind::set, {{"loss", 1.0}}, 0}));
  EXPECT_EQ(c.events[1], (netkf::RelayEvent{50, "rt/scan", netkf::LinkEvent::Kind::ramp, {{"p", 0.2}}, 100}));
  EXPECT_TRUE(parse_relay_config(kTwoTopics, "relay.yaml").events.empty());
}

TEST(RelayEvents, NamesEachMistakeWhereItIs) {
  const std::string base = kTwoTopics;  // 8 lines: `events:` is line 9, its first entry line 10
  const auto error = [&](const std::string& entry) { return error_of(base + "events:\n  - " + entry + "\n"); };
  const std::string unknown = error("{ at_sample: 1, topic: rt/imu, set: { loss: 1 } }");
  EXPECT_NE(unknown.find("relay.yaml:10:"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("events[0].topic: rt/imu is not relayed (the relay's topics: rt/scan, rt/odom)"),
            std::string::npos)
      << unknown;
  const std::string negative = error("{ at_sample: -3, topic: rt/odom, set: { loss: 1 } }");
  EXPECT_NE(negative.find("relay.yaml:10:18: events[0].at_sample: the event is before the topic's first sample (0), "
                          "got -3"),
            std::string::npos)
      << negative;
  const std::string key = error("{ at_sample: 1, topic: rt/odom, set: { los: 1 } }");
  EXPECT_NE(key.find("relay.yaml:10:"), std::string::npos) << key;
  EXPECT_NE(key.find("unknown key 'los' in events[0].set"), std::string::npos) << key;
  const std::string value = error_of(base + "events:\n  - at_sample: 1\n    topic: rt/odom\n    set:\n      loss: 1.5\n");
  EXPECT_NE(value.find("relay.yaml:13:7: events[0].set.loss must be a probability"), std::string::npos) << value;
  // A key of another model than the link has then: checked in the order the events apply.
  const std::string model = error("{ at_sample: 1, topic: rt/odom, set: { p: 0.5 } }");
  EXPECT_NE(model.find("relay.yaml:10:"), std::string::npos) << model;
  EXPECT_NE(model.find("events[0].set"), std::string::npos) << model;
  EXPECT_EQ(error_of(base + "events:\n  - { at_sample: 1, topic: rt/odom, set: { model: gilbert_elliott, p: 0.1, r: 0.5 } }\n"
                            "  - { at_sample: 2, topic: rt/odom, set: { p: 0.5 } }\n"),
            "(no error)")
      << "after the first event rt/odom is a Gilbert-Elliott link";
  const std::string seconds = error("{ at_s: 3, topic: rt/odom, set: { loss: 1 } }");
  EXPECT_NE(seconds.find("events[0].at_s: a relay's event names the topic's sample index, at_sample"),
            std::string::npos)
      << seconds;
  const std::string both = error("{ at_sample: 1, topic: rt/odom, set: { loss: 1 }, ramp: { to: { loss: 0 }, "
                                 "over_samples: 5 } }");
  EXPECT_NE(both.find("needs exactly one of set: { LINK KEYS } or ramp: { to: { LINK KEYS }, over_samples: N }"),
            std::string::npos)
      << both;
  const std::string word = error("{ at_sample: 1, topic: rt/odom, ramp: { to: { model: bernoulli }, over_samples: 5 } }");
  EXPECT_NE(word.find("a ramp moves numbers"), std::string::npos) << word;
  const std::string duration = error("{ at_sample: 1, topic: rt/odom, ramp: { to: { loss: 0.5 }, over_periods: 5 } }");
  EXPECT_NE(duration.find("unknown key 'over_periods' in events[0].ramp (expected one of: to, over_samples)"),
            std::string::npos)
      << duration;
}

TEST(RelayEvents, AJournalFileIsTheSameListAndWritesBackExactly) {
  const auto config = parse_relay_config(kTwoTopics, "relay.yaml");
  const std::vector<netkf::RelayEvent> events{
      {7, "rt/scan", netkf::LinkEvent::Kind::set, netkf::link_keys(netkf::LinkSpec(netkf::BernoulliLink{0.1 + 0.2})), 0},
      {9, "rt/odom", netkf::LinkEvent::Kind::ramp, {{"loss", 1.0 / 3.0}}, 40},
  };
  const std::string yaml = netkf::relay_events_to_yaml(events);
  EXPECT_EQ(netkf::parse_relay_events(yaml, config, "j.yaml"), events) << yaml;
  EXPECT_EQ(netkf::parse_relay_events("- { at_sample: 7, topic: rt/odom, set: { loss: 0 } }", config, "j.yaml").size(), 1u)
      << "the bare list too";
  EXPECT_TRUE(netkf::parse_relay_events(netkf::relay_events_to_yaml({}), config, "j.yaml").empty());
  try {
    netkf::parse_relay_events("", config, "j.yaml");
    ADD_FAILURE() << "an empty events file is refused";
  } catch (const netkf::ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find("j.yaml: the events file is empty"), std::string::npos) << e.what();
  }
  try {
    netkf::parse_relay_events("events:\n  - { at_sample: 1, topic: rt/x, set: { loss: 0 } }\n", config, "j.yaml");
    ADD_FAILURE() << "a topic the relay does not relay is refused";
  } catch (const netkf::ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find("j.yaml:2:"), std::string::npos) << e.what();
  }
}

TEST(RelayConfig, PerWriterIsATopicsOptionOffByDefault) {
  const auto c = parse_relay_config("relay:\n  from_domain: 1\n  to_domain: 2\n  topics:\n"
                                    "    - {name: rt/scan, per_writer: true, link: {model: bernoulli, loss: 0.1}}\n"
                                    "    - {name: rt/odom, link: {model: bernoulli, loss: 0}}\n",
                                    "relay.yaml");
  ASSERT_EQ(c.topics.size(), 2u);
  EXPECT_TRUE(c.topics[0].per_writer);
  EXPECT_FALSE(c.topics[1].per_writer);
  const std::string bad = error_of("relay:\n  from_domain: 1\n  to_domain: 2\n  topics:\n    - name: a\n"
                                   "      per_writer: maybe\n      link: {model: bernoulli, loss: 0}\n");
  EXPECT_NE(bad.find("relay.yaml:6:7: relay.topics[0].per_writer must be true or false"), std::string::npos) << bad;
}

}  // namespace
