// Scenario model: loading, validation messages (file:line:col + what is wrong),
// the shipped scenarios for the papers' examples, the default scenario, round trip.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include "test_paths.hpp"
#include "netkf/theory/operating_point.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "netkf/model/scenario.hpp"
#include "netkf/support/input_file.hpp"

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

const fs::path kData = netkf::test::test_data_dir() / "scenarios";
const fs::path kDeploy = netkf::test::source_dir() / "deploy" / "scenarios";

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const netkf::ScenarioError& e) {
    return e.what();
  }
  return "<no ScenarioError thrown>";
}

std::vector<fs::path> yaml_files(const fs::path& dir) {
  std::vector<fs::path> out;
  if (!fs::is_directory(dir)) return out;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().extension() == ".yaml") out.push_back(entry.path());
  std::sort(out.begin(), out.end());
  return out;
}

double spectral_radius(const netkf::Matrix& M) {
  return Eigen::EigenSolver<netkf::Matrix>(M, false).eigenvalues().cwiseAbs().maxCoeff();
}

// Stationary drop probability, computed here independently of the loss-model library.
double drop_probability(const netkf::LinkModel& link) {
  if (const auto* b = std::get_if<netkf::BernoulliLink>(&link)) return b->loss;
  const auto& g = std::get<netkf::GilbertElliottLink>(link);
  return (g.r * g.loss_good + g.p * g.loss_bad) / (g.p + g.r);
}

void expect_matrix_near(const netkf::Matrix& a, const netkf::Matrix& b, double tol, const std::string& what) {
  ASSERT_EQ(a.rows(), b.rows()) << what;
  ASSERT_EQ(a.cols(), b.cols()) << what;
  for (Eigen::Index i = 0; i < a.rows(); ++i)
    for (Eigen::Index j = 0; j < a.cols(); ++j)
      EXPECT_NEAR(a(i, j), b(i, j), tol * std::max(1.0, std::abs(a(i, j)))) << what << "(" << i << "," << j << ")";
}

void expect_link_near(const netkf::LinkModel& a, const netkf::LinkModel& b, double tol, const std::string& what) {
  ASSERT_EQ(a.index(), b.index()) << what;
  if (const auto* x = std::get_if<netkf::BernoulliLink>(&a)) {
    EXPECT_NEAR(x->loss, std::get<netkf::BernoulliLink>(b).loss, tol) << what;
  } else {
    const auto& g = std::get<netkf::GilbertElliottLink>(a);
    const auto& h = std::get<netkf::GilbertElliottLink>(b);
    EXPECT_NEAR(g.p, h.p, tol) << what;
    EXPECT_NEAR(g.r, h.r, tol) << what;
    EXPECT_NEAR(g.loss_good, h.loss_good, tol) << what;
    EXPECT_NEAR(g.loss_bad, h.loss_bad, tol) << what;
  }
}

// Everything except `source` (where it was loaded from).
void expect_same_scenario(const netkf::Scenario& a, const netkf::Scenario& b, double tol) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.period_ms, b.period_ms);
  EXPECT_EQ(a.seed, b.seed);
  expect_matrix_near(a.plant.A, b.plant.A, tol, "A");
  expect_matrix_near(a.plant.Q, b.plant.Q, tol, "Q");
  expect_matrix_near(a.plant.x0, b.plant.x0, tol, "x0");
  expect_matrix_near(a.plant.P0, b.plant.P0, tol, "P0");
  EXPECT_NEAR(a.plant.state_bound, b.plant.state_bound, tol * a.plant.state_bound);
  ASSERT_EQ(a.plant.B.has_value(), b.plant.B.has_value());
  if (a.plant.B) expect_matrix_near(*a.plant.B, *b.plant.B, tol, "B");
  ASSERT_EQ(a.plant.control.has_value(), b.plant.control.has_value());
  if (a.plant.control) {
    expect_matrix_near(a.plant.control->gain, b.plant.control->gain, tol, "gain");
    ASSERT_EQ(a.plant.control->lqr_Qx.has_value(), b.plant.control->lqr_Qx.has_value());
    if (a.plant.control->lqr_Qx) {
      expect_matrix_near(*a.plant.control->lqr_Qx, *b.plant.control->lqr_Qx, tol, "Qx");
      expect_matrix_near(*a.plant.control->lqr_Ru, *b.plant.control->lqr_Ru, tol, "Ru");
    }
  }
  ASSERT_EQ(a.sensors.size(), b.sensors.size());
  for (std::size_t i = 0; i < a.sensors.size(); ++i) {
    EXPECT_EQ(a.sensors[i].id, b.sensors[i].id);
    expect_matrix_near(a.sensors[i].C, b.sensors[i].C, tol, "C");
    expect_matrix_near(a.sensors[i].R, b.sensors[i].R, tol, "R");
    expect_link_near(a.sensors[i].link.loss, b.sensors[i].link.loss, tol, "link");
  }
  EXPECT_EQ(a.estimator.deadline_ms, b.estimator.deadline_ms);
  EXPECT_NEAR(a.estimator.divergence_trace_bound, b.estimator.divergence_trace_bound,
              tol * a.estimator.divergence_trace_bound);
}

