// ChannelLinks: per-link seeded loss, runtime changes with validation, statistics.
// Expectations: binomial tolerance around the configured loss, and the Gilbert-Elliott
// closed forms (stationary loss p/(p+r) and mean burst 1/r for loss_good=0, loss_bad=1).
#include <gtest/gtest.h>

#include <cmath>

#include "netkf/nodes/channel_links.hpp"

namespace {

using netkf::nodes::ChannelLinks;

netkf::Scenario links_scenario() {
  netkf::Scenario s;
  s.name = "unit-links";
  s.seed = 1234;
  s.plant.A = netkf::Matrix::Identity(1, 1);
  s.plant.Q = netkf::Matrix::Identity(1, 1);
  for (int id : {1, 2, 3}) {
    netkf::SensorSpec sp;
    sp.id = id;
    sp.C = netkf::Matrix::Identity(1, 1);
    sp.R = netkf::Matrix::Identity(1, 1);
    sp.link = netkf::BernoulliLink{0.3};
    s.sensors.push_back(sp);
  }
  s.sensors[2].link = netkf::GilbertElliottLink{0.05, 0.5, 0.0, 1.0};
  return s;
}

TEST(ChannelLogic, BernoulliLossWithinBinomialTolerance) {
  ChannelLinks links(links_scenario());
  const int n = 20000;
  int dropped = 0;
  for (int i = 0; i < n; ++i) dropped += links.on_sample(1) == ChannelLinks::Verdict::dropped;
  const double sigma = std::sqrt(0.3 * 0.7 / n);
  EXPECT_NEAR(dropped / double(n), 0.3, 4 * sigma);
  const auto* r = links.report(1);
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->stats.samples(), static_cast<std::uint64_t>(n));
  EXPECT_EQ(r->stats.dropped(), static_cast<std::uint64_t>(dropped));
}

TEST(ChannelLogic, GilbertElliottMatchesTheory) {
  ChannelLinks links(links_scenario());
  const int n = 100000;
  for (int i = 0; i < n; ++i) links.on_sample(3);
  const auto* r = links.report(3);
  const double p = 0.05, rr = 0.5;
  EXPECT_NEAR(r->stats.observed_loss(), p / (p + rr), 0.01);
  EXPECT_NEAR(r->stats.mean_burst_length(), 1.0 / rr, 0.1);
}

TEST(ChannelLogic, SeededPerLinkAndReproducible) {
  ChannelLinks a(links_scenario()), b(links_scenario());
  int same_link_differs = 0, other_link_differs = 0;
  for (int i = 0; i < 1000; ++i) {
    const auto va = a.on_sample(1);
    same_link_differs += va != b.on_sample(1);
    other_link_differs += va != a.on_sample(2);
  }
  EXPECT_EQ(same_link_differs, 0);
  EXPECT_GT(other_link_differs, 100);  // links 1 and 2 draw from different streams
}

TEST(ChannelLogic, ChangeAppliesFromTheNextSampleAndResetsStatistics) {
  ChannelLinks links(links_scenario());
  for (int i = 0; i < 50; ++i) links.on_sample(2);
  auto res = links.apply(7, 2, netkf::BernoulliLink{1.0});
  EXPECT_TRUE(res.applied);
  EXPECT_TRUE(res.reason.empty());
  for (int i = 0; i < 100; ++i) EXPECT_EQ(links.on_sample(2), ChannelLinks::Verdict::dropped);
  const auto* r = links.report(2);
  EXPECT_EQ(r->stats.samples(), 100u);
  EXPECT_EQ(r->last_request_id, 7u);
  EXPECT_FALSE(r->last_request_rejected);
  EXPECT_EQ(std::get<netkf::BernoulliLink>(r->model).loss, 1.0);
  links.apply(8, 2, netkf::BernoulliLink{0.0});
  for (int i = 0; i < 100; ++i) EXPECT_EQ(links.on_sample(2), ChannelLinks::Verdict::delivered);
}

TEST(ChannelLogic, BadRequestsChangeNothing) {
  ChannelLinks links(links_scenario());
  auto res = links.apply(3, 1, netkf::BernoulliLink{1.5});
  EXPECT_FALSE(res.applied);
  EXPECT_NE(res.reason.find("loss"), std::string::npos) << res.reason;
  const auto* r = links.report(1);
  EXPECT_EQ(std::get<netkf::BernoulliLink>(r->model).loss, 0.3);
  EXPECT_TRUE(r->last_request_rejected);
  EXPECT_EQ(r->last_request_id, 3u);

  auto unknown = links.apply(4, 42, netkf::BernoulliLink{0.1});
  EXPECT_FALSE(unknown.applied);
  EXPECT_NE(unknown.reason.find("unknown sensor"), std::string::npos);

  EXPECT_EQ(links.on_sample(42), ChannelLinks::Verdict::unknown_sensor);
  EXPECT_EQ(links.unknown_sensor_samples(), 1u);
  EXPECT_EQ(links.reports().size(), 3u);
}

}  // namespace
