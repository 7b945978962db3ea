// lim E[Tr P_{k|k-1}] by simulating the covariance recursion over the links' loss sequences
// (see core/src/theory/sampled_covariance.hpp).
#include "sampled_covariance.hpp"

#include <cmath>
#include <vector>

#include "netkf/links/loss_model.hpp"
#include "netkf/support/random.hpp"

namespace netkf::theory {

std::optional<SampledCovariance> sampled_expected_covariance(const Matrix& A, const Matrix& Q, const Matrix& P0,
                                                             std::span<const SensorSpec> sensors, std::uint64_t seed,
                                                             const SampledCovarianceOptions& options) {
  if (sensors.empty() || options.runs < 2 || options.periods < 1 || options.burn_in < 0) return std::nullopt;
  const std::size_t d = sensors.size();
  std::vector<double> run_means;
  run_means.reserve(static_cast<std::size_t>(options.runs));
  for (int run = 0; run < options.runs; ++run) {
    std::vector<LinkLossProcess> links;
    links.reserve(d);
    for (std::size_t j = 0; j < d; ++j)
      links.emplace_back(sensors[j].link.loss,
                         derive_seed(seed, "sampled-covariance", static_cast<std::uint64_t>(run) * d + j));
    Matrix P = P0;
    double sum = 0.0;
    for (int k = 0; k < options.burn_in + options.periods; ++k) {
      // P is P_{k|k-1} here: it is what the bounds and the live Tr P pred speak of.
      const double trace = P.trace();
      if (!std::isfinite(trace) || trace > options.divergence_trace) return std::nullopt;
      if (k >= options.burn_in) sum += trace;
      // The fused update, one arrived sensor after the other: with block-diagonal R the
      // sequential updates equal the stacked one.
      for (std::size_t j = 0; j < d; ++j) {
        if (links[j].next_dropped()) continue;
        const Matrix& C = sensors[j].C;
        const Matrix PCt = P * C.transpose();
        const Matrix innovation = C * PCt + sensors[j].R;
        P -= PCt * innovation.ldlt().solve(PCt.transpose());
      }
      P = A * P * A.transpose() + Q;
      P = 0.5 * (P + P.transpose());
    }
    run_means.push_back(sum / options.periods);
  }
  double mean = 0.0;
  for (double m : run_means) mean += m;
  mean /= static_cast<double>(run_means.size());
  double var = 0.0;
  for (double m : run_means) var += (m - mean) * (m - mean);
  var /= static_cast<double>(run_means.size() - 1);
  return SampledCovariance{mean, std::sqrt(var / static_cast<double>(run_means.size())), options.runs,
                           options.periods, options.burn_in};
}

}  // namespace netkf::theory
