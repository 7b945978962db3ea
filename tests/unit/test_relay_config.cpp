// A `netkf relay` file (netkf/relay_config.hpp, docs/relay.md): what it reads, and each mistake
// named at its line and column, as the scenario loader names a scenario's.
#include <gtest/gtest.h>

#include <string>

#include "netkf/relay_config.hpp"
#include "netkf/scenario.hpp"

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
