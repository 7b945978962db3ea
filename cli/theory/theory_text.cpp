#include "netkf/cli/theory/theory_text.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace netkf::cli {

using nlohmann::json;

nlohmann::json number_or_null(const std::optional<double>& v) {
  if (!v || !std::isfinite(*v)) return nullptr;
  return *v;
}

namespace {

using cli::number_or_null;  // the optional form, beside this one
json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json actuation_json(const theory::ActuationReport& a) {
  json j;
  j["link"] = a.link;
  j["on_loss"] = to_string(a.on_loss);
  j["acknowledged"] = a.acknowledged;
  j["deadline_ms"] = number_or_null(a.deadline_ms);
  j["loss"] = number_or_null(a.loss);
  j["in_time"] = number_or_null(a.in_time);
  j["arrival_rate"] = number_or_null(a.arrival_rate);
  j["mss_radius"] = number_or_null(a.mss_radius);
  j["critical_rate"] = number_or_null(a.critical_rate);
  j["critical_rate_reason"] = a.critical_rate_reason;
  j["critical_rate_lower"] = number_or_null(a.critical_rate_lower);
  j["stable"] = theory::to_string(a.stable);
  j["stable_reason"] = a.stable_reason;
  j["gain"] = a.gain;
  j["gain_arrival_rate"] = number_or_null(a.gain_arrival_rate);
  if (a.optimal) {
    j["optimal_critical_rate"] = {{"lower", number_or_null(a.optimal->lower)},
                                  {"upper", number_or_null(a.optimal->upper)},
                                  {"upper_iteration", number_or_null(a.optimal->upper_iteration)}};
  } else {
    j["optimal_critical_rate"] = nullptr;
  }
  j["cost"] = {{"lower", number_or_null(a.cost_lower)}, {"upper", number_or_null(a.cost_upper)}, {"reason", a.cost_reason}};
  return j;
}

json report_json(const theory::AnalysisReport& r) {
  json j;
  j["spectral_radius"] = number_or_null(r.spectral_radius);
  j["stable"] = theory::to_string(r.stable);
  j["stable_reason"] = r.stable_reason;
  j["expected_covariance"] = {{"lower_trace", number_or_null(r.lower_trace)},
                              {"upper_trace", number_or_null(r.upper_trace)},
                              {"upper_method", r.iid_bounds ? json(theory::to_string(r.upper_method)) : json(nullptr)},
                              {"upper_trace_standard_error", number_or_null(r.upper_trace_standard_error)},
                              {"sampled_trace", number_or_null(r.sampled_trace)},
                              {"sampled_trace_standard_error", number_or_null(r.sampled_trace_standard_error)}};
  if (r.critical_rate) {
    const auto& cr = *r.critical_rate;
    j["critical_rate"] = {{"lower", number_or_null(cr.lower)},
                          {"upper", number_or_null(cr.upper)},
                          {"upper_iteration", number_or_null(cr.upper_iteration)},
                          {"exact", number_or_null(cr.exact)}};
  } else {
    j["critical_rate"] = nullptr;
  }
  j["markov_criterion"] = number_or_null(r.markov_criterion);
  j["second_order_criterion"] = number_or_null(r.second_order_criterion);
  j["links"] = json::array();
  for (const auto& l : r.links)
    j["links"].push_back({{"sensor_id", l.sensor_id},
                          {"loss", number_or_null(l.loss)},
                          {"in_time", number_or_null(l.in_time)},
                          {"effective_arrival_rate", number_or_null(l.effective_arrival_rate)}});
  if (r.final_estimate) {
    const auto& f = *r.final_estimate;
    json links = json::array();
    for (const auto& l : f.links)
      links.push_back({{"sensor_id", l.sensor_id},
                       {"loss", number_or_null(l.loss)},
                       {"in_time", number_or_null(l.in_time)},
                       {"effective_arrival_rate", number_or_null(l.effective_arrival_rate)}});
    j["final_estimate"] = {{"max_delay_periods", f.max_delay_periods},
                           {"horizon_ms", number_or_null(f.horizon_ms)},
                           {"stable", theory::to_string(f.stable)},
                           {"stable_reason", f.stable_reason},
                           {"expected_covariance",
                            {{"lower_trace", number_or_null(f.lower_trace)},
                             {"upper_trace", number_or_null(f.upper_trace)},
                             {"upper_method", f.iid_bounds ? json(theory::to_string(f.upper_method)) : json(nullptr)},
                             {"upper_trace_standard_error", number_or_null(f.upper_trace_standard_error)}}},
                           {"markov_criterion", number_or_null(f.markov_criterion)},
                           {"links", std::move(links)}};
  } else {
    j["final_estimate"] = nullptr;
  }
  // Only with an actuation link (plant.control.link): absent otherwise, so the output of a
  // scenario without one is unchanged.
  if (r.actuation) {
    j["estimator_stable"] = theory::to_string(r.estimator_stable);
    j["estimator_stable_reason"] = r.estimator_stable_reason;
    j["actuation"] = actuation_json(*r.actuation);
  }
  j["notes"] = r.notes;
  return j;
}

std::string show(const std::optional<double>& v, const char* missing = "unbounded") {
  if (!v) return missing;
  std::ostringstream os;
  os << std::setprecision(6) << *v;
  return os.str();
}

// Tr V̄ as the report has it: a sampled value says so, with its standard error.
std::string show_upper(const std::optional<double>& v, const char* missing, theory::BoundMethod method,
                       const std::optional<double>& standard_error) {
  if (!v || method != theory::BoundMethod::sampled) return show(v, missing);
  return show(v) + " +/- " + show(standard_error) + " (SAMPLED estimate, not a bound)";
}

}  // namespace

