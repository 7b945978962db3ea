// `netkf analyze`: assemble what the papers decide about a scenario (see theory/report.hpp).
#include "netkf/theory/report.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <complex>
#include <sstream>
#include <stdexcept>
#include <variant>

#include "netkf/links/link_delay.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/support/gaussian.hpp"
#include "netkf/theory/arrival_groups.hpp"
#include "netkf/theory/markov.hpp"
#include "netkf/theory/riccati.hpp"
#include "sampled_covariance.hpp"
#include "netkf/theory/stability.hpp"

namespace netkf::theory {
namespace {


Matrix stacked_C(const Scenario& s) {
  Eigen::Index m = 0;
  for (const auto& sensor : s.sensors) m += sensor.C.rows();
  Matrix C(m, s.state_dim());
  Eigen::Index row = 0;
  for (const auto& sensor : s.sensors) {
    C.middleRows(row, sensor.C.rows()) = sensor.C;
    row += sensor.C.rows();
  }
  return C;
}

// PBH test: every eigenvalue with |λ| ≥ 1 must be observable through C.
bool detectable(const Matrix& A, const Matrix& C) {
  using CM = Eigen::MatrixXcd;
  Eigen::ComplexEigenSolver<CM> es(A.cast<std::complex<double>>());
  const Eigen::Index n = A.rows();
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto l = es.eigenvalues()(i);
    if (std::abs(l) < 1.0) continue;
    CM pbh(n + C.rows(), n);
    pbh.topRows(n) = A.cast<std::complex<double>>() - l * CM::Identity(n, n);
    pbh.bottomRows(C.rows()) = C.cast<std::complex<double>>();
    Eigen::JacobiSVD<CM> svd(pbh);
    const auto& sv = svd.singularValues();
    if (sv(n - 1) <= 1e-9 * std::max(1.0, sv(0))) return false;
  }
  return true;
}

// (A, Q^{1/2}) controllable: rank [Q^{1/2}, A Q^{1/2}, ..., A^{n-1} Q^{1/2}] = n.
bool noise_controllable(const Matrix& A, const Matrix& Q) {
  const Eigen::Index n = A.rows();
  Matrix K(n, n * n);
  Matrix block = psd_square_root(Q);
  for (Eigen::Index k = 0; k < n; ++k) {
    K.middleCols(k * n, n) = block;
    block = A * block;
    if (block.norm() > 0) block /= block.norm();
  }
  Eigen::JacobiSVD<Matrix> svd(K);
  const auto& sv = svd.singularValues();
  return sv(n - 1) > 1e-9 * std::max(1.0, sv(0));
}

// The final estimate's verdict and bounds (FinalEstimateReport): the same decision at the
// arrival rates of the longer horizon.
FinalEstimateReport final_estimate_report(const Scenario& configured) {
  FinalEstimateReport f;
  f.max_delay_periods = configured.estimator.fusable_delay_periods();
  f.horizon_ms = configured.final_horizon_ms();
  for (const auto& sensor : configured.sensors) {
    const double in_time = probability_within(sensor.link.delay, f.horizon_ms);
    f.links.push_back({sensor.id, stationary_loss(sensor.link.loss), in_time, arrival_rate(sensor.link.loss, in_time)});
  }
  const Scenario scenario = with_effective_links(configured, f.horizon_ms);
  const StabilityDecision decision = decide_stability(scenario.plant.A, scenario.plant.Q, scenario.sensors, scenario.seed);
  f.stable = decision.stable;
  f.stable_reason = decision.reason;
  if (decision.markov.applies) f.markov_criterion = decision.markov.value;
  if (decision.iid_bounds) {
    f.iid_bounds = true;
    if (decision.lower) f.lower_trace = decision.lower->trace();
    if (decision.upper.status == BoundStatus::bounded) f.upper_trace = decision.upper.V.trace();
    f.upper_method = decision.upper_method;
    if (decision.upper_method == BoundMethod::sampled && f.upper_trace)
      f.upper_trace_standard_error = decision.upper_standard_error;
  }
  return f;
}


// Links with memory: no i.i.d. bound applies, so where the Markov criterion says stable the
// mean covariance is estimated by simulation (core/src/theory/sampled_covariance.hpp). Above
// kMaxSampledSensors the runs would cost seconds: not sampled, and the note says so.
void add_sampled_covariance(AnalysisReport& report, const Scenario& scenario, Verdict stable) {
  constexpr std::size_t kMaxSampledSensors = 64;
  if (stable != Verdict::yes) return;
  if (scenario.sensors.size() > kMaxSampledSensors) {
    report.notes.push_back("sampled_trace: not estimated for more than " + std::to_string(kMaxSampledSensors) +
                           " sensors (the simulation would take seconds)");
    return;
  }
  const SampledCovarianceOptions options;
  const auto sampled =
      sampled_expected_covariance(scenario.plant.A, scenario.plant.Q, scenario.plant.P0, scenario.sensors,
                                  scenario.seed, options);
  if (!sampled) {
    report.notes.push_back("sampled_trace: a simulated run diverged; no estimate");
    return;
  }
  report.sampled_trace = sampled->trace_mean;
  report.sampled_trace_standard_error = sampled->standard_error;
  report.notes.push_back("sampled_trace is SAMPLED, not a bound: lim E[Tr P_k|k-1] estimated by running the "
                         "covariance recursion (Sinopoli eq. 9, arrived sensors stacked) over the links' own loss "
                         "sequences, " + std::to_string(sampled->runs) + " runs of " +
                         std::to_string(sampled->periods) + " periods after " + std::to_string(sampled->burn_in) +
                         " (seeded from the scenario), +/- its standard error over the runs");
}

// The configured links as the estimator sees them in time (delays folded into the loss), and
// the note on what that folding assumes when any link has a delay.
void add_links(AnalysisReport& report, const Scenario& configured) {
  bool any_delay = false;
  for (std::size_t i = 0; i < configured.sensors.size(); ++i) {
    const LinkSpec& link = configured.sensors[i].link;
    const double in_time = probability_within(link.delay, configured.deadline_ms());
    report.links.push_back({configured.sensors[i].id, stationary_loss(link.loss), in_time, arrival_rate(link.loss, in_time)});
    any_delay = any_delay || !link.delay.none();
  }
  if (any_delay) {
    report.notes.push_back(
        "delay: a sample later than the deadline (" + std::to_string(configured.deadline_ms()) +
        " ms after its period's tick) is never fused, so each link is analysed with its effective arrival rate "
        "(1 - loss) * P(delay <= deadline); exact for i.i.d. delays drawn independently of the loss process (for "
        "a Gilbert-Elliott link, loss_good and loss_bad are thinned alike and the chain stays Markov); not covered: "
        "delays that depend on each other or on the chain's state, and the network's own latency on top of the "
        "configured delay");
  }
}

// The i.i.d. closed forms need every link Bernoulli; the critical rate also one shared rate.
struct BernoulliRates {
  bool all_bernoulli = true;
  std::vector<double> rates;  // 1 - loss of each Bernoulli link
  bool shared = false;        // all Bernoulli, at least one link, one arrival rate
};

BernoulliRates bernoulli_rates(std::span<const SensorSpec> sensors) {
  BernoulliRates b;
  for (const auto& s : sensors) {
    if (const auto rate = iid_arrival_rate(s.link.loss)) b.rates.push_back(*rate);
    else b.all_bernoulli = false;
  }
  b.shared = b.all_bernoulli && !sensors.empty();
  for (double r : b.rates) b.shared = b.shared && std::abs(r - b.rates.front()) <= 1e-12;
  return b;
}

// What the model itself says before any link: the papers' assumptions, and a stable A.
void add_model_notes(AnalysisReport& report, const Scenario& scenario) {
  const Matrix& A = scenario.plant.A;
  if (!noise_controllable(A, scenario.plant.Q))
    report.notes.push_back("(A, Q^1/2) is not controllable: Sinopoli Thm 2-5 assume it; bounds may be loose");
  if (!scenario.sensors.empty() && !detectable(A, stacked_C(scenario)))
    report.notes.push_back("(A, C) is not detectable: an unstable mode is never observed, so E[P] diverges at any "
                           "arrival rate");
  if (report.spectral_radius < 1.0)
    report.notes.push_back("A is stable (alpha < 1): E[P] stays bounded for every arrival rate");
}

// Necessary-and-sufficient Markov criterion (multi-sensor paper Thm 4/7/9; Rohr et al. Thm 3.1).
void add_markov_criterion(AnalysisReport& report, const MarkovCriterion& markov) {
  if (markov.applies) {
    report.markov_criterion = markov.value;
    report.notes.push_back("markov_criterion = max over eigen-blocks of alpha_i^2 limsup P(R_N)^(1/N), by the "
                           "transition matrix (multi-sensor paper Thm 7, 9; Rohr et al. Lemma 4.1)");
  }
  for (const auto& r : markov.reasons) report.notes.push_back(r);
}

// i.i.d. bounds S̄ ≤ lim E[P] ≤ V̄ (Sinopoli Thm 4, 6; Liu-Goldsmith Thm 4), computed by the verdict;
// links with memory get the sampled mean covariance instead.
void add_expected_covariance(AnalysisReport& report, const Scenario& scenario, const StabilityDecision& decision) {
  const UpperBound& upper = decision.upper;
  if (decision.iid_bounds) {
    report.iid_bounds = true;
    if (decision.lower) report.lower_trace = decision.lower->trace();
    if (upper.status == BoundStatus::bounded) report.upper_trace = upper.V.trace();
    report.upper_method = decision.upper_method;
    if (decision.upper_method == BoundMethod::grouped)
      report.notes.push_back("upper bound V-bar summed exactly over how many sensors of each group (same C, R) "
                             "arrive (Poisson-binomial counts) instead of the 2^d patterns");
    if (decision.upper_method == BoundMethod::sampled) {
      if (report.upper_trace) report.upper_trace_standard_error = decision.upper_standard_error;
      report.notes.push_back("upper_trace is SAMPLED, not a bound: too many arrival patterns to sum (more than " +
                             std::to_string(exact_pattern_limit) + " count patterns); mean of 8 batches of 256 "
                             "patterns drawn from the links (seeded from the scenario) +/- its standard error; "
                             "it decides no verdict");
    }
    if (upper.status == BoundStatus::undecided)
      report.notes.push_back("upper bound V-bar: the g iteration neither certified a fixed point nor diverged in " +
                             std::to_string(upper.iterations) + " iterations (operating point near the boundary)");
  } else if (!scenario.sensors.empty()) {
    report.notes.push_back("expected_covariance: the bounds S-bar, V-bar (Sinopoli Thm 4; Liu-Goldsmith Thm 4) "
                           "assume i.i.d. arrivals; Gilbert-Elliott links have memory, so none is reported");
    add_sampled_covariance(report, scenario, decision.stable);
  }
}

// Thm 12 closed form as a cross-check of the transition matrix (second order, i.i.d.).
void add_second_order_check(AnalysisReport& report, const Scenario& scenario, const BernoulliRates& bernoulli,
                            const MarkovCriterion& markov) {
  const Matrix& A = scenario.plant.A;
  if (!bernoulli.all_bernoulli || scenario.sensors.empty()) return;
  std::string why;
  int tau = 0;
  const auto thm12 = second_order_iid_criterion(A, scenario.sensors, bernoulli.rates, &why, &tau);
  if (thm12) {
    report.second_order_criterion = *thm12;
    std::string line = "Thm 12 closed form (period tau = " + (tau > 0 ? std::to_string(tau) : std::string("inf")) +
                       "): " + verdict_number(*thm12);
    if (markov.applies && std::abs(*thm12 - markov.value) > 1e-6 * std::max(1.0, markov.value))
      line += " DISAGREES with the transition matrix " + verdict_number(markov.value);
    else if (markov.applies)
      line += ", agrees with the transition matrix";
    report.notes.push_back(line);
  } else if (A.rows() == 2) {
    report.notes.push_back("Thm 12 closed form not applicable: " + why);
  }
}

// The verdict: the estimator's, and with an actuation link the closed loop's.
void add_verdict(AnalysisReport& report, const Scenario& configured, const StabilityDecision& decision,
                 const AnalyzeOptions& options) {
  report.stable = report.estimator_stable = decision.stable;
  report.stable_reason = report.estimator_stable_reason = decision.reason;
  report.notes.push_back(decision.reason);
  ActuationOptions actuation_options;
  actuation_options.use_lmi = options.use_lmi;
  report.actuation = analyze_actuation(configured, actuation_options);
  if (!report.actuation) return;
  // Acknowledged inputs: separation, so the loop is stable iff both sides are.
  const ClosedLoopVerdict loop = closed_loop_verdict(decision.stable, decision.reason, *report.actuation);
  report.stable = loop.stable;
  report.stable_reason = loop.reason;
  report.notes.push_back(loop.reason);
  if (!report.actuation->cost_reason.empty()) report.notes.push_back(report.actuation->cost_reason);
  if (report.actuation->gain == "lqr at the arrival rate")
    report.notes.push_back("plant.control.gain: the TCP-like optimum for inputs arriving at rate " +
                           verdict_number(*report.actuation->gain_arrival_rate) +
                           " (S = A'SA + Qx - rate A'SB(B'SB + Ru)^-1 B'SA, Schenato et al. 2007 Sec. V), "
                           "fixed at load time");
}

// With late_policy fuse_within: the final estimate's verdict at the longer horizon's rates.
void add_final_estimate(AnalysisReport& report, const Scenario& configured) {
  if (configured.estimator.fusable_delay_periods() <= 0) return;
  report.final_estimate = final_estimate_report(configured);
  report.notes.push_back(
      "late_policy fuse_within (D = " + std::to_string(report.final_estimate->max_delay_periods) +
      "): the verdict and bounds above are at the in-time arrival rates (delay <= deadline), i.e. those of the "
      "estimator without the buffer (late_policy drop); the final estimate, after every revision, fuses the "
      "samples delayed at most deadline + D periods = " +
      verdict_number(report.final_estimate->horizon_ms) +
      " ms: final_estimate is its verdict at those rates (the same criteria; exact for i.i.d. delays as above). "
      "With the buffer the in-time estimate of k already knows every sample the final estimate of k - D "
      "fuses, so its error is at most that of a D-step prediction from it: it stays bounded whenever the final "
      "one does");
}

// The critical arrival rate, when every link shares one Bernoulli rate.
void add_critical_rate(AnalysisReport& report, const Scenario& scenario, bool shared, const MarkovCriterion& markov,
                       const AnalyzeOptions& options) {
  if (shared) {
    CriticalRateOptions cro;
    cro.use_lmi = options.use_lmi;
    cro.lmi_max_block = options.lmi_max_block;
    cro.exact = markov.applies && markov.exact;
    report.critical_rate =
        shared_critical_rates(scenario.plant.A, scenario.plant.Q, scenario.sensors, cro, &report.notes);
  } else if (!scenario.sensors.empty()) {
    report.notes.push_back("critical_rate: null (needs every link Bernoulli with one shared arrival rate)");
  }
}

// --sweep: the i.i.d. bounds over a grid of the arrival rate every link shares.
void add_sweep(AnalysisReport& report, const Scenario& scenario, bool all_bernoulli, const AnalyzeOptions& options) {
  const std::size_t d = scenario.sensors.size();
  if (!options.sweep || d == 0) return;
  if (!all_bernoulli) report.notes.push_back("sweep: every link treated as Bernoulli with the swept arrival rate");
  const int points = std::max(2, options.sweep_points);
  for (int k = 0; k < points; ++k) {
    SweepPoint p;
    p.lambda = static_cast<double>(k) / (points - 1);
    const std::vector<double> r(d, p.lambda);
    const TraceBounds b = iid_trace_bounds(scenario.plant.A, scenario.plant.Q, scenario.sensors, r, scenario.seed);
    p.lower_trace = b.lower_trace;
    p.upper_trace = b.upper_trace;
    report.sweep.push_back(p);
  }
}

// --region: with an actuation link and one sensor (or --region-sensor) the (gamma, nu) region,
// otherwise the two sensors' (lambda1, lambda2) region.
void add_region(AnalysisReport& report, const Scenario& configured, const Scenario& scenario,
                const AnalyzeOptions& options) {
  if (!options.region) return;
  const std::size_t d = scenario.sensors.size();
  if (report.actuation && (options.region_sensor.has_value() || d == 1)) {
    const int id = options.region_sensor.value_or(d == 1 ? scenario.sensors.front().id : 0);
    report.actuation_region = theory::actuation_region(configured, id, options.region_points, options.progress);
    report.notes.push_back("actuation_region: for sensor " + std::to_string(id) +
                           "'s arrival rate gamma (its link i.i.d., the other sensors as configured), the "
                           "actuation arrival rates nu below which the loop is unstable (nu_lower) and above which "
                           "it is stable (nu_upper): with acknowledgements the estimator's verdict at gamma times "
                           "the jump system's critical rate (separation)");
  } else if (d == 2) {
    RegionOptions ro;
    ro.points = options.region_points;
    ro.use_lmi = options.use_lmi;
    ro.progress = options.progress;
    report.region = stability_region(scenario.plant.A, scenario.plant.Q, scenario.sensors, ro);
    report.notes.push_back("region: lambda2_lower = Liu-Goldsmith Thm 3 closed form, lambda2_upper = LMI "
                           "bisection (CSDP), lambda2_exact = Markov criterion where it applies");
  } else {
    report.notes.push_back("region: needs exactly two sensors (Liu-Goldsmith); this scenario has " +
                           std::to_string(d));
  }
}

}  // namespace

