#include "netkf/cli/theory/fit_text.hpp"
#include "netkf/cli/theory/theory_text.hpp"
#include "netkf/links/link_text.hpp"

#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>

namespace netkf::cli {

using nlohmann::json;

namespace {

// Six significant digits: what a person pastes into a scenario (the intervals are wider).
std::string g6(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

std::string show(const std::optional<double>& v, const char* missing = "-") { return v ? g6(*v) : missing; }

json run_test_json(const fit::RunLengthTest& t) {
  json bins = json::array();
  for (const auto& b : t.bins)
    bins.push_back({{"from", b.from}, {"to", b.to < 0 ? json(nullptr) : json(b.to)}, {"observed", b.observed},
                    {"expected", b.expected}});
  return {{"runs", t.runs},
          {"chi_square", number_or_null(t.chi_square)},
          {"degrees_of_freedom", t.chi_square ? json(t.degrees_of_freedom) : json(nullptr)},
          {"p_value", number_or_null(t.p_value)},
          {"bins", bins}};
}

json delay_json(const std::optional<fit::DelaySummary>& d) {
  if (!d) return nullptr;
  json q = json::object();
  for (const auto& [p, v] : d->quantiles) q[g6(p)] = v;
  return {{"samples", d->samples}, {"mean_ms", d->mean_ms}, {"jitter_ms", d->jitter_ms}, {"quantiles", q}};
}

// One family's fit: its link, numbers, errors and tests.
json candidate_json(const fit::LossFit& f, const std::optional<fit::DelaySummary>& delay) {
  json j;
  j["family"] = fit::to_string(f.family);
  j["link"] = fitted_link_json(f, delay);
  j["loss"] = f.loss.value;
  j["mean_burst"] = number_or_null(f.mean_burst.value);
  json se = json::object(), ci = json::object();
  for (const auto* v : {&f.loss, &f.mean_burst}) {
    se[v->name] = number_or_null(v->stderr_value);
    ci[v->name] = v->ci_low ? json::array({*v->ci_low, *v->ci_high}) : json(nullptr);
  }
  for (const auto& v : f.parameters) {
    if (!v.free) continue;
    se[v.name] = number_or_null(v.stderr_value);
    ci[v.name] = v.ci_low ? json::array({*v.ci_low, *v.ci_high}) : json(nullptr);
  }
  j["stderr"] = se;
  j["ci95"] = ci;
  j["log_likelihood"] = f.log_likelihood;
  j["aic"] = f.aic;
  j["free_parameters"] = fit::free_parameters(f.family);
  j["gof"] = {{"bursts", run_test_json(f.bursts)}, {"gaps", run_test_json(f.gaps)}};
  j["method"] = f.starts == 0 ? "closed form" : "Baum-Welch";
  if (f.starts > 0) j["em"] = {{"starts", f.starts}, {"iterations", f.iterations}, {"converged", f.converged}};
  j["notes"] = f.notes;
  return j;
}

}  // namespace

std::string fitted_link_text(const fit::LossFit& fit, const std::optional<fit::DelaySummary>& delay) {
  std::string text = "{ model: " + link_model_name(fit.link);
  for (const auto& [key, value] : link_parameters(fit.link)) text += ", " + key + ": " + g6(value);
  if (delay) text += ", delay_ms: " + g6(delay->mean_ms) + ", jitter_ms: " + g6(delay->jitter_ms) + ", delay_distribution: normal";
  return text + " }";
}

json fitted_link_json(const fit::LossFit& fit, const std::optional<fit::DelaySummary>& delay) {
  json j;
  j["model"] = link_model_name(fit.link);
  for (const auto& [key, value] : link_parameters(fit.link)) j[key] = value;
  if (delay) {
    j["delay_ms"] = delay->mean_ms;
    j["jitter_ms"] = delay->jitter_ms;
    j["delay_distribution"] = "normal";
  }
  return j;
}

json fit_json(const std::string& trace_name, const fit::TraceFit& r,
              const std::optional<fit::DelaySummary>& delay) {
  const fit::LossFit& f = r.fit();
  json j = candidate_json(f, delay);
  // The chosen fit's link keys flat beside `model`, as a scenario's link takes them.
  json flat;
  flat["trace"] = trace_name;
  flat["samples"] = r.samples;
  flat["dropped"] = r.dropped;
  flat["model"] = link_model_name(f.link);
  for (const auto& [key, value] : link_parameters(f.link)) flat[key] = value;
  flat.update(j);  // `loss` of a bernoulli link is its key and its stationary loss alike
  flat["why"] = r.why;
  flat["candidates"] = json::array();
  for (const auto& c : r.candidates) flat["candidates"].push_back(candidate_json(c, delay));
  flat["delay"] = delay_json(delay);
  flat["trace_notes"] = r.notes;
  return flat;
}

namespace {

std::string interval(const fit::FittedValue& v) {
  if (!v.free) return "(fixed by the family)";
  if (!v.ci_low) return "-";
  return "[" + g6(*v.ci_low) + ", " + g6(*v.ci_high) + "]";
}

void print_value(std::ostream& out, const fit::FittedValue& v) {
  out << "  " << std::left << std::setw(11) << v.name << std::setw(12) << g6(v.value) << std::setw(12)
      << (v.free ? show(v.stderr_value) : "") << interval(v) << "\n";
}

// The test's line, and with `table` its bins: observed against expected runs.
void print_run_test(std::ostream& out, const char* what, const fit::RunLengthTest& t, bool table) {
  out << "  " << what << ": " << t.runs << " complete runs";
  if (!t.chi_square) {
    out << ", too few for a chi-square test\n";
    return;
  }
  out << ", chi-square " << g6(*t.chi_square) << " on " << t.degrees_of_freedom << " dof, p = " << show(t.p_value)
      << (table ? "" : " (bins: --json)") << "\n";
  if (!table) return;
  out << "    length    observed  expected\n";
  for (const auto& b : t.bins) {
    const std::string range = b.to < 0 ? std::to_string(b.from) + "+"
                              : b.from == b.to ? std::to_string(b.from)
                                               : std::to_string(b.from) + "-" + std::to_string(b.to);
    char expected[32];
    std::snprintf(expected, sizeof expected, "%.1f", b.expected);
    out << "    " << std::left << std::setw(10) << range << std::right << std::setw(8)
        << static_cast<long long>(b.observed) << std::setw(10) << expected << "\n";
  }
}

void print_candidates(std::ostream& out, const fit::TraceFit& r) {
  double least = r.candidates.front().aic;
  for (const auto& c : r.candidates) least = std::min(least, c.aic);
  out << "  family           params  log-likelihood  AIC           dAIC        bursts p     gaps p\n";
  for (std::size_t i = 0; i < r.candidates.size(); ++i) {
    const auto& c = r.candidates[i];
    out << (i == r.chosen ? "* " : "  ") << std::left << std::setw(17) << fit::to_string(c.family) << std::setw(8)
        << fit::free_parameters(c.family) << std::setw(16) << g6(c.log_likelihood) << std::setw(14) << g6(c.aic)
        << std::setw(12) << ("+" + g6(c.aic - least)) << std::setw(13) << show(c.bursts.p_value) << show(c.gaps.p_value)
        << "\n";
  }
}

void print_delay(std::ostream& out, const fit::DelaySummary& d) {
  out << "delay of the " << d.samples << " delivered samples: mean " << g6(d.mean_ms) << " ms, jitter (std) "
      << g6(d.jitter_ms) << " ms\n  quantiles:";
  for (const auto& [q, v] : d.quantiles)
    out << "  " << (q == 0.0 ? "min" : q == 1.0 ? "max" : g6(100 * q) + "%") << " " << g6(v);
  out << " ms\n";
}

}  // namespace

void print_fit(std::ostream& out, const std::string& trace_name, const fit::TraceFit& r,
               const std::optional<fit::DelaySummary>& delay) {
  const fit::LossFit& f = r.fit();
  out << "trace " << trace_name << ": " << r.samples << " samples, " << r.dropped << " dropped ("
      << g6(100.0 * static_cast<double>(r.dropped) / static_cast<double>(r.samples)) << "%)\n";
  print_candidates(out, r);
  out << "chosen: " << fit::to_string(f.family) << " (" << r.why << ")\n";
  for (const auto& n : r.notes) out << "note: " << n << "\n";
  out << "\n" << fit::to_string(f.family) << " fit ("
      << (f.starts == 0 ? std::string("closed form")
                        : "Baum-Welch, " + std::to_string(f.starts) + " seeded starts, " +
                              std::to_string(f.iterations) + " iterations") << "; 95% intervals from the observed information)\n";
  out << "  key        value       stderr      95% interval\n";
  for (const auto& v : f.parameters) print_value(out, v);
  if (f.family != fit::LossFamily::bernoulli) print_value(out, f.loss);  // else it is the parameter
  print_value(out, f.mean_burst);
  print_run_test(out, "burst lengths (runs of drops)", f.bursts, true);
  print_run_test(out, "gap lengths (runs of deliveries)", f.gaps, false);
  for (const auto& n : f.notes) out << "  note: " << n << "\n";
  if (delay) print_delay(out, *delay);
  out << "scenario link: " << fitted_link_text(f, delay) << "\n";
}

}  // namespace netkf::cli