namespace {
void print_final_estimate(std::ostream& out, const theory::FinalEstimateReport& f) {
  out << "  final estimate (late_policy fuse_within, D = " << f.max_delay_periods << ": samples within "
      << show(f.horizon_ms) << " ms)\n";
  out << "    stable                   " << theory::to_string(f.stable);
  if (!f.stable_reason.empty()) out << " (" << f.stable_reason << ")";
  out << "\n";
  const char* missing = f.iid_bounds ? "unbounded" : "not reported (links not i.i.d., see notes)";
  out << "    Tr S-bar (lower bound)   " << show(f.lower_trace, missing) << "\n";
  out << "    Tr V-bar (upper bound)   " << show_upper(f.upper_trace, missing, f.upper_method, f.upper_trace_standard_error)
      << "\n";
  out << "    Markov criterion         " << show(f.markov_criterion, "n/a") << "\n";
  out << "    links: id  loss  P(delay <= horizon)  final arrival rate\n";
  for (const auto& l : f.links)
    out << "      " << std::setw(4) << l.sensor_id << "  " << std::setw(9) << show(l.loss) << "  " << std::setw(9)
        << show(l.in_time) << "  " << std::setw(9) << show(l.effective_arrival_rate) << "\n";
}
}  // namespace

namespace {
void print_actuation(std::ostream& out, const theory::AnalysisReport& r) {
  const auto& a = *r.actuation;
  out << "  estimator alone            " << theory::to_string(r.estimator_stable) << " ("
      << r.estimator_stable_reason << ")\n";
  out << "  actuation link             " << a.link << ", " << to_string(a.on_loss) << " on loss, "
      << (a.acknowledged ? "acknowledged (TCP-like)" : "unacknowledged (UDP-like)") << "\n";
  out << "    arrival rate nu          " << show(a.arrival_rate) << " = (1 - loss " << show(a.loss)
      << ") * P(delay <= " << show(a.deadline_ms) << " ms) " << show(a.in_time) << "\n";
  out << "    stable                   " << theory::to_string(a.stable) << " (" << a.stable_reason << ")\n";
  out << "    mean-square radius       " << show(a.mss_radius, "n/a") << "\n";
  out << "    critical rate            " << show(a.critical_rate, "none") << " (" << a.critical_rate_reason << ")\n";
  if (a.critical_rate_lower)
    out << "    any controller needs     nu > " << show(a.critical_rate_lower) << " (zero on loss: open loop while inputs are lost)\n";
  out << "    gain                     " << a.gain;
  if (a.gain_arrival_rate && *a.gain_arrival_rate < 1.0) out << " " << show(a.gain_arrival_rate);
  out << "\n";
  if (a.optimal)
    out << "    optimal controller nu_c  lower " << show(a.optimal->lower) << ", upper (LMI) "
        << show(a.optimal->upper, "none") << ", upper (iteration) " << show(a.optimal->upper_iteration, "none") << "\n";
  if (a.cost_lower || a.cost_upper)
    out << "    cost J                   between " << show(a.cost_lower) << " and " << show(a.cost_upper) << "\n";
  else
    out << "    cost J                   n/a (" << a.cost_reason << ")\n";
  if (r.actuation_region) {
    const auto& g = *r.actuation_region;
    out << "  region (sensor " << g.sensor_id << " x actuation): gamma -> estimator, nu below which unstable / above which stable"
        << " (gamma_c in [" << show(g.gamma_lower, "none") << ", " << show(g.gamma_upper, "none") << "])\n";
    for (const auto& p : g.points)
      out << "    " << std::setw(5) << p.gamma << "  " << std::setw(7) << theory::to_string(p.estimator) << "  "
          << std::setw(9) << show(p.nu_lower) << "  " << std::setw(9) << show(p.nu_upper, "none") << "\n";
  }
}
}  // namespace