AnalysisReport analyze(const Scenario& configured, const AnalyzeOptions& options) {
  AnalysisReport report;
  // Everything below is about what reaches the estimator in time: delays fold into the
  // links' loss (docs/scenario-format.md, "Delay"); the delay-free links are unchanged.
  const Scenario scenario = with_effective_links(configured);
  add_links(report, configured);
  report.spectral_radius = spectral_radius(scenario.plant.A);
  // The verdict and the bounds it used, as the live status has them (theory/stability.hpp).
  const StabilityDecision decision =
      decide_stability(scenario.plant.A, scenario.plant.Q, scenario.sensors, scenario.seed);
  const BernoulliRates bernoulli = bernoulli_rates(scenario.sensors);
  const MarkovCriterion& markov = decision.markov;

  add_model_notes(report, scenario);
  add_markov_criterion(report, markov);
  add_expected_covariance(report, scenario, decision);
  add_second_order_check(report, scenario, bernoulli, markov);
  add_verdict(report, configured, decision, options);
  add_final_estimate(report, configured);
  if (markov.applies && !markov.stable() && decision.upper.status == BoundStatus::bounded)
    report.notes.push_back("inconsistent: V-bar is bounded but the Markov criterion says unstable");
  add_critical_rate(report, scenario, bernoulli.shared, markov, options);
  add_sweep(report, scenario, bernoulli.all_bernoulli, options);
  add_region(report, configured, scenario, options);
  return report;
}

