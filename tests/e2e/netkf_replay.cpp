// netkf_replay: the offline expectation of the exactness e2e test. Feeds the samples a
// live run fused (recorded by `netkf launch --record-samples`) through the core filter
// (netkf::IntermittentKalmanFilter) period by period, and compares x̂_{k|k} and Tr P_{k|k}
// with the live estimates (`--record`). The live estimator implements the same
// recursion (multi-sensor paper Thm 1, eqs. 8-9), so they must agree to rounding.
//
// Usage: netkf_replay SCENARIO.yaml SAMPLES.csv PERIODS.csv
// Prints one JSON object; exit 0 when it could compare, 2 on bad input. Open loop only
// (a closed loop would also need the inputs the plant acknowledged).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "netkf/filter/kalman_filter.hpp"
#include "netkf/model/scenario.hpp"

namespace {

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, sep)) out.push_back(cell);
  if (!line.empty() && line.back() == sep) out.emplace_back();
  return out;
}

struct Row {
  std::vector<double> xhat;
  double trace_P = 0.0;
  std::vector<int> fused;
  std::string state;
};

int fail(const std::string& what) {
  std::cerr << "netkf_replay: " << what << "\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) return fail("usage: netkf_replay SCENARIO.yaml SAMPLES.csv PERIODS.csv");
  netkf::Scenario scenario;
  try {
    scenario = netkf::load_scenario_file(argv[1]);
  } catch (const std::exception& e) {
    return fail(e.what());
  }
  if (scenario.plant.B) return fail("closed-loop scenarios are not supported by the replay");
  const int n = scenario.state_dim();

  // Samples the live estimator fused, by period.
  std::map<std::int64_t, std::vector<netkf::SensorSample>> fused_samples;
  {
    std::ifstream in(argv[2]);
    std::string line;
    if (!std::getline(in, line)) return fail("empty samples file");
    while (std::getline(in, line)) {
      const auto c = split(line, ',');
      if (c.size() < 5) return fail("short samples row: " + line);
      if (c[3] != "1") continue;
      netkf::SensorSample s;
      s.sensor_id = std::stoi(c[1]);
      const auto* spec = scenario.find_sensor(s.sensor_id);
      if (!spec) return fail("unknown sensor in samples: " + c[1]);
      s.y.resize(spec->C.rows());
      for (int i = 0; i < s.y.size(); ++i) s.y[i] = std::stod(c[4 + i]);
      fused_samples[std::stoll(c[0])].push_back(s);
    }
  }
  // Live estimates.
  std::map<std::int64_t, Row> rows;
  {
    std::ifstream in(argv[3]);
    std::string line;
    if (!std::getline(in, line)) return fail("empty periods file");
    while (std::getline(in, line)) {
      const auto c = split(line, ',');
      // (A closed loop's rows end with the applied input u: not read here.)
      if (static_cast<int>(c.size()) < 2 + 2 * n + 5) return fail("bad periods row: " + line);
      if (c[5 + 2 * n] == "none") continue;  // a period without an estimate (its truth only)
      Row r;
      for (int i = 0; i < n; ++i) r.xhat.push_back(std::stod(c[2 + n + i]));
      r.trace_P = std::stod(c[2 + 2 * n]);
      for (const auto& id : split(c[3 + 2 * n], ';'))
        if (!id.empty()) r.fused.push_back(std::stoi(id));
      r.state = c[5 + 2 * n];
      rows[std::stoll(c[0])] = r;
    }
  }
  if (rows.empty()) return fail("no periods recorded");
  if (rows.begin()->first != 0) return fail("the recording does not start at period 0 (first k = " +
                                            std::to_string(rows.begin()->first) + ")");

  netkf::FilterModel model;
  model.A = scenario.plant.A;
  model.Q = scenario.plant.Q;
  for (const auto& s : scenario.sensors) model.sensors.push_back({s.id, s.C, s.R});
  netkf::FilterOptions options;
  options.divergence_trace_bound = scenario.estimator.divergence_trace_bound;
  netkf::IntermittentKalmanFilter filter(model, scenario.plant.x0, scenario.plant.P0, options);

  double max_x_diff = 0.0, max_trace_rel_diff = 0.0;
  std::int64_t compared = 0, missing = 0, fused_mismatch = 0, state_mismatch = 0;
  const std::int64_t last = rows.rbegin()->first;
  for (std::int64_t k = 0; k <= last; ++k) {
    const auto& samples = fused_samples[k];
    const auto result = filter.update(samples);
    auto it = rows.find(k);
    if (it == rows.end()) {
      ++missing;  // period not recorded: still advance the filter with what was fused
    } else {
      ++compared;
      std::vector<int> ids = it->second.fused;
      std::sort(ids.begin(), ids.end());
      if (ids != result.fused_ids) ++fused_mismatch;
      for (int i = 0; i < n; ++i)
        max_x_diff = std::max(max_x_diff, std::abs(filter.x()[i] - it->second.xhat[i]) /
                                              std::max(1.0, std::abs(filter.x()[i])));
      max_trace_rel_diff = std::max(max_trace_rel_diff, std::abs(filter.trace_P() - it->second.trace_P) /
                                                            std::max(1.0, std::abs(filter.trace_P())));
      if (it->second.state != netkf::to_string(filter.state())) ++state_mismatch;
    }
    filter.predict();
  }
  nlohmann::json out{{"periods_compared", compared},   {"periods_missing", missing},
                     {"max_xhat_diff", max_x_diff},     {"max_trace_P_diff", max_trace_rel_diff},
                     {"fused_mismatch", fused_mismatch}, {"state_mismatch", state_mismatch}};
  std::cout << out.dump() << "\n";
  return 0;
}