void print_analysis(std::ostream& out, const Scenario& s, const theory::AnalysisReport& r) {
  out << "scenario " << s.name << " (" << s.state_dim() << " states, " << s.sensors.size() << " sensors)\n";
  out << "  spectral radius alpha      " << std::setprecision(6) << r.spectral_radius << "\n";
  out << "  stable                     " << theory::to_string(r.stable);
  if (!r.stable_reason.empty()) out << " (" << r.stable_reason << ")";
  out << "\n";
  const char* missing = r.iid_bounds ? "unbounded" : "not reported (links not i.i.d., see notes)";
  out << "  Tr S-bar (lower bound)     " << show(r.lower_trace, missing) << "\n";
  out << "  Tr V-bar (upper bound)     " << show_upper(r.upper_trace, missing, r.upper_method, r.upper_trace_standard_error)
      << "\n";
  if (r.sampled_trace)
    out << "  E[Tr P] (sampled)          " << show(r.sampled_trace) << " +/- " << show(r.sampled_trace_standard_error)
        << " (SAMPLED estimate over the links' loss sequences, not a bound)\n";
  out << "  Markov criterion           " << show(r.markov_criterion, "n/a") << "\n";
  out << "  links: id  loss  P(in time)  effective arrival rate (1 - loss) * P(in time)\n";
  for (const auto& l : r.links)
    out << "    " << std::setw(4) << l.sensor_id << "  " << std::setw(9) << show(l.loss) << "  " << std::setw(9)
              << show(l.in_time) << "  " << std::setw(9) << show(l.effective_arrival_rate) << "\n";
  if (r.final_estimate) print_final_estimate(out, *r.final_estimate);
  if (r.actuation) print_actuation(out, r);
  if (r.critical_rate) {
    const auto& cr = *r.critical_rate;
    out << "  critical arrival rate      lower " << show(cr.lower) << ", upper (LMI) " << show(cr.upper, "none")
              << ", upper (iteration) " << show(cr.upper_iteration, "none") << ", exact " << show(cr.exact, "n/a")
              << "\n";
  }
  if (!r.region.empty()) {
    out << "  stability region (Liu-Goldsmith): lambda1 -> lambda2 lower / upper / exact\n";
    for (const auto& p : r.region)
      out << "    " << std::setw(5) << p.lambda1 << "  " << std::setw(9) << show(p.lambda2_lower) << "  "
                << std::setw(9) << show(p.lambda2_upper, "none") << "  " << std::setw(9) << show(p.lambda2_exact, "n/a")
                << "\n";
  }
  if (!r.sweep.empty()) {
    out << "  sweep: lambda -> Tr S-bar / Tr V-bar\n";
    for (const auto& p : r.sweep)
      out << "    " << std::setw(5) << p.lambda << "  " << std::setw(12) << show(p.lower_trace) << "  "
                << std::setw(12) << show(p.upper_trace) << "\n";
  }
  for (const auto& n : r.notes) out << "  note: " << n << "\n";
}