netkf::Matrix M(std::initializer_list<std::initializer_list<double>> rows) {
  netkf::Matrix m(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(rows.begin()->size()));
  Eigen::Index i = 0;
  for (const auto& row : rows) {
    Eigen::Index j = 0;
    for (double v : row) m(i, j++) = v;
    ++i;
  }
  return m;
}

// ---------------------------------------------------------------------------------
// Broken files: each states its expected message ("# expect: ...") and marks the line
// the message must point at ("# <-- error"); "# expect-no-line" for a file-level error.

struct BadFile {
  fs::path path;
  std::vector<std::string> expected;
  int line = 0;  // 0: the message must carry no line
};

BadFile read_bad_file(const fs::path& path) {
  BadFile bad{path, {}, 0};
  std::ifstream in(path);
  std::string text;
  int number = 0;
  while (std::getline(in, text)) {
    ++number;
    const std::string tag = "# expect: ";
    if (text.rfind(tag, 0) == 0) bad.expected.push_back(text.substr(tag.size()));
    if (text.find("# <-- error") != std::string::npos) bad.line = number;
  }
  return bad;
}

class BrokenScenario : public ::testing::TestWithParam<fs::path> {};

TEST_P(BrokenScenario, GivesOnePreciseError) {
  const BadFile bad = read_bad_file(GetParam());
  ASSERT_FALSE(bad.expected.empty()) << "no '# expect:' line in " << bad.path;
  const std::string message = error_of([&] { netkf::load_scenario_file(bad.path); });
  RecordProperty("message", message);  // visible with --gtest_output=xml
  const std::string file = bad.path.string();
  if (bad.line > 0) {
    EXPECT_THAT(message, StartsWith(file + ":" + std::to_string(bad.line) + ":")) << message;
  } else {
    EXPECT_THAT(message, StartsWith(file + ": ")) << message;
  }
  for (const auto& words : bad.expected) EXPECT_THAT(message, HasSubstr(words));
}