CriticalRates shared_critical_rates(const Matrix& A, const Matrix& Q, std::span<const SensorSpec> sensors,
                                    const CriticalRateOptions& options, std::vector<std::string>* notes) {
  std::vector<std::string> discarded;
  std::vector<std::string>& said = notes ? *notes : discarded;
  const std::size_t d = sensors.size();
  CriticalRates cr;
  cr.lower = critical_rate_lower_bound(spectral_radius(A), static_cast<int>(d));
  const RateFamily family = shared_rate(d);
  cr.upper_iteration = upper_rate_iteration(A, Q, sensors, family, cr.lower);
  if (!cr.upper_iteration)
    said.push_back("critical_rate.upper_iteration: null (too many arrival patterns to sum exactly; a bisection on "
                   "a sampled map would be noise)");
  // The LMI enumerates the 2^d patterns: only for few sensors (1 << d must not overflow).
  const long long block = d <= 16 ? static_cast<long long>(A.rows()) * (1 + (1LL << d)) : -1;
  const bool lmi = options.use_lmi && block > 0 && (options.lmi_max_block <= 0 || block <= options.lmi_max_block);
  if (lmi) {
    cr.upper = upper_rate_lmi(A, sensors, family, cr.lower);
  } else {
    cr.upper = cr.upper_iteration;
    said.push_back(!options.use_lmi ? "critical_rate.upper from the g-iteration bisection (LMI disabled)"
                   : block < 0      ? "critical_rate.upper from the g-iteration bisection: the LMI needs the 2^d "
                                      "patterns, too many for " + std::to_string(d) + " sensors"
                                    : "critical_rate.upper from the g-iteration bisection: the LMI (" +
                                     std::to_string(block) + " rows) exceeds the size limit for CSDP "
                                     "(analyze --lmi-always forces it)");
  }
  if (options.exact) cr.exact = exact_rate_markov(A, sensors, family, cr.lower);
  if (d > 1)
    said.push_back("critical_rate.lower = 1 - alpha^(-2/d) for d links sharing the rate (Sinopoli Thm 3 with "
                   "Liu-Goldsmith's all-lost probability)");
  if (lmi && cr.upper && cr.upper_iteration) {
    const bool agree = std::abs(*cr.upper - *cr.upper_iteration) <= 1e-3;
    said.push_back(agree ? "critical_rate.upper: LMI (CSDP) and g-iteration bisection agree (" +
                               verdict_number(*cr.upper_iteration) + ")"
                         : "critical_rate.upper: LMI (CSDP) " + verdict_number(*cr.upper) +
                               " and g-iteration bisection " + verdict_number(*cr.upper_iteration) + " disagree");
  }
  return cr;
}

TraceBounds iid_trace_bounds(const Matrix& A, const Matrix& Q, std::span<const SensorSpec> sensors,
                             std::span<const double> arrival_rates, std::uint64_t seed) {
  if (arrival_rates.size() != sensors.size())
    throw std::invalid_argument("bounds: " + std::to_string(arrival_rates.size()) + " arrival rates for " +
                                std::to_string(sensors.size()) + " sensors");
  for (double r : arrival_rates)
    if (!(r >= 0.0 && r <= 1.0)) throw std::invalid_argument("bounds: an arrival rate must be in [0, 1]");
  TraceBounds b;
  if (auto S = lyapunov_lower_bound(A, Q, all_lost_probability(arrival_rates))) b.lower_trace = S->trace();
  UpperBoundOptions ub;
  ub.max_iterations = stability_upper_bound_iterations;  // the verdict's cap: a point at its rates agrees
  SamplingOptions sampling;
  sampling.seed = seed;
  const auto V = expected_covariance_upper_bound(A, Q, grouped_arrival_patterns(sensors, arrival_rates, sampling), ub);
  if (V.bound.status == BoundStatus::bounded) b.upper_trace = V.bound.V.trace();
  return b;
}

}  // namespace netkf::theory
