// A link's delay distributions (netkf/links/link_delay.hpp): netem's names, quantiles and
// the probability that a delivered sample is in time.
#include "netkf/links/link_delay.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace netkf {
namespace {

// netem's distribution tables hold Z · 8192 as 16-bit integers: |Z| <= 32767/8192 ≈ 4.
constexpr double kNetemTableLimit = 32767.0 / 8192.0;

// Φ, the standard normal CDF.
double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

// Φ⁻¹ by Acklam's rational approximation (relative error 1.15e-9), refined by one Halley
// step on erfc, which brings it to double precision.
double normal_quantile(double q) {
  if (q <= 0.0) return -std::numeric_limits<double>::infinity();
  if (q >= 1.0) return std::numeric_limits<double>::infinity();
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                                 1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                 6.680131188771972e+01,  -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                 -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                 3.754408661907416e+00};
  constexpr double low = 0.02425;
  double x;
  if (q < low) {
    const double t = std::sqrt(-2.0 * std::log(q));
    x = (((((c[0] * t + c[1]) * t + c[2]) * t + c[3]) * t + c[4]) * t + c[5]) /
        ((((d[0] * t + d[1]) * t + d[2]) * t + d[3]) * t + 1.0);
  } else if (q <= 1.0 - low) {
    const double s = q - 0.5;
    const double t = s * s;
    x = (((((a[0] * t + a[1]) * t + a[2]) * t + a[3]) * t + a[4]) * t + a[5]) * s /
        (((((b[0] * t + b[1]) * t + b[2]) * t + b[3]) * t + b[4]) * t + 1.0);
  } else {
    const double t = std::sqrt(-2.0 * std::log(1.0 - q));
    x = -(((((c[0] * t + c[1]) * t + c[2]) * t + c[3]) * t + c[4]) * t + c[5]) /
        ((((d[0] * t + d[1]) * t + d[2]) * t + d[3]) * t + 1.0);
  }
  const double e = normal_cdf(x) - q;
  const double u = e * std::sqrt(2.0 * M_PI) * std::exp(x * x / 2.0);
  return x - u / (1.0 + x * u / 2.0);
}

// netem's Pareto table: Z(q) = (4/3)((1 − q)^(−1/3) − 3/2), the quantile of a Pareto of
// shape 3 and scale 1 (mean 3/2), centred and scaled by 4/3 (iproute2, netem/pareto.c).
double pareto_standard_quantile(double q) { return (4.0 / 3.0) * (std::pow(1.0 - q, -1.0 / 3.0) - 1.5); }

// The standard quantile Z(q) of each distribution (delay = delay_ms + jitter_ms · Z),
// limited to the range of netem's tables where netem's meaning is the definition.
double standard_quantile(DelayDistribution d, double q) {
  switch (d) {
    case DelayDistribution::uniform: return 2.0 * q - 1.0;
    case DelayDistribution::normal: return normal_quantile(q);
    case DelayDistribution::pareto: return std::min(pareto_standard_quantile(q), kNetemTableLimit);
    case DelayDistribution::paretonormal:
      // netem/paretonormal.c: (normal + 3·pareto)/4 of the same table index, i.e. quantile.
      // The Pareto part is capped at the table's limit before mixing, as netem's generator does.
      return std::clamp(0.25 * normal_quantile(q) + 0.75 * std::min(pareto_standard_quantile(q), kNetemTableLimit),
                        -kNetemTableLimit, kNetemTableLimit);
  }
  return 0.0;
}

// P(Z <= z) for the standard quantiles above.
double standard_cdf(DelayDistribution d, double z) {
  switch (d) {
    case DelayDistribution::uniform: return std::clamp((z + 1.0) / 2.0, 0.0, 1.0);
    case DelayDistribution::normal: return normal_cdf(z);
    case DelayDistribution::pareto: {
      if (z >= kNetemTableLimit) return 1.0;
      const double base = 1.5 + 0.75 * z;  // (1 − q)^(−1/3) at Z = z
      return base <= 1.0 ? 0.0 : 1.0 - std::pow(base, -3.0);
    }
    case DelayDistribution::paretonormal: {
      // No closed form: Z(q) increases with q, so bisect for the largest q with Z(q) <= z.
      if (z >= kNetemTableLimit) return 1.0;
      if (z < -kNetemTableLimit) return 0.0;
      double lo = 0.0, hi = 1.0;
      for (int i = 0; i < 80; ++i) {
        const double mid = 0.5 * (lo + hi);
        (standard_quantile(d, mid) <= z ? lo : hi) = mid;
      }
      return lo;
    }
  }
  return 0.0;
}

}  // namespace

std::string delay_distribution_name(DelayDistribution d) {
  switch (d) {
    case DelayDistribution::uniform: return "uniform";
    case DelayDistribution::normal: return "normal";
    case DelayDistribution::pareto: return "pareto";
    case DelayDistribution::paretonormal: return "paretonormal";
  }
  return "uniform";
}

DelayDistribution parse_delay_distribution(const std::string& name) {
  for (const auto d : {DelayDistribution::uniform, DelayDistribution::normal, DelayDistribution::pareto,
                       DelayDistribution::paretonormal})
    if (name == delay_distribution_name(d)) return d;
  throw LinkError("delay_distribution",
                  "unknown delay_distribution '" + name + "' (expected uniform, normal, pareto or paretonormal)");
}

// ---- delay --------------------------------------------------------------------------

double delay_quantile(const LinkDelay& delay, double q) {
  if (delay.jitter_ms == 0.0) return delay.delay_ms;
  return std::max(0.0, delay.delay_ms + delay.jitter_ms * standard_quantile(delay.distribution, q));
}

double probability_within(const LinkDelay& delay, double deadline_ms) {
  if (deadline_ms < 0.0) return 0.0;  // a delay is never negative
  if (delay.jitter_ms == 0.0) return delay.delay_ms <= deadline_ms ? 1.0 : 0.0;
  // For a deadline >= 0 the cut at 0 does not matter: P(max(0, X) <= D) = P(X <= D).
  return standard_cdf(delay.distribution, (deadline_ms - delay.delay_ms) / delay.jitter_ms);
}

}  // namespace netkf
