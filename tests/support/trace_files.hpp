#pragma once
// What the trace tests of the links, the channel and the recording share: a scratch directory
// per test, removed at the end, a five-row trace and a scenario whose link replays a trace.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace netkf_test {

// A scratch directory of this test process, removed at the end.
class TraceFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("netkf-trace-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_ / "traces");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) const {
    const auto path = dir_ / name;
    std::ofstream(path) << text;
    return path.string();
  }
  std::filesystem::path dir_;
};

// Rows 0..4 delivered 1,0,0,1,1 with delays 3, -, -, 7.5, 2.
inline const char* const kTrace =
    "# five rows\n"
    "k,delivered,delay_ms\n"
    "10,1,3\n"
    "11,0,\n"
    "12,0,\n"
    "13,1,7.5\n"
    "14,1,2\n";

// A one-sensor scenario whose link 1 is `link` (a trace's file is named relative to the
// scenario, e.g. traces/t.csv in the scratch directory).
inline std::string trace_scenario_text(const std::string& link) {
  return "period_ms: 10\n"
         "seed: 7\n"
         "plant: { A: [[0.5]], Q: [[1.0]] }\n"
         "sensors:\n"
         "  - { id: 1, C: [[1.0]], R: [[1.0]], link: " + link + " }\n";
}

}  // namespace netkf_test