INSTANTIATE_TEST_SUITE_P(BadFiles, BrokenScenario, ::testing::ValuesIn(yaml_files(kData / "bad")),
                         [](const ::testing::TestParamInfo<fs::path>& param_info) {
                           std::string name = param_info.param.stem().string();
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

TEST(BrokenScenarioSet, CoversEveryValidationError) {
  // The set of broken files must stay large: one per validation error in the issue.
  const auto files = yaml_files(kData / "bad");
  EXPECT_GE(files.size(), 40u);
  std::set<std::string> stems;
  for (const auto& f : files) stems.insert(f.stem().string());
  for (const char* needed :
       {"R-wrong-dimension", "R-not-positive-definite", "Q-not-symmetric", "Q-not-psd", "P0-not-positive-definite",
        "loss-above-one", "duplicate-sensor-id", "unknown-link-key", "missing-plant-A", "A-not-square", "A-ragged",
        "A-nan", "A-not-a-number", "period-zero", "deadline-after-period", "negative-seed", "no-sensors",
        "unknown-link-model", "B-wrong-rows", "control-without-B", "B-without-control", "gain-wrong-shape",
        "lqr-Ru-not-positive-definite", "lqr-Qx-wrong-shape", "x0-wrong-length", "syntax-error"})
    EXPECT_TRUE(stems.count(needed)) << needed;
}

TEST(ScenarioErrors, ColumnPointsAtTheOffendingKey) {
  const std::string text =
      "period_ms: 10\n"
      "plant: { A: [[0.5]], Q: [[1.0]] }\n"
      "sensors:\n"
      "  - { id: 1, C: [[1.0]], R: [[1.0]], link: { model: bernoulli, los: 0.3 } }\n";
  const std::string message = error_of([&] { netkf::parse_scenario(text, "inline.yaml"); });
  // "los" starts in column 64 of line 4 (1-based).
  EXPECT_THAT(message, StartsWith("inline.yaml:4:64: unknown key 'los' in sensors[0].link")) << message;
}

TEST(ScenarioErrors, MissingFileIsReported) {
  const std::string message = error_of([] { netkf::load_scenario_file(kData / "does-not-exist.yaml"); });
  EXPECT_THAT(message, HasSubstr("does-not-exist.yaml: cannot open scenario file: No such file or directory"));
}

TEST(ScenarioErrors, DirectoryIsReported) {
  EXPECT_THAT(error_of([] { netkf::load_scenario_file(kData); }), HasSubstr("is a directory"));
}

// Inputs are read bounded (netkf/support/input_file.hpp): a device or a FIFO is refused by its kind,
// at once (it used to be read until memory ran out, or to wait for a writer), and so is a file
// larger than a scenario may be.
TEST(ScenarioErrors, DevicesFifosAndHugeFilesAreRefusedUnread) {
  EXPECT_THAT(error_of([] { netkf::load_scenario_file("/dev/zero"); }),
              HasSubstr("/dev/zero: is a character device, not a scenario file"));
  EXPECT_THAT(error_of([] { netkf::load_scenario_file("/dev/urandom"); }), HasSubstr("is a character device"));
  const fs::path dir = fs::temp_directory_path() / ("netkf-test-inputs-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path fifo = dir / "fifo.yaml";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  EXPECT_THAT(error_of([&] { netkf::load_scenario_file(fifo); }), HasSubstr("is a FIFO (named pipe), not a scenario file"));
  const fs::path huge = dir / "huge.yaml";
  std::ofstream(huge).close();
  fs::resize_file(huge, netkf::max_yaml_input_bytes + 1);  // sparse: no disk used
  EXPECT_THAT(error_of([&] { netkf::load_scenario_file(huge); }), HasSubstr("more than a scenario file may have"));
  fs::remove_all(dir);
}

// A file of another kind (here /etc/passwd's first line) is named as such; its text is never
// echoed into the message.
TEST(ScenarioErrors, PlainTextIsNotEchoed) {
  const std::string text = "root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n";
  const std::string message = error_of([&] { netkf::parse_scenario(text, "passwd"); });
  EXPECT_THAT(message, HasSubstr("got plain text"));
  EXPECT_THAT(message, ::testing::Not(HasSubstr("root:x")));
  // A field's value is shown up to its first line, at most 40 characters.
  const std::string named = error_of([&] {
    netkf::parse_scenario("period_ms: 'x\n\n  second line " + std::string(60, 'b') + "'\n", "v.yaml");
  });
  EXPECT_THAT(named, HasSubstr("period_ms must be an integer, got 'x...'")) << named;
}

TEST(ScenarioErrors, AnIntegerBeyondRangeIsSaidToBe) {
  const std::string text =
      "period_ms: 10\nplant: { A: [[0.5]], Q: [[1.0]] }\n"
      "sensors:\n  - { id: 1, C: [[1.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.3 } }\n"
      "events:\n  - { at_period: 99999999999999999999, link: 1, set: { loss: 0.5 } }\n";
  const std::string message = error_of([&] { netkf::parse_scenario(text, "e.yaml"); });
  EXPECT_THAT(message, HasSubstr("events[0].at_period is out of range")) << message;
  EXPECT_THAT(error_of([&] { netkf::parse_scenario("period_ms: 99999999999999999999\n", "p.yaml"); }),
              HasSubstr("period_ms is out of range"));
}

TEST(ScenarioErrors, DeepNestingIsAnErrorNotACrash) {
  const std::string text = "period_ms: 10\nplant: { A: " + std::string(100000, '[') + " }\n";
  EXPECT_THAT(error_of([&] { netkf::parse_scenario(text, "deep.yaml"); }), StartsWith("deep.yaml:"));
}

TEST(ScenarioErrors, SeveralDocumentsAreRejected) {
  const std::string text = "period_ms: 10\n---\nperiod_ms: 20\n";
  EXPECT_THAT(error_of([&] { netkf::parse_scenario(text, "two.yaml"); }), HasSubstr("2 YAML documents"));
}

// Found by tests/fuzz/fuzz_scenario_loader (corpus: hang-flow-sequence-then-comma.yaml):
// yaml-cpp's LoadAll never returned on a flow collection followed by a comma.
TEST(ScenarioErrors, FlowCollectionThenCommaIsAnErrorNotAHang) {
  for (const std::string text : {"[0],\n", "{period_ms: 10},\n", "[0] ,\nB: 1\n"}) {
    EXPECT_THAT(error_of([&] { netkf::parse_scenario(text, "comma.yaml"); }), StartsWith("comma.yaml")) << text;
  }
}

// Found with the fuzz build's UBSan (tests/fuzz corpus: ubsan-largest-period.yaml): the default
// deadline, 80 % of the period, overflowed an int for the largest periods.
TEST(GoodScenario, DefaultDeadlineOfTheLargestPeriod) {
  const std::string text =
      "period_ms: 2147483647\nplant: { A: [[0.5]], Q: [[1.0]] }\n"
      "sensors: [ { id: 1, C: [[1.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.1 } } ]\n";
  const auto s = netkf::parse_scenario(text, "long.yaml");
  EXPECT_EQ(s.deadline_ms(), 1717986917);  // floor(0.8 * (2^31 - 1))
  EXPECT_NO_THROW(netkf::with_effective_links(s));
}

// Found with the fuzz build's UBSan (tests/fuzz corpus: ubsan-event-seconds-period-zero.yaml):
// an event's seconds were converted by a period of 0 (NaN) before the period was refused.
TEST(ScenarioErrors, EventInSecondsWithAPeriodOfZeroReportsThePeriod) {
  for (const std::string period : {"0", "-10"}) {
    const std::string text =
        "period_ms: " + period + "\nplant: { A: [[0.5]], Q: [[1.0]] }\n"
        "sensors: [ { id: 1, C: [[1.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.1 } } ]\n"
        "events: [ { at_s: 1.5, link: 1, ramp: { to: { loss: 0.2 }, over_s: 2 } } ]\n";
    EXPECT_THAT(error_of([&] { netkf::parse_scenario(text, "p.yaml"); }), HasSubstr("period_ms must be > 0")) << period;
  }
}

TEST(ScenarioErrors, SeedAbove64BitsIsRejected) {
  const std::string text =
      "period_ms: 10\nseed: 18446744073709551616\nplant: { A: [[0.5]], Q: [[1.0]] }\n"
      "sensors: [ { id: 1, C: [[1.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.1 } } ]\n";
  EXPECT_THAT(error_of([&] { netkf::parse_scenario(text, "seed.yaml"); }),
              StartsWith("seed.yaml:2:7: seed must fit in 64 bits"));
}

TEST(ScenarioNaming, RosTwoOrNetkfElseAnErrorAtTheValue) {
  const std::string rest =
      "plant: { A: [[0.5]], Q: [[1.0]] }\n"
      "sensors: [ { id: 1, C: [[1.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.1 } } ]\n";
  EXPECT_EQ(netkf::parse_scenario("period_ms: 10\n" + rest, "a.yaml").naming, netkf::TopicNaming::netkf);
  const netkf::Scenario ros2 = netkf::parse_scenario("period_ms: 10\nnaming: ros2\n" + rest, "b.yaml");
  EXPECT_EQ(ros2.naming, netkf::TopicNaming::ros2);
  EXPECT_EQ(netkf::parse_scenario("period_ms: 10\nnaming: netkf\n" + rest, "c.yaml").naming,
            netkf::TopicNaming::netkf);
  EXPECT_THAT(error_of([&] { netkf::parse_scenario("period_ms: 10\nnaming: ROS2\n" + rest, "d.yaml"); }),
              StartsWith("d.yaml:2:9: naming must be netkf or ros2"));
  // The effective scenario a launch hands its processes keeps the key; the default adds none
  // (an unchanged text keeps the scenario's hash).
  EXPECT_EQ(netkf::parse_scenario(netkf::scenario_to_yaml(ros2), "e.yaml").naming, netkf::TopicNaming::ros2);
  EXPECT_EQ(netkf::scenario_to_yaml(netkf::parse_scenario("period_ms: 10\n" + rest, "f.yaml")).find("naming"),
            std::string::npos);
}

// ---------------------------------------------------------------------------------
// Good files load with the right values.

TEST(GoodScenario, EveryKeyIsRead) {
  const netkf::Scenario s = netkf::load_scenario_file(kData / "good" / "full.yaml");
  EXPECT_EQ(s.name, "full-example");
  EXPECT_EQ(s.source, (kData / "good" / "full.yaml").string());
  EXPECT_EQ(s.period_ms, 20);
  EXPECT_EQ(s.seed, std::numeric_limits<std::uint64_t>::max());
  EXPECT_EQ(s.state_dim(), 2);
  EXPECT_EQ(s.plant.A, M({{1.2, 0.1}, {0.0, 0.8}}));
  EXPECT_EQ(s.plant.Q, M({{0.5, 0.1}, {0.1, 0.25}}));
  ASSERT_TRUE(s.plant.B);
  EXPECT_EQ(*s.plant.B, M({{0.0}, {1.0}}));
  ASSERT_TRUE(s.plant.control);
  EXPECT_EQ(s.plant.control->gain, M({{4.9, 1.0}}));
  EXPECT_FALSE(s.plant.control->lqr_Qx);
  EXPECT_EQ(s.plant.x0, (netkf::Vector(2) << 1.5, -2.0).finished());
  EXPECT_EQ(s.plant.P0, M({{2.0, 0.0}, {0.0, 3.0}}));
  EXPECT_EQ(s.plant.state_bound, 1000.0);
  ASSERT_EQ(s.sensors.size(), 2u);
  EXPECT_EQ(s.sensors[0].id, 7);
  EXPECT_EQ(s.sensors[0].C, M({{1.0, 0.0}, {0.0, 1.0}}));
  EXPECT_EQ(s.sensors[0].R, M({{1.0, 0.2}, {0.2, 2.0}}));
  EXPECT_EQ(s.sensors[0].link, netkf::LinkModel(netkf::BernoulliLink{0.25}));
  EXPECT_EQ(s.sensors[1].id, 3);
  EXPECT_EQ(s.sensors[1].link, netkf::LinkModel(netkf::GilbertElliottLink{0.1, 0.6, 0.05, 0.95}));
  EXPECT_EQ(s.estimator.deadline_ms, 15);
  EXPECT_EQ(s.deadline_ms(), 15);
  EXPECT_EQ(s.estimator.divergence_trace_bound, 5.0e4);
  ASSERT_NE(s.find_sensor(3), nullptr);
  EXPECT_EQ(s.find_sensor(3)->R, M({{0.5}}));
  EXPECT_EQ(s.find_sensor(4), nullptr);
}

TEST(GoodScenario, OptionalKeysTakeTheirDefaults) {
  const netkf::Scenario s = netkf::load_scenario_file(kData / "good" / "minimal.yaml");
  EXPECT_EQ(s.name, "minimal");  // file stem
  EXPECT_EQ(s.seed, 0u);
  EXPECT_EQ(s.plant.x0, netkf::Vector::Zero(1));
  EXPECT_EQ(s.plant.P0, netkf::Matrix::Identity(1, 1));
  EXPECT_FALSE(s.plant.B);
  EXPECT_FALSE(s.plant.control);
  EXPECT_EQ(s.plant.state_bound, 1e8);
  EXPECT_FALSE(s.estimator.deadline_ms);
  EXPECT_EQ(s.deadline_ms(), 8);  // 80 % of the 10 ms period
  EXPECT_EQ(s.estimator.divergence_trace_bound, 1e6);
  EXPECT_EQ(s.sensors[0].id, 0);
  EXPECT_EQ(s.sensors[0].R, M({{0.01}}));
  EXPECT_EQ(s.sensors[0].link, netkf::LinkModel(netkf::GilbertElliottLink{0.3, 0.7, 0.0, 1.0}));
}

TEST(GoodScenario, LqrWeightsGiveAStabilisingGain) {
  const std::string text =
      "period_ms: 10\n"
      "plant:\n"
      "  A: [[-1.25]]\n  Q: [[1.0]]\n  B: [[1.0]]\n"
      "  control: { lqr: { Qx: [[1.0]], Ru: [[1.0]] } }\n"
      "sensors: [ { id: 1, C: [[1.0]], R: [[2.5]], link: { model: bernoulli, loss: 0.4 } } ]\n";
  const netkf::Scenario s = netkf::parse_scenario(text, "lqr.yaml");
  ASSERT_TRUE(s.plant.control);
  // Scalar DARE x = a²x - a²b²x²/(r + b²x) + q with a = -1.25, b = q = r = 1:
  // x² - a²x - 1 = 0 (after simplification: b²x² + (r - a²r - qb²)x - qr = 0).
  const double a = -1.25;
  const double c1 = 1.0 - a * a - 1.0;
  const double x = (-c1 + std::sqrt(c1 * c1 + 4.0)) / 2.0;
  const double gain = x * a / (1.0 + x);
  EXPECT_NEAR(s.plant.control->gain(0, 0), gain, 1e-12);
  EXPECT_LT(std::abs(a - gain), 1.0);
}

// ---------------------------------------------------------------------------------
// Shipped scenarios.

TEST(DeployScenarios, EveryShippedFileLoads) {
  const auto files = yaml_files(kDeploy);
  ASSERT_FALSE(files.empty()) << kDeploy;
  std::set<std::string> names;
  for (const auto& f : files) {
    SCOPED_TRACE(f.string());
    netkf::Scenario s;
    ASSERT_NO_THROW(s = netkf::load_scenario_file(f));
    EXPECT_EQ(s.name, f.stem().string());
    names.insert(s.name);
    if (s.plant.control) {
      EXPECT_LT(spectral_radius(s.plant.A - *s.plant.B * s.plant.control->gain), 1.0);
    }
  }
  for (const char* needed : {"default", "sinopoli-scalar", "sinopoli-mimo", "sinopoli-general", "sinopoli-static-gain",
                             "liu-goldsmith-case1", "liu-goldsmith-diag", "liu-goldsmith-fig5", "markov-gilbert-scalar",
                             "below-critical"})
    EXPECT_TRUE(names.count(needed)) << needed;
}

// Sinopoli's scalar example: A = -1.25, C = 1, Q = 1, R = 2.5 (Sec. IV).
void expect_sinopoli_scalar_plant(const netkf::Scenario& s) {
  EXPECT_EQ(s.plant.A, M({{-1.25}}));
  EXPECT_EQ(s.plant.Q, M({{1.0}}));
  ASSERT_EQ(s.sensors.size(), 1u);
  EXPECT_EQ(s.sensors[0].C, M({{1.0}}));
  EXPECT_EQ(s.sensors[0].R, M({{2.5}}));
}

TEST(DeployScenarios, SinopoliScalarAndStaticGain) {
  for (const char* file : {"sinopoli-scalar.yaml", "sinopoli-static-gain.yaml"}) {
    SCOPED_TRACE(file);
    const auto s = netkf::load_scenario_file(kDeploy / file);
    expect_sinopoli_scalar_plant(s);
    EXPECT_EQ(s.sensors[0].link, netkf::LinkModel(netkf::BernoulliLink{0.4}));  // λ = 0.6
    ASSERT_TRUE(s.plant.B);
  }
}

TEST(DeployScenarios, SinopoliMimoAndGeneral) {
  const auto mimo = netkf::load_scenario_file(kDeploy / "sinopoli-mimo.yaml");
  EXPECT_EQ(mimo.plant.A, M({{1.25, 1, 0}, {0, 0.9, 7}, {0, 0, 0.6}}));
  EXPECT_EQ(mimo.plant.Q, 20.0 * netkf::Matrix::Identity(3, 3));
  EXPECT_EQ(mimo.sensors[0].C, M({{1, 0, 2}}));
  EXPECT_EQ(mimo.sensors[0].R, M({{2.5}}));
  // Above λ_c = 0.36 (single unstable eigenvalue 1.25).
  EXPECT_GT(1.0 - drop_probability(mimo.sensors[0].link.loss), 1.0 - 1.0 / (1.25 * 1.25));

  const auto general = netkf::load_scenario_file(kDeploy / "sinopoli-general.yaml");
  EXPECT_EQ(general.plant.A, M({{1.25, 0}, {1, 1.1}}));
  EXPECT_EQ(general.plant.Q, 20.0 * netkf::Matrix::Identity(2, 2));
  EXPECT_EQ(general.sensors[0].C, M({{1, 1}}));
  EXPECT_EQ(general.sensors[0].R, M({{2.5}}));
}

TEST(DeployScenarios, LiuGoldsmithExamples) {
  const auto case1 = netkf::load_scenario_file(kDeploy / "liu-goldsmith-case1.yaml");
  ASSERT_EQ(case1.sensors.size(), 2u);
  EXPECT_EQ(case1.sensors[0].C, netkf::Matrix::Identity(2, 2));
  EXPECT_EQ(case1.sensors[1].C, M({{1, 0}, {1, 1}}));
  EXPECT_EQ(case1.sensors[0].R, 2.5 * netkf::Matrix::Identity(2, 2));
  // Case 1 closed form: λ2c = max(0, 1 - 1/(α²(1-λ1))), α = 1.25.
  const double l1 = 1.0 - drop_probability(case1.sensors[0].link.loss);
  const double l2 = 1.0 - drop_probability(case1.sensors[1].link.loss);
  EXPECT_GT(l2, std::max(0.0, 1.0 - 1.0 / (1.25 * 1.25 * (1.0 - l1))));

  const auto diag = netkf::load_scenario_file(kDeploy / "liu-goldsmith-diag.yaml");
  EXPECT_EQ(diag.plant.A, M({{2.5, 0}, {0, 1.5}}));
  EXPECT_EQ(diag.sensors[0].C, M({{1, 0}}));
  EXPECT_EQ(diag.sensors[1].C, M({{0, 1}}));
  EXPECT_GT(1.0 - drop_probability(diag.sensors[0].link.loss), 0.84);
  EXPECT_GT(1.0 - drop_probability(diag.sensors[1].link.loss), 5.0 / 9.0);

  const auto fig5 = netkf::load_scenario_file(kDeploy / "liu-goldsmith-fig5.yaml");
  EXPECT_EQ(fig5.plant.A, M({{1.25, 0}, {1, 1.1}}));
  EXPECT_EQ(fig5.sensors[0].C, M({{1, 0}}));
  EXPECT_EQ(fig5.sensors[1].C, M({{1, 1}}));
  EXPECT_NEAR(2.0 - drop_probability(fig5.sensors[0].link.loss) - drop_probability(fig5.sensors[1].link.loss), 0.5, 1e-15);
}

TEST(DeployScenarios, MarkovGilbertAndBelowCritical) {
  const auto gilbert = netkf::load_scenario_file(kDeploy / "markov-gilbert-scalar.yaml");
  expect_sinopoli_scalar_plant(gilbert);
  const auto& g = std::get<netkf::GilbertElliottLink>(gilbert.sensors[0].link.loss);
  EXPECT_EQ(g.loss_good, 0.0);
  EXPECT_EQ(g.loss_bad, 1.0);
  EXPECT_GT(g.r, 0.36);  // α²(1 - r) < 1

  const auto below = netkf::load_scenario_file(kDeploy / "below-critical.yaml");
  expect_sinopoli_scalar_plant(below);
  EXPECT_FALSE(below.plant.control);
  EXPECT_GT(drop_probability(below.sensors[0].link.loss), 1.0 / (1.25 * 1.25));  // λ < λ_c = 0.36
}

// ---------------------------------------------------------------------------------
// Default scenario.

TEST(DefaultScenario, MatchesTheShippedFile) {
  const netkf::Scenario builtin = netkf::default_scenario();
  const netkf::Scenario file = netkf::load_scenario_file(kDeploy / "default.yaml");
  expect_same_scenario(builtin, file, 0.0);
}

TEST(DefaultScenario, IsTheDemoTheDesignAsksFor) {
  const netkf::Scenario s = netkf::default_scenario();
  ASSERT_NO_THROW(netkf::validate_scenario(s));
  EXPECT_TRUE(s.period_ms == 10 || s.period_ms == 20);
  ASSERT_EQ(s.sensors.size(), 3u);
  int bernoulli = 0;
  for (const auto& sensor : s.sensors) bernoulli += std::holds_alternative<netkf::BernoulliLink>(sensor.link.loss);
  EXPECT_EQ(bernoulli, 2);
  const double alpha = spectral_radius(s.plant.A);
  EXPECT_GT(alpha, 1.0);  // open-loop unstable
  ASSERT_TRUE(s.plant.control);
  EXPECT_LT(spectral_radius(s.plant.A - *s.plant.B * s.plant.control->gain), 1.0);
  // The demo: stable as configured, and link 2 is critical. Degrading it to loss 0.97
  // (the README's walk-through) crosses the boundary; 0.9 does not (the criterion
  // crosses 1 at loss 0.914).
  const auto configured = netkf::theory::assess_configured_links(s);
  EXPECT_EQ(configured.stable, netkf::theory::Verdict::yes);
  ASSERT_TRUE(configured.markov_criterion);
  EXPECT_LT(*configured.markov_criterion, 0.5);
  netkf::Scenario degraded = s;
  degraded.sensors[1].link = netkf::BernoulliLink{0.97};
  EXPECT_EQ(netkf::theory::assess_configured_links(degraded).stable, netkf::theory::Verdict::no);
  degraded.sensors[1].link = netkf::BernoulliLink{0.9};
  EXPECT_EQ(netkf::theory::assess_configured_links(degraded).stable, netkf::theory::Verdict::yes);
}

// ---------------------------------------------------------------------------------
// Round trip through scenario_to_yaml.

TEST(RoundTrip, ShippedAndTestScenariosSurviveSerialisation) {
  std::vector<netkf::Scenario> all{netkf::default_scenario(),
                                   netkf::load_scenario_file(kData / "good" / "full.yaml"),
                                   netkf::load_scenario_file(kData / "good" / "minimal.yaml")};
  for (const auto& f : yaml_files(kDeploy)) all.push_back(netkf::load_scenario_file(f));
  for (const auto& s : all) {
    SCOPED_TRACE(s.name);
    const std::string yaml = netkf::scenario_to_yaml(s);
    const netkf::Scenario back = netkf::parse_scenario(yaml, "roundtrip.yaml");
    expect_same_scenario(s, back, 1e-15);
  }
}

TEST(RoundTrip, AwkwardDoublesAreExact) {
  netkf::Scenario s;
  s.name = "awkward: name # with YAML specials";
  s.period_ms = 7;
  s.seed = 12345678901234567890ull;
  s.plant.A = M({{1.0 / 3.0, 1e-300}, {-2.0 / 7.0, 0.1}});
  s.plant.Q = M({{0.1, 1.0 / 3.0}, {1.0 / 3.0, 5.0}});
  s.plant.x0 = (netkf::Vector(2) << 1e300, -4.9e-324).finished();
  s.plant.P0 = M({{std::nextafter(1.0, 2.0), 0.0}, {0.0, 2.0 / 3.0}});
  s.plant.state_bound = 1e300;
  s.sensors.push_back({9, M({{std::sqrt(2.0), 0.7}}), M({{0.3}}), netkf::GilbertElliottLink{1.0 / 3.0, 0.1, 0.0, 2.0 / 3.0}});
  s.estimator.divergence_trace_bound = 123.456789012345678;
  ASSERT_NO_THROW(netkf::validate_scenario(s));
  const netkf::Scenario back = netkf::parse_scenario(netkf::scenario_to_yaml(s), "awkward.yaml");
  expect_same_scenario(s, back, 0.0);  // 17 significant digits: bit-exact
}

// ---------------------------------------------------------------------------------
// Programmatic scenarios get the same checks (messages name the field).

netkf::Scenario valid_programmatic() {
  netkf::Scenario s;
  s.name = "prog";
  s.plant.A = M({{1.1, 0.0}, {0.0, 0.5}});
  s.plant.Q = netkf::Matrix::Identity(2, 2);
  s.plant.x0 = netkf::Vector::Zero(2);
  s.plant.P0 = netkf::Matrix::Identity(2, 2);
  s.sensors.push_back({1, M({{1.0, 0.0}}), M({{1.0}}), netkf::BernoulliLink{0.1}});
  s.sensors.push_back({2, M({{0.0, 1.0}}), M({{1.0}}), netkf::GilbertElliottLink{0.1, 0.5, 0.0, 1.0}});
  return s;
}

std::string validation_error(const std::function<void(netkf::Scenario&)>& mutate) {
  netkf::Scenario s = valid_programmatic();
  mutate(s);
  return error_of([&] { netkf::validate_scenario(s); });
}

TEST(ProgrammaticValidation, ValidScenarioPasses) { EXPECT_NO_THROW(netkf::validate_scenario(valid_programmatic())); }

TEST(ProgrammaticValidation, EachProblemIsNamed) {
  using netkf::Scenario;
  EXPECT_THAT(validation_error([](Scenario& s) { s.plant.A(1, 0) = std::nan(""); }),
              StartsWith("scenario 'prog': plant.A[1][0] must be a finite number, got nan"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.sensors[1].R(0, 0) = -0.5; }),
              HasSubstr("sensors[1].R is not positive definite (smallest eigenvalue -0.5)"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.sensors[1].R = netkf::Matrix::Identity(2, 2); }),
              HasSubstr("sensors[1].R must be 1x1 to match C (1 rows), got 2x2"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.sensors[1].id = 1; }),
              HasSubstr("duplicate sensor id 1 in sensors[1] (first at sensors[0].id)"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.sensors[0].link = netkf::BernoulliLink{1.3}; }),
              HasSubstr("sensors[0].link.loss must be a probability in [0, 1], got 1.3"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.sensors[1].link = netkf::GilbertElliottLink{std::nan(""), 0.5, 0, 1}; }),
              HasSubstr("sensors[1].link.p must be a probability in [0, 1], got nan"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.sensors.clear(); }), HasSubstr("sensors must list at least one sensor"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.plant.x0 = netkf::Vector::Zero(3); }),
              HasSubstr("plant.x0 must have 2 entries to match A, got 3"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.plant.x0(0) = INFINITY; }),
              HasSubstr("plant.x0[0] must be a finite number, got inf"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.period_ms = -5; }), HasSubstr("period_ms must be > 0, got -5"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.estimator.deadline_ms = 0; }),
              HasSubstr("estimator.deadline_ms must be in (0, period_ms] = (0, 10], got 0"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.plant.state_bound = std::nan(""); }),
              HasSubstr("plant.state_bound must be a positive finite number"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.plant.A = netkf::Matrix(); }), HasSubstr("plant.A must not be empty"));
  EXPECT_THAT(validation_error([](Scenario& s) { s.plant.B = M({{0.0}, {1.0}}); }),
              HasSubstr("plant.B is given but plant.control is missing"));
  EXPECT_THAT(validation_error([](Scenario& s) {
                s.source = "from/somewhere.yaml";
                s.sensors[0].C = M({{1.0}});
              }),
              StartsWith("from/somewhere.yaml: sensors[0].C must have 2 columns to match A"));
}

