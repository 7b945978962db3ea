// The theory toolkit for Python: analyze, critical_rate, bounds, markov_criterion, simulate, fit.
// Where the CLI prints JSON, the binding returns the same JSON as Python objects (py_convert.hpp),
// so the names are the CLI's (docs/architecture.md, "Contracts"; docs/cli.md, "netkf fit"). The
// GIL is released while the core computes.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <optional>
#include <variant>

#include "bindings.hpp"
#include "netkf/cli/theory/fit_text.hpp"
#include "netkf/fit/loss_fit.hpp"
#include "netkf/links/link_trace.hpp"
#include "netkf/sim/monte_carlo.hpp"
#include "netkf/theory/markov.hpp"
#include "netkf/theory/report.hpp"
#include "py_convert.hpp"
#include "netkf/cli/theory/theory_text.hpp"

namespace netkf::python {
namespace {

using nlohmann::json;

double or_nan(const std::optional<double>& v) { return v ? *v : std::numeric_limits<double>::quiet_NaN(); }

py::object number_or_none(const std::optional<double>& v) { return v ? py::object(py::float_(*v)) : py::none(); }

py::dict analyze_binding(const Scenario& scenario, bool region, bool sweep, std::optional<int> points, bool lmi,
                         std::optional<int> region_sensor) {
  if (points && (*points < 2 || *points > 10001)) throw py::value_error("points: 2 .. 10001");
  if (region_sensor && !region) throw py::value_error("region_sensor needs region=True");
  if (region_sensor && !scenario.find_sensor(*region_sensor))
    throw py::value_error("region_sensor: the scenario has no sensor " + std::to_string(*region_sensor));
  theory::AnalyzeOptions o;
  o.region = region;
  o.sweep = sweep;
  o.use_lmi = lmi;
  o.region_sensor = region_sensor;
  if (points) o.region_points = o.sweep_points = *points;
  json j;
  {
    py::gil_scoped_release release;
    j = cli::analysis_json(theory::analyze(scenario, o), region, sweep);
  }
  return to_python(j);
}

py::dict critical_rate_binding(const Scenario& scenario, bool lmi) {
  if (scenario.sensors.empty()) throw py::value_error("critical_rate: the scenario has no sensors");
  theory::CriticalRateOptions o;  // the links' models are not read: every link Bernoulli at λ
  o.use_lmi = lmi;
  std::vector<std::string> notes;
  theory::CriticalRates cr;
  {
    py::gil_scoped_release release;
    cr = theory::shared_critical_rates(scenario.plant.A, scenario.plant.Q, scenario.sensors, o, &notes);
  }
  py::dict out;
  out["lower"] = cr.lower;  // the keys of analyze()'s "critical_rate"
  out["upper"] = number_or_none(cr.upper);
  out["upper_iteration"] = number_or_none(cr.upper_iteration);
  out["exact"] = number_or_none(cr.exact);
  out["notes"] = notes;
  return out;
}

// arrival_rates: 1-D (each entry a rate every sensor shares) or 2-D (points x sensors).
py::tuple bounds_binding(const Scenario& scenario, const py::handle& arrival_rates) {
  const std::size_t d = scenario.sensors.size();
  if (d == 0) throw py::value_error("bounds: the scenario has no sensors");
  std::vector<std::vector<double>> points;
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(arrival_rates);
  if (!a) throw py::value_error("arrival_rates: not an array of numbers");
  if (a.ndim() == 2) {
    if (static_cast<std::size_t>(a.shape(1)) != d)
      throw py::value_error("arrival_rates: " + std::to_string(a.shape(1)) + " columns for " + std::to_string(d) +
                            " sensors (2-D: one row per point, one column per sensor)");
    for (py::ssize_t i = 0; i < a.shape(0); ++i) points.push_back(rates_argument(a[py::int_(i)], "arrival_rates"));
  } else if (a.ndim() <= 1) {
    for (double rate : rates_argument(a, "arrival_rates")) points.emplace_back(d, rate);
  } else {
    throw py::value_error("arrival_rates: 1-D (a shared rate per point) or 2-D (points x sensors)");
  }
  py::array_t<double> lower(static_cast<py::ssize_t>(points.size())), upper(static_cast<py::ssize_t>(points.size()));
  auto lo = lower.mutable_unchecked<1>();
  auto up = upper.mutable_unchecked<1>();
  {
    py::gil_scoped_release release;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const auto b = theory::iid_trace_bounds(scenario.plant.A, scenario.plant.Q, scenario.sensors, points[i],
                                                scenario.seed);
      lo(static_cast<py::ssize_t>(i)) = or_nan(b.lower_trace);
      up(static_cast<py::ssize_t>(i)) = or_nan(b.upper_trace);
    }
  }
  return py::make_tuple(lower, upper);
}

py::dict markov_binding(const Scenario& scenario, const py::object& arrival_rates) {
  Scenario effective = with_effective_links(scenario);
  if (!arrival_rates.is_none()) {
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(arrival_rates);
    std::vector<double> rates = rates_argument(arrival_rates, "arrival_rates");
    if (a && a.ndim() == 0) rates.assign(effective.sensors.size(), rates.front());
    if (rates.size() != effective.sensors.size())
      throw py::value_error("arrival_rates: " + std::to_string(rates.size()) + " rates for " +
                            std::to_string(effective.sensors.size()) + " sensors");
    for (std::size_t i = 0; i < rates.size(); ++i) effective.sensors[i].link.loss = BernoulliLink{1.0 - rates[i]};
  }
  theory::MarkovCriterion c;
  {
    py::gil_scoped_release release;
    c = theory::markov_stability_criterion(effective.plant.A, effective.sensors);
  }
  py::dict out;
  out["applies"] = c.applies;
  out["value"] = c.applies ? py::object(py::float_(c.value)) : py::none();
  out["exact"] = c.exact;
  out["stable"] = c.stable();
  out["reasons"] = c.reasons;
  py::list blocks;
  for (const auto& b : c.blocks) {
    py::dict block;
    block["modulus"] = b.modulus;
    block["dimension"] = b.dimension;
    block["deficiency_rate"] = b.deficiency_rate;
    block["criterion"] = b.criterion;
    block["chain_states"] = b.chain_states;
    block["method"] = b.method;
    block["observing_sensors"] = b.observing_sensors;
    block["classes"] = b.classes;
    if (b.method == "bounds") {
      block["criterion_lower"] = b.criterion_lower;
      block["criterion_upper"] = b.criterion_upper;
    }
    blocks.append(block);
  }
  out["blocks"] = blocks;
  return out;
}

py::dict simulate_binding(const Scenario& scenario, int runs, int steps, std::optional<std::uint64_t> seed,
                          int threads, const std::string& kernel, bool series) {
  if (runs < 1 || steps < 1) throw py::value_error("runs and steps must be at least 1");
  if (threads < 0 || threads > 1024) throw py::value_error("threads: 0 (all cores) .. 1024");
  MonteCarloOptions o;
  o.runs = runs;
  o.steps = steps;
  o.seed = seed;
  o.threads = threads;
  o.record_series = series;
  if (kernel == "reference") o.kernel = MonteCarloOptions::Kernel::reference;
  else if (kernel == "fast") o.kernel = MonteCarloOptions::Kernel::fixed_size;
  else if (kernel != "auto") throw py::value_error("kernel: auto, reference or fast");
  MonteCarloResult r;
  {
    py::gil_scoped_release release;
    r = run_monte_carlo(scenario, o);
  }
  py::dict out = to_python(cli::monte_carlo_json(r));
  if (series) {
    const auto n = static_cast<py::ssize_t>(r.series.size());
    py::array_t<std::int64_t> step(n);
    py::array_t<double> trace(n), trace_se(n), error(n), error_se(n);
    for (py::ssize_t i = 0; i < n; ++i) {
      const auto& p = r.series[static_cast<std::size_t>(i)];
      step.mutable_at(i) = p.step;
      trace.mutable_at(i) = p.trace_P_pred.mean;
      trace_se.mutable_at(i) = p.trace_P_pred.se;
      error.mutable_at(i) = p.sq_error_pred.mean;
      error_se.mutable_at(i) = p.sq_error_pred.se;
    }
    py::dict s;
    s["step"] = step;
    s["mean_trace_P_pred"] = trace;
    s["mean_trace_P_pred_se"] = trace_se;
    s["mean_sq_error_pred"] = error;
    s["mean_sq_error_pred_se"] = error_se;
    out["series"] = s;
  }
  return out;
}

// trace: a trace file's path (str), or the arrivals as an array of 0/1 (True/False).
py::dict fit_binding(const py::object& trace, const std::string& model, std::uint64_t seed) {
  fit::LossFitOptions o;
  if (model != "auto") {
    o.family = fit::parse_loss_family(model);
    if (!o.family) throw py::value_error("model: auto, bernoulli, simple_gilbert, gilbert or gilbert_elliott");
  }
  o.seed = seed;
  LinkTrace t;
  std::string name = "<array>";
  if (py::isinstance<py::str>(trace)) {
    name = trace.cast<std::string>();
    py::gil_scoped_release release;
    t = read_link_trace_file(name);
  } else {
    const Vector v = vector_argument(trace, "trace");
    t.delivered.reserve(static_cast<std::size_t>(v.size()));
    for (Eigen::Index i = 0; i < v.size(); ++i) {
      if (v(i) != 0.0 && v(i) != 1.0)
        throw py::value_error("trace: sample " + std::to_string(i) + " is " + std::to_string(v(i)) +
                              "; an arrival is 1 (delivered) or 0 (lost)");
      t.delivered.push_back(v(i) == 1.0 ? 1 : 0);
    }
  }
  if (t.delivered.empty()) throw py::value_error("trace: empty");
  fit::TraceFit f;
  std::optional<fit::DelaySummary> delay;
  {
    py::gil_scoped_release release;
    f = fit::fit_loss_model(t.delivered, o);
    if (t.has_delay) delay = fit::summarize_delays(t.delay_ms);
  }
  return to_python(cli::fit_json(name, f, delay));
}

}  // namespace

