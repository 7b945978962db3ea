// The one stability verdict (see theory/stability.hpp).
#include "netkf/theory/stability.hpp"

#include "netkf/links/link_statistics.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <variant>
#include <vector>

namespace netkf::theory {
namespace {

// Why the Markov criterion does not apply, on one line.
std::string why_not(const MarkovCriterion& markov) {
  std::string out;
  for (const auto& r : markov.reasons) out += (out.empty() ? "" : "; ") + r;
  return out.empty() ? std::string("no reason given") : out;
}

}  // namespace

std::string verdict_number(double v) {
  std::ostringstream os;
  os.precision(std::abs(v - 1.0) < 1e-4 ? 12 : 6);
  os << v;
  return os.str();
}

const char* to_string(Verdict verdict) {
  switch (verdict) {
    case Verdict::yes: return "yes";
    case Verdict::no: return "no";
    case Verdict::unknown: return "unknown";
  }
  return "unknown";
}

StabilityDecision decide_stability(const Matrix& A, const Matrix& Q, std::span<const SensorSpec> sensors,
                                   std::uint64_t seed) {
  StabilityDecision out;
  if (sensors.empty()) {
    // E[P] = Σ A^k Q A'^k: bounded iff α < 1.
    const double alpha = spectral_radius(A);
    out.stable = alpha < 1.0 ? Verdict::yes : Verdict::no;
    out.reason = std::string(alpha < 1.0 ? "stable" : "unstable") +
                 " decided by open-loop prediction (no sensors): alpha " + verdict_number(alpha) + (alpha < 1.0 ? " < 1" : " >= 1");
    return out;
  }

  out.markov = markov_stability_criterion(A, sensors);

  std::vector<double> rates;
  for (const auto& s : sensors)
    if (const auto rate = iid_arrival_rate(s.link.loss)) rates.push_back(*rate);
  out.iid_bounds = rates.size() == sensors.size();
  double all_lost = 1.0;
  if (out.iid_bounds) {
    // i.i.d. bounds S̄ ≤ lim E[P] ≤ V̄ (Sinopoli Thm 4, 6; Liu-Goldsmith Thm 4), also the
    // traces both callers report when the criterion decides.
    all_lost = all_lost_probability(rates);
    out.lower = lyapunov_lower_bound(A, Q, all_lost);
    UpperBoundOptions ub;
    ub.max_iterations = stability_upper_bound_iterations;
    SamplingOptions sampling;
    sampling.seed = seed;
    const UpperBoundEstimate estimate =
        expected_covariance_upper_bound(A, Q, grouped_arrival_patterns(sensors, rates, sampling), ub);
    out.upper = estimate.bound;
    out.upper_method = estimate.method;
    out.upper_standard_error = estimate.trace_standard_error;
  }

  if (out.markov.applies) {
    const bool stable = out.markov.stable();
    out.stable = stable ? Verdict::yes : Verdict::no;
    const std::string how = out.markov.exact ? "" : (stable ? " (a sufficient bound)" : " (a necessary bound)");
    out.reason = stable ? "stable decided by the Markov criterion " + verdict_number(out.markov.value) +
                              " < 1" + how + " (multi-sensor paper Thm 7)"
                        : "unstable decided by the Markov criterion " + verdict_number(out.markov.value) +
                              " >= 1" + how + " (multi-sensor paper Thm 7): below the critical boundary";
  } else if (!out.iid_bounds) {
    out.reason = "stable unknown: Gilbert-Elliott links are decided only by the Markov criterion, which does not "
                 "apply here (" + why_not(out.markov) + ")";
  } else if (out.upper.status == BoundStatus::bounded && out.upper_method != BoundMethod::sampled) {
    out.stable = Verdict::yes;
    out.reason = "stable decided by the upper bound: V-bar = g(V-bar) exists (Sinopoli Thm 3/5)";
  } else if (!out.lower) {
    const double alpha = spectral_radius(A);
    out.stable = Verdict::no;
    out.reason = "unstable decided by the lower bound: S-bar does not exist (q alpha^2 = " +
                 verdict_number(all_lost * alpha * alpha) + " >= 1, Sinopoli Thm 3): below the critical rate";
  } else {
    out.reason = std::string("stable unknown: S-bar exists but V-bar ") +
                 (out.upper_method == BoundMethod::sampled
                      ? "was only sampled (too many arrival patterns to sum exactly; a sample decides nothing)"
                  : out.upper.status == BoundStatus::unbounded
                      ? "does not exist"
                      : "was neither certified nor diverged in " + std::to_string(out.upper.iterations) +
                            " iterations (near the boundary)") +
                 ", and the Markov criterion does not apply (" + why_not(out.markov) + ")";
  }
  return out;
}

}  // namespace netkf::theory