TEST(ProgrammaticValidation, SymmetryCheckToleratesRounding) {
  netkf::Scenario s = valid_programmatic();
  s.plant.Q(0, 1) = 1e-14;  // last-bit asymmetry from e.g. A P A': accepted
  EXPECT_NO_THROW(netkf::validate_scenario(s));
  s.plant.Q(0, 1) = 1e-3;
  EXPECT_THAT(error_of([&] { netkf::validate_scenario(s); }), HasSubstr("plant.Q must be symmetric"));
}

TEST(ProgrammaticValidation, DefinitenessIsJudgedRelativeToScale) {
  netkf::Scenario s = valid_programmatic();
  s.sensors[0].R = M({{1e-10}});  // tiny but well-conditioned: fine
  EXPECT_NO_THROW(netkf::validate_scenario(s));
  s.plant.P0 = M({{1.0, 0.0}, {0.0, 1e-15}});  // condition number 1e15: singular in practice
  EXPECT_THAT(error_of([&] { netkf::validate_scenario(s); }),
              HasSubstr("plant.P0 is not positive definite (smallest eigenvalue 1e-15, numerically singular)"));
}

TEST(ProgrammaticValidation, CompleteScenarioComputesTheLqrGain) {
  netkf::Scenario s = valid_programmatic();
  s.plant.B = M({{1.0}, {0.0}});
  netkf::ControlSpec control;
  control.lqr_Qx = netkf::Matrix::Identity(2, 2);
  control.lqr_Ru = M({{1.0}});
  s.plant.control = control;
  EXPECT_THAT(error_of([&] { netkf::validate_scenario(s); }), HasSubstr("call complete_scenario()"));
  ASSERT_NO_THROW(netkf::complete_scenario(s));
  ASSERT_EQ(s.plant.control->gain.rows(), 1);
  ASSERT_EQ(s.plant.control->gain.cols(), 2);
  EXPECT_LT(spectral_radius(s.plant.A - *s.plant.B * s.plant.control->gain), 1.0);
  EXPECT_NO_THROW(netkf::validate_scenario(s));
  // A gain that disagrees with the weights is caught.
  s.plant.control->gain(0, 0) += 0.01;
  EXPECT_THAT(error_of([&] { netkf::validate_scenario(s); }), HasSubstr("differs from the LQR gain"));
}

}  // namespace