void bind_theory(py::module_& m) {
  m.def("analyze", &analyze_binding, py::arg("scenario"), py::arg("region") = false, py::arg("sweep") = false,
        py::arg("points") = py::none(), py::arg("lmi") = true, py::arg("region_sensor") = py::none(),
        "`netkf analyze --json` as a dict");
  m.def("critical_rate", &critical_rate_binding, py::arg("scenario"), py::arg("lmi") = true,
        "the critical arrival rates with every link Bernoulli at one shared rate");
  m.def("bounds", &bounds_binding, py::arg("scenario"), py::arg("arrival_rates"),
        "(Tr S-bar, Tr V-bar) at each point of arrival rates; NaN: unbounded");
  m.def("markov_criterion", &markov_binding, py::arg("scenario"), py::arg("arrival_rates") = py::none(),
        "the necessary-and-sufficient Markov criterion for the scenario's links (or Bernoulli at arrival_rates)");
  m.def("simulate", &simulate_binding, py::arg("scenario"), py::arg("runs") = 1000, py::arg("steps") = 300,
        py::arg("seed") = py::none(), py::arg("threads") = 0, py::arg("kernel") = "auto", py::arg("series") = true,
        "`netkf simulate --json` as a dict, with the per-step means under 'series'");
  m.def("fit", &fit_binding, py::arg("trace"), py::arg("model") = "auto", py::arg("seed") = 1,
        "`netkf fit --json` as a dict");
}

}  // namespace netkf::python