json analysis_json(const theory::AnalysisReport& r, bool with_region, bool with_sweep) {
  json j = report_json(r);
  if (with_region) {
    json region = json::array();
    for (const auto& p : r.region)
      region.push_back({{"lambda1", p.lambda1},
                        {"lambda2_lower", number_or_null(p.lambda2_lower)},
                        {"lambda2_upper", number_or_null(p.lambda2_upper)},
                        {"lambda2_upper_iteration", number_or_null(p.lambda2_upper_iteration)},
                        {"lambda2_exact", number_or_null(p.lambda2_exact)}});
    j["region"] = region;
    if (r.actuation_region) {
      const auto& g = *r.actuation_region;
      json points = json::array();
      for (const auto& p : g.points)
        points.push_back({{"gamma", p.gamma},
                          {"estimator_stable", theory::to_string(p.estimator)},
                          {"nu_lower", number_or_null(p.nu_lower)},
                          {"nu_upper", number_or_null(p.nu_upper)}});
      j["actuation_region"] = {{"sensor_id", g.sensor_id},
                               {"gamma_lower", number_or_null(g.gamma_lower)},
                               {"gamma_upper", number_or_null(g.gamma_upper)},
                               {"points", std::move(points)}};
    }
  }
  if (with_sweep) {
    json sweep = json::array();
    for (const auto& p : r.sweep)
      sweep.push_back({{"lambda", p.lambda},
                       {"lower_trace", number_or_null(p.lower_trace)},
                       {"upper_trace", number_or_null(p.upper_trace)}});
    j["sweep"] = sweep;
  }
  return j;
}

json monte_carlo_json(const MonteCarloResult& r) {
  json j;
  auto put = [&](const char* key, const MeanSe& m) {
    j[key] = number_or_null(m.mean);
    j[std::string(key) + "_se"] = number_or_null(m.se);
  };
  put("mean_trace_P_pred", r.trace_P_pred);
  put("mean_trace_P_filt", r.trace_P_filt);
  put("mean_sq_error_pred", r.sq_error_pred);
  put("mean_sq_error_filt", r.sq_error_filt);
  j["diverged_fraction"] = r.diverged_fraction;
  j["runs"] = r.runs;
  j["steps"] = r.steps;
  j["seed"] = r.seed;
  j["kernel"] = r.used_fixed_size_kernel ? "fast" : "reference";
  return j;
}

void print_monte_carlo(std::ostream& out, const Scenario& s, const MonteCarloResult& r) {
  out << "scenario " << s.name << ": " << r.runs << " runs x " << r.steps << " steps, seed " << r.seed << " ("
      << (r.used_fixed_size_kernel ? "fixed-size" : "reference") << " kernel)\n"
      << std::setprecision(6) << "  at k = " << r.steps - 1 << " (mean +/- standard error):\n"
      << "  Tr P_{k|k-1}        " << r.trace_P_pred.mean << " +/- " << r.trace_P_pred.se << "\n"
      << "  Tr P_{k|k}          " << r.trace_P_filt.mean << " +/- " << r.trace_P_filt.se << "\n"
      << "  |x - x^_{k|k-1}|^2  " << r.sq_error_pred.mean << " +/- " << r.sq_error_pred.se << "\n"
      << "  |x - x^_{k|k}|^2    " << r.sq_error_filt.mean << " +/- " << r.sq_error_filt.se << "\n"
      << "  diverged fraction   " << r.diverged_fraction << "\n";
}

}  // namespace netkf::cli