namespace {

std::string late_policy_text(const std::string& estimator) {
  return "period_ms: 10\n"
         "plant: { A: [[0.5]], Q: [[1.0]] }\n"
         "sensors:\n"
         "  - { id: 1, C: [[1.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.3 } }\n"
         "estimator: " + estimator + "\n";
}

TEST(ScenarioLatePolicy, DropIsTheDefaultAndFuseWithinReadsD) {
  const netkf::Scenario plain = netkf::parse_scenario(late_policy_text("{ deadline_ms: 8 }"), "inline.yaml");
  EXPECT_EQ(plain.estimator.late_policy, netkf::LatePolicy::drop);
  EXPECT_EQ(plain.estimator.fusable_delay_periods(), 0);
  const netkf::Scenario s =
      netkf::parse_scenario(late_policy_text("{ late_policy: fuse_within, max_delay_periods: 64 }"), "inline.yaml");
  EXPECT_EQ(s.estimator.late_policy, netkf::LatePolicy::fuse_within);
  EXPECT_EQ(s.estimator.fusable_delay_periods(), 64);
  // The YAML handed to the child processes keeps both keys.
  const netkf::Scenario again = netkf::parse_scenario(netkf::scenario_to_yaml(s), "again.yaml");
  EXPECT_EQ(again.estimator.late_policy, netkf::LatePolicy::fuse_within);
  EXPECT_EQ(again.estimator.max_delay_periods, 64);
}

TEST(ScenarioLatePolicy, BadValuesAreNamedAtTheirLine) {
  auto error = [](const std::string& estimator) {
    return error_of([&] { netkf::parse_scenario(late_policy_text(estimator), "inline.yaml"); });
  };
  EXPECT_THAT(error("{ late_policy: fuse_within, max_delay_periods: 0 }"),
              HasSubstr("inline.yaml:5:"));
  EXPECT_THAT(error("{ late_policy: fuse_within, max_delay_periods: 0 }"),
              HasSubstr("estimator.max_delay_periods must be in [1, 64], got 0"));
  EXPECT_THAT(error("{ late_policy: fuse_within, max_delay_periods: 65 }"),
              HasSubstr("estimator.max_delay_periods must be in [1, 64], got 65"));
  EXPECT_THAT(error("{ late_policy: fuse_within }"),
              HasSubstr("estimator.late_policy: fuse_within needs estimator.max_delay_periods (1..64)"));
  EXPECT_THAT(error("{ max_delay_periods: 2 }"),
              HasSubstr("estimator.max_delay_periods needs estimator.late_policy: fuse_within"));
  EXPECT_THAT(error("{ late_policy: fuse }"),
              HasSubstr("inline.yaml:5:27: estimator.late_policy must be drop or fuse_within, got 'fuse'"));
  EXPECT_THAT(error("{ late_policy: fuse_within, max_delay_periods: 2.5 }"),
              HasSubstr("estimator.max_delay_periods must be an integer"));
}

}  // namespace
