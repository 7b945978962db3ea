#include "sweep_runs.hpp"

#include <cmath>
#include <deque>

#include "netkf/sim/offline_run.hpp"
#include "netkf/theory/report.hpp"

namespace netkf::cli::sweep {

std::string run_scenario_yaml(const YAML::Node& file_tree, const std::vector<Vary>& vary, const Point& point,
                              int seed_index) {
  YAML::Node tree = YAML::Clone(file_tree);
  for (std::size_t i = 0; i < vary.size(); ++i) apply_key(tree, vary[i].key, point.values[i]);
  if (seed_index > 0) {
    const std::uint64_t base = tree["seed"] && tree["seed"].IsScalar() ? parse_seed(tree["seed"].Scalar()) : 0;
    tree["seed"] = std::to_string(run_seed(base, seed_index));
  }
  YAML::Emitter out;
  out << tree;
  return std::string(out.c_str()) + "\n";
}

RunSummary offline_summary(const Scenario& scenario, std::int64_t periods, const std::function<bool()>& stop) {
  RunSummary s;
  s.sensors = static_cast<int>(scenario.sensors.size());
  for (const auto& sensor : scenario.sensors) {
    LinkSummary l;
    l.id = sensor.id;
    l.reported = true;
    s.links.push_back(l);
  }
  // The window rate's last kWindowSamples arrivals per link (observed_rate.hpp; offline one
  // sample per period, so the window is exactly kWindowSamples).
  std::vector<std::deque<bool>> window(s.links.size());
  std::vector<std::uint64_t> window_arrived(s.links.size(), 0);
  simulate_offline_run(scenario, scenario.seed, periods, [&](const OfflinePeriod& p) {
    if (stop && s.periods % 4096 == 0 && stop()) throw RunStopped();
    ++s.periods;
    ++s.periods_scored;
    ++s.periods_scored_final;  // no late sample offline: the final estimate is the in-time one
    s.sum_squared_error += p.squared_error;
    s.sum_squared_error_final += p.squared_error;
    s.sum_trace_P += p.trace_P;
    s.sum_trace_P_pred += p.trace_P_pred;
    s.fused += p.fused.size();
    s.periods_diverging += p.diverging;
    for (std::size_t i = 0; i < s.links.size(); ++i) {
      LinkSummary& l = s.links[i];
      ++l.samples;
      l.delivered += p.arrived[i];
      l.dropped += !p.arrived[i];
      window[i].push_back(p.arrived[i]);
      window_arrived[i] += p.arrived[i];
      if (window[i].size() > kWindowSamples) {
        window_arrived[i] -= window[i].front();
        window[i].pop_front();
      }
    }
    for (int id : p.fused)
      for (auto& l : s.links) l.fused += l.id == id;
  });
  for (std::size_t i = 0; i < s.links.size(); ++i) {
    LinkSummary& l = s.links[i];
    l.observed_rate_since_change = static_cast<double>(l.delivered) / static_cast<double>(l.samples);
    l.observed_window_samples = window[i].size();
    l.observed_rate_window = static_cast<double>(window_arrived[i]) / static_cast<double>(window[i].size());
  }
  return s;
}

std::vector<std::optional<double>> summary_values(const RunSummary& summary, const std::vector<std::string>& names) {
  std::vector<std::optional<double>> out;
  for (const auto& name : names) {
    const Measured m = measure(summary, name);
    out.push_back(m.measured() && std::isfinite(m.value) ? std::optional<double>(m.value) : std::nullopt);
  }
  return out;
}

std::vector<std::optional<double>> summary_values(const nlohmann::json& summary, const std::vector<std::string>& names) {
  std::vector<std::optional<double>> out;
  for (const auto& name : names) {
    const nlohmann::json* node = &summary;
    std::size_t start = 0;
    // link.ID.q: the JSON nests links under "link" → "ID" → q; a run quantity is one key.
    const bool link = name.rfind("link.", 0) == 0;
    while (node && node->is_object()) {
      const auto dot = link ? name.find('.', start) : std::string::npos;
      const std::string key = name.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
      const auto it = node->find(key);
      node = it == node->end() ? nullptr : &*it;
      if (dot == std::string::npos) break;
      start = dot + 1;
    }
    out.push_back(node && node->is_number() ? std::optional<double>(node->get<double>()) : std::nullopt);
  }
  return out;
}

Theory point_theory(const Scenario& scenario) {
  const theory::AnalysisReport r = theory::analyze(scenario, theory::AnalyzeOptions{});
  Theory t;
  if (r.stable != theory::Verdict::unknown) t.stable = r.stable == theory::Verdict::yes;
  t.trace_S_bar = r.lower_trace;
  t.trace_V_bar = r.upper_trace;
  t.trace_P_sampled = r.sampled_trace;
  t.trace_P_sampled_se = r.sampled_trace_standard_error;
  if (r.markov_criterion) t.critical_margin = 1.0 - *r.markov_criterion;
  return t;
}

}  // namespace netkf::cli::sweep
