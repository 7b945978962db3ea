// netkf sweep's logic (cli/sweep/): key paths, the grid, run seeds, aggregation, the files and
// --resume, and the offline run against independent expectations.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <yaml-cpp/yaml.h>

#include "sha256.hpp"
#include "netkf/cli/sweep/sweep.hpp"
#include "sweep_runs.hpp"
#include "netkf/cli/sweep/sweep_spec.hpp"
#include "sweep_table.hpp"
#include "test_paths.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/support/random.hpp"

namespace netkf::cli::sweep {
namespace {

namespace fs = std::filesystem;

const char* kScenario = R"(
name: t
period_ms: 10
seed: 7
plant:
  A: [[1.1, 0.1], [0.0, 0.9]]
  Q: [[0.1, 0.0], [0.0, 0.1]]
sensors:
  - id: 5
    C: [[1.0, 0.0]]
    R: [[0.5]]
    link: { model: bernoulli, loss: 0.2 }
  - id: 2
    C: [[0.0, 1.0]]
    R: [[1.0]]
    link: { model: bernoulli, loss: 0.3 }
)";

TEST(SweepKeys, SensorSegmentIsTheSensorIdNotTheListIndex) {
  YAML::Node tree = YAML::Load(kScenario);
  apply_key(tree, "sensors.2.link.loss", "0.6");
  EXPECT_EQ(tree["sensors"][1]["link"]["loss"].as<double>(), 0.6);  // id 2 is the second entry
  EXPECT_EQ(tree["sensors"][0]["link"]["loss"].as<double>(), 0.2);
  const Scenario s = parse_scenario(YAML::Dump(tree), "t");
  EXPECT_DOUBLE_EQ(std::get<BernoulliLink>(s.sensors[1].link.loss).loss, 0.6);
}

TEST(SweepKeys, WildcardListIndexesAndNewMappingKeys) {
  YAML::Node tree = YAML::Load(kScenario);
  apply_key(tree, "sensors.*.link.loss", "0.45");
  apply_key(tree, "plant.A.0.1", "0.25");
  apply_key(tree, "estimator.deadline_ms", "6");
  const Scenario s = parse_scenario(YAML::Dump(tree), "t");
  EXPECT_DOUBLE_EQ(std::get<BernoulliLink>(s.sensors[0].link.loss).loss, 0.45);
  EXPECT_DOUBLE_EQ(std::get<BernoulliLink>(s.sensors[1].link.loss).loss, 0.45);
  EXPECT_DOUBLE_EQ(s.plant.A(0, 1), 0.25);
  EXPECT_DOUBLE_EQ(s.deadline_ms(), 6.0);
}

TEST(SweepKeys, BadPathsSayWhichKeyAndWhy) {
  YAML::Node tree = YAML::Load(kScenario);
  auto message = [&](const std::string& key) {
    try {
      apply_key(tree, key, "1");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("sensors.9.link.loss").find("no sensor with id 9"), std::string::npos);
  EXPECT_NE(message("plant.A.2.0").find("not an index"), std::string::npos);
  EXPECT_NE(message("period_ms.x").find("is a value"), std::string::npos);
  EXPECT_NE(message("plant.A").find("not a value"), std::string::npos);
}

TEST(SweepGrid, ParsesListsAndRanges) {
  const Vary list = parse_vary("sensors.2.link.loss=0.1,0.5,0.9");
  EXPECT_EQ(list.key, "sensors.2.link.loss");
  EXPECT_EQ(list.values, (std::vector<std::string>{"0.1", "0.5", "0.9"}));
  const Vary range = parse_vary("plant.A.0.0=1:2:5");
  EXPECT_EQ(range.values, (std::vector<std::string>{"1", "1.25", "1.5", "1.75", "2"}));
  EXPECT_THROW(parse_vary("nokey"), std::invalid_argument);
  EXPECT_THROW(parse_vary("=1,2"), std::invalid_argument);
  EXPECT_THROW(parse_vary("a=1,,2"), std::invalid_argument);
  EXPECT_THROW(parse_vary("a=0:1:0"), std::invalid_argument);
  EXPECT_THROW(parse_vary("a=0:x:3"), std::invalid_argument);
}

TEST(SweepGrid, IsTheProductWithTheLastKeyFastest) {
  const auto grid = expand_grid({{"a", {"1", "2"}}, {"b", {"x", "y", "z"}}});
  ASSERT_EQ(grid.size(), 6u);
  EXPECT_EQ(grid[0].values, (std::vector<std::string>{"1", "x"}));
  EXPECT_EQ(grid[2].values, (std::vector<std::string>{"1", "z"}));
  EXPECT_EQ(grid[3].values, (std::vector<std::string>{"2", "x"}));
  EXPECT_EQ(grid[5].index, 5);
  EXPECT_EQ(expand_grid({}).size(), 1u);
  EXPECT_THROW(expand_grid({{"a", {"1"}}, {"a", {"2"}}}), std::invalid_argument);
}

TEST(SweepGrid, MoreThanTheMostRunsIsRefusedWithItsCount) {
  const Vary thousand = parse_vary("a=0:1:1000");
  Vary other = thousand;
  other.key = "b";
  try {
    check_grid_size({thousand, other}, 1);
    ADD_FAILURE() << "10^6 runs accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("1000 x 1000 = 1000000 points x 1 seeds = 1000000 runs"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("at most 100000"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(check_grid_size({thousand, parse_vary("b=0:1:100")}, 1));  // exactly the limit
  EXPECT_THROW(check_grid_size({thousand, parse_vary("b=0:1:100")}, 2), std::invalid_argument);
  EXPECT_NO_THROW(check_grid_size({}, 100000));
  EXPECT_THROW(check_grid_size({}, 100001), std::invalid_argument);
  // Axes whose product overflows 64 bits are refused, not wrapped round to a small number.
  const Vary big = parse_vary("c=0:1:100000");
  std::vector<Vary> many;
  for (int i = 0; i < 5; ++i) {
    many.push_back(big);
    many.back().key = "k" + std::to_string(i);
  }
  EXPECT_THROW(check_grid_size(many, 1), std::invalid_argument);
}

TEST(SweepSeeds, DependOnSeedIndexNotOnThePointAndRepeat) {
  const YAML::Node tree = YAML::Load(kScenario);
  const std::vector<Vary> vary{{"sensors.2.link.loss", {"0.1", "0.7"}}};
  const auto grid = expand_grid(vary);
  auto seed_of = [&](int point, int index) {
    return parse_scenario(run_scenario_yaml(tree, vary, grid[static_cast<std::size_t>(point)], index), "t").seed;
  };
  EXPECT_EQ(seed_of(0, 1), seed_of(1, 1));  // common random numbers across points
  EXPECT_NE(seed_of(0, 1), seed_of(0, 2));
  EXPECT_NE(seed_of(0, 1), 7u);              // not the scenario's own seed
  EXPECT_EQ(seed_of(0, 3), seed_of(0, 3));
  // A different scenario seed gives different run seeds.
  EXPECT_NE(run_seed(7, 1), run_seed(8, 1));
}

TEST(SweepAggregate, MeanStandardErrorMinMaxByHand) {
  // {1, 2, 4}: mean 7/3; sample variance ((4/3)² + (1/3)² + (5/3)²)/2 = 7/3; se = √(7/3 / 3) = √7 / 3.
  const Stats s = aggregate({1.0, std::nullopt, 2.0, 4.0});
  EXPECT_EQ(s.n, 3);
  EXPECT_NEAR(*s.mean, 7.0 / 3.0, 1e-15);
  EXPECT_NEAR(*s.se, std::sqrt(7.0) / 3.0, 1e-15);
  EXPECT_EQ(*s.min, 1.0);
  EXPECT_EQ(*s.max, 4.0);
  const Stats one = aggregate({3.5});
  EXPECT_EQ(*one.mean, 3.5);
  EXPECT_FALSE(one.se.has_value());
  EXPECT_FALSE(aggregate({std::nullopt}).mean.has_value());
}

TEST(SweepFiles, RunsCsvRoundTripsAndResumeSkipsOnlyOkRuns) {
  const std::vector<Vary> vary{{"k", {"0.1", "0.2"}}};
  const auto grid = expand_grid(vary);
  const std::vector<std::string> q{"periods", "rms_error"};
  std::ostringstream out;
  out << runs_header(vary, q) << "\n";
  out << runs_line({0, 1, true, {100.0, 0.123456789012345678}}, grid[0]) << "\n";
  out << runs_line({0, 2, false, {std::nullopt, std::nullopt}}, grid[0]) << "\n";
  out << runs_line({1, 1, true, {100.0, std::nullopt}}, grid[1]) << "\n";
  out << "1,2,0.2,ok,10";  // cut by a kill mid-line
  EXPECT_EQ(out.str().substr(0, out.str().find('\n')), "point,seed,k,status,periods,rms_error");
  std::istringstream in(out.str());
  const auto rows = read_runs_csv(in, vary, q);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(*rows[0].values[1], 0.123456789012345678);  // 17 digits round-trip
  EXPECT_FALSE(rows[2].values[1].has_value());
  EXPECT_EQ(done_runs(rows), (std::set<std::pair<int, int>>{{0, 1}, {1, 1}}));
  std::istringstream other("point,seed,j,status,periods,rms_error\n");
  EXPECT_THROW(read_runs_csv(other, vary, q), std::runtime_error);
}

TEST(SweepHash, Sha256KnownVectors) {
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

// With no loss the filter's P_{k|k} follows the ordinary Riccati recursion: the offline run's
// mean Tr P_{k|k} is that recursion's mean, computed here by hand; every sample is fused.
TEST(SweepOffline, LosslessRunFollowsTheRiccatiRecursion) {
  YAML::Node tree = YAML::Load(kScenario);
  apply_key(tree, "sensors.*.link.loss", "0");
  const Scenario s = parse_scenario(YAML::Dump(tree), "t");
  const int periods = 400;
  const RunSummary r = offline_summary(s, periods);
  Matrix P = Matrix::Identity(2, 2);  // P0
  Matrix C(2, 2);
  C << 1, 0, 0, 1;
  Matrix R = Matrix::Zero(2, 2);
  R(0, 0) = 0.5;
  R(1, 1) = 1.0;
  double sum = 0.0;
  for (int k = 0; k < periods; ++k) {
    const Matrix K = P * C.transpose() * (C * P * C.transpose() + R).inverse();
    const Matrix Pf = (Matrix::Identity(2, 2) - K * C) * P;
    sum += Pf.trace();
    P = s.plant.A * Pf * s.plant.A.transpose() + s.plant.Q;
  }
  EXPECT_NEAR(r.sum_trace_P / periods, sum / periods, 1e-9);
  EXPECT_EQ(r.periods, 400u);
  EXPECT_EQ(r.fused, 800u);
  EXPECT_EQ(r.links[0].dropped, 0u);
}

// Link 2's drops over many periods: the observed loss within 5 standard errors of its loss.
TEST(SweepOffline, ObservedLossMatchesTheLinkAndRerunsAreIdentical) {
  const Scenario s = parse_scenario(kScenario, "t");
  const int periods = 20000;
  const RunSummary a = offline_summary(s, periods);
  const double loss = static_cast<double>(a.links[1].dropped) / periods;
  EXPECT_NEAR(loss, 0.3, 5 * std::sqrt(0.3 * 0.7 / periods));
  EXPECT_EQ(a.links[1].samples, static_cast<std::uint64_t>(periods));
  EXPECT_EQ(a.links[1].fused, a.links[1].delivered);
  const RunSummary b = offline_summary(s, periods);
  EXPECT_EQ(a.sum_squared_error, b.sum_squared_error);
  EXPECT_EQ(a.links[0].dropped, b.links[0].dropped);
}

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A sweep cut after some runs and resumed ends with the same runs.csv as one run straight
// through (the rows kept, the others run with the same seeds), and points.csv alike.
TEST(SweepResume, ACutSweepResumedEqualsAnUncutOne) {
  const fs::path dir = fs::temp_directory_path() / ("netkf-sweep-test-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  { std::ofstream(dir / "s.yaml") << kScenario; }
  SweepConfig c;
  c.scenario_path = (dir / "s.yaml").string();
  c.vary = {parse_vary("sensors.2.link.loss=0.1,0.5")};
  c.seeds = 3;
  c.periods = 200;
  c.out = (dir / "full").string();
  std::ostringstream err;
  ASSERT_EQ(run_sweep(c, false, {}, err), 0) << err.str();
  const std::string full = read(dir / "full" / "runs.csv");
  // The same sweep, cut: keep the header and the first 2 rows, then resume.
  c.out = (dir / "cut").string();
  ASSERT_EQ(run_sweep(c, false, {}, err), 0) << err.str();
  std::istringstream lines(full);
  std::string line, kept;
  for (int i = 0; i < 3 && std::getline(lines, line); ++i) kept += line + "\n";
  { std::ofstream(dir / "cut" / "runs.csv") << kept << "1,2,0.5,ok,12"; }  // and a cut line
  std::string sha;
  SweepConfig resumed = read_sweep_yaml(c.out, sha);
  resumed.expected_sha256 = sha;
  ASSERT_EQ(run_sweep(resumed, true, {}, err), 0) << err.str();
  const std::string again = read(dir / "cut" / "runs.csv");
  // Same rows (order: the kept ones first, then the rest in grid order, as straight through).
  EXPECT_EQ(again, full);
  EXPECT_EQ(read(dir / "cut" / "points.csv"), read(dir / "full" / "points.csv"));
  // Resuming a done sweep runs nothing and changes nothing.
  ASSERT_EQ(run_sweep(resumed, true, {}, err), 0);
  EXPECT_EQ(read(dir / "cut" / "runs.csv"), full);
  // A changed scenario is refused (status 2).
  { std::ofstream(dir / "s.yaml", std::ios::app) << "# edited\n"; }
  EXPECT_EQ(run_sweep(resumed, true, {}, err), 2);
  // A new sweep into a sweep's directory is refused.
  c.out = (dir / "full").string();
  EXPECT_EQ(run_sweep(c, false, {}, err), 2);
  fs::remove_all(dir);
}

TEST(SweepErrors, APointTheLoaderRefusesIsNamed) {
  const fs::path dir = fs::temp_directory_path() / ("netkf-sweep-bad-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  { std::ofstream(dir / "s.yaml") << kScenario; }
  SweepConfig c;
  c.scenario_path = (dir / "s.yaml").string();
  c.vary = {parse_vary("sensors.2.link.loss=0.1,1.5")};
  c.periods = 10;
  c.out = (dir / "out").string();
  std::ostringstream err;
  EXPECT_EQ(run_sweep(c, false, {}, err), 2);
  EXPECT_NE(err.str().find("point 1: sensors.2.link.loss=1.5"), std::string::npos) << err.str();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace netkf::cli::sweep
