#include "netkf/cli/theory/measured_links.hpp"
#include "netkf/links/link_trace.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "netkf/cli/theory/fit_text.hpp"
#include "netkf/cli/theory/theory_text.hpp"

namespace netkf::cli {

using nlohmann::json;

namespace {

std::string g6(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

std::pair<int, std::string> parse_spec(const std::string& spec) {
  const auto eq = spec.find('=');
  const std::string id_text = eq == std::string::npos ? "" : spec.substr(0, eq);
  std::size_t used = 0;
  int id = 0;
  try {
    id = std::stoi(id_text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (id_text.empty() || used != id_text.size() || eq + 1 >= spec.size())
    throw std::invalid_argument("--link '" + spec + "': expected ID=TRACE.csv (a link id of the scenario, a trace file)");
  return {id, spec.substr(eq + 1)};
}

json boundary_json(const fit::LinkBoundary& b) {
  return {{"critical", number_or_null(b.critical)}, {"searched_to", b.limit}, {"text", b.text}};
}

}  // namespace

std::vector<MeasuredLink> fit_measured_links(Scenario& scenario, const std::vector<std::string>& specs) {
  std::vector<MeasuredLink> links;
  for (const auto& spec : specs) {
    MeasuredLink m;
    std::tie(m.link_id, m.trace) = parse_spec(spec);
    auto sensor = std::find_if(scenario.sensors.begin(), scenario.sensors.end(),
                               [&](const SensorSpec& s) { return s.id == m.link_id; });
    if (sensor == scenario.sensors.end())
      throw std::invalid_argument("--link " + std::to_string(m.link_id) + ": no such link in the scenario");
    if (std::any_of(links.begin(), links.end(), [&](const MeasuredLink& l) { return l.link_id == m.link_id; }))
      throw std::invalid_argument("--link " + std::to_string(m.link_id) + " given twice");
    const LinkTrace trace = read_link_trace_file(m.trace);
    m.fit = fit::fit_loss_model(trace.delivered);
    if (trace.has_delay) m.delay = fit::summarize_delays(trace.delay_ms);
    sensor->link = fit::fitted_link_spec(sensor->link, m.fit.fit(), m.delay);
    links.push_back(std::move(m));
  }
  return links;
}

void judge_measured_links(const Scenario& scenario, std::vector<MeasuredLink>& links) {
  for (auto& m : links) m.verdict = fit::measured_link_verdict(scenario, m.link_id, m.fit.fit());
}

json measured_links_json(const std::vector<MeasuredLink>& links) {
  json out = json::array();
  for (const auto& m : links) {
    const auto& v = m.verdict;
    const auto& f = m.fit.fit();
    json corners = json::array();
    for (const auto& c : v.interval_corners)
      corners.push_back({{"loss", c.loss}, {"mean_burst", c.mean_burst}, {"criterion", number_or_null(c.criterion)}});
    out.push_back({{"link", m.link_id},
                   {"trace", m.trace},
                   {"family", fit::to_string(f.family)},
                   {"fitted_link", fitted_link_json(f, m.delay)},
                   {"loss", v.loss},
                   {"mean_burst", number_or_null(v.mean_burst)},
                   {"ci95", {{"loss", f.loss.ci_low ? json::array({*f.loss.ci_low, *f.loss.ci_high}) : json(nullptr)},
                             {"mean_burst", f.mean_burst.ci_low ? json::array({*f.mean_burst.ci_low, *f.mean_burst.ci_high})
                                                                : json(nullptr)}}},
                   {"why", m.fit.why},
                   {"markov_criterion", number_or_null(v.criterion)},
                   {"stable", theory::to_string(v.stable)},
                   {"equivalent_criterion", number_or_null(v.equivalent_criterion)},
                   {"loss_margin", boundary_json(v.loss_boundary)},
                   {"mean_burst_margin", boundary_json(v.burst_boundary)},
                   {"interval_corners", corners},
                   {"across_interval", v.across_interval}});
  }
  return out;
}

void print_measured_links(std::ostream& out, const std::vector<MeasuredLink>& links) {
  for (const auto& m : links) {
    const auto& v = m.verdict;
    const auto& f = m.fit.fit();
    out << "measured link " << m.link_id << " (" << m.trace << ")\n";
    out << "  fitted         " << fit::to_string(f.family) << ": " << fitted_link_text(f, m.delay) << "\n";
    out << "  loss           " << g6(v.loss);
    if (f.loss.ci_low) out << "  95% [" << g6(*f.loss.ci_low) << ", " << g6(*f.loss.ci_high) << "]";
    out << "\n  mean burst     " << g6(v.mean_burst);
    if (f.mean_burst.ci_low) out << "  95% [" << g6(*f.mean_burst.ci_low) << ", " << g6(*f.mean_burst.ci_high) << "]";
    out << "\n  Markov criterion " << (v.criterion ? g6(*v.criterion) : std::string("does not apply"))
        << " -> stable " << theory::to_string(v.stable) << "\n";
    if (v.equivalent_criterion && v.criterion && std::abs(*v.equivalent_criterion - *v.criterion) > 1e-9)
      out << "  (as the simple Gilbert channel of the same loss and mean burst, which the margins move along: "
          << g6(*v.equivalent_criterion) << ")\n";
    out << "  margin in loss       " << v.loss_boundary.text << "\n";
    out << "  margin in mean burst " << v.burst_boundary.text << "\n";
    out << "  within the fit       " << v.across_interval << "\n";
  }
}

}  // namespace netkf::cli
