// The expected Riccati map for any number of sensors (see theory/arrival_groups.hpp).
#include "netkf/theory/arrival_groups.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <stdexcept>
#include <string>

#include "netkf/support/random.hpp"

namespace netkf::theory {
namespace {

// Sensors with the same (C, R): their information C'R⁻¹C and their members.
struct Group {
  Matrix information;
  std::vector<int> members;
  std::vector<double> rates;
};

std::vector<Group> exchangeable_groups(std::span<const SensorSpec> sensors, std::span<const double> rates) {
  std::vector<Group> groups;
  std::vector<std::size_t> representative;
  for (std::size_t i = 0; i < sensors.size(); ++i) {
    const auto& s = sensors[i];
    std::size_t g = 0;
    for (; g < groups.size(); ++g) {
      const auto& r = sensors[representative[g]];
      if (r.C.rows() == s.C.rows() && r.C.cols() == s.C.cols() && r.C == s.C && r.R == s.R) break;
    }
    if (g == groups.size()) {
      groups.push_back({s.C.transpose() * s.R.ldlt().solve(s.C), {}, {}});
      representative.push_back(i);
    }
    groups[g].members.push_back(static_cast<int>(i));
    groups[g].rates.push_back(rates[i]);
  }
  return groups;
}

// P(k of the group's links deliver), k = 0..m: Poisson-binomial by the usual recursion.
std::vector<double> count_distribution(const std::vector<double>& rates) {
  std::vector<double> p{1.0};
  for (double rate : rates) {
    std::vector<double> next(p.size() + 1, 0.0);
    for (std::size_t k = 0; k < p.size(); ++k) {
      next[k] += p[k] * (1.0 - rate);
      next[k + 1] += p[k] * rate;
    }
    p = std::move(next);
  }
  return p;
}

// A pattern with information J, carried as C = J^{1/2} (rank-revealed rows) and R = I.
ArrivalPattern compressed_pattern(const Matrix& J, double probability, Eigen::Index n) {
  ArrivalPattern p;
  p.probability = probability;
  Eigen::SelfAdjointEigenSolver<Matrix> es(0.5 * (J + J.transpose()));
  const Vector& ev = es.eigenvalues();
  const double tol = 1e-12 * std::max(1.0, ev.size() > 0 ? ev.cwiseAbs().maxCoeff() : 0.0);
  std::vector<Eigen::Index> kept;
  for (Eigen::Index k = 0; k < ev.size(); ++k)
    if (ev(k) > tol) kept.push_back(k);
  p.C = Matrix::Zero(static_cast<Eigen::Index>(kept.size()), n);
  for (std::size_t r = 0; r < kept.size(); ++r)
    p.C.row(static_cast<Eigen::Index>(r)) = std::sqrt(ev(kept[r])) * es.eigenvectors().col(kept[r]).transpose();
  p.R = Matrix::Identity(p.C.rows(), p.C.rows());
  return p;
}

void check(std::span<const SensorSpec> sensors, std::span<const double> rates) {
  if (sensors.size() != rates.size())
    throw std::invalid_argument("arrival rates: expected " + std::to_string(sensors.size()) + " values, got " +
                                std::to_string(rates.size()));
  for (double rate : rates)
    if (!(rate >= 0.0 && rate <= 1.0)) throw std::invalid_argument("arrival rate outside [0,1]");
}

Eigen::Index state_dim(std::span<const SensorSpec> sensors) { return sensors.empty() ? 0 : sensors.front().C.cols(); }

}  // namespace

const char* to_string(BoundMethod method) {
  switch (method) {
    case BoundMethod::enumerated: return "enumerated";
    case BoundMethod::grouped: return "grouped";
    case BoundMethod::sampled: return "sampled";
  }
  return "?";
}

PatternSets sampled_arrival_patterns(std::span<const SensorSpec> sensors, std::span<const double> rates,
                                     const SamplingOptions& sampling) {
  check(sensors, rates);
  const auto groups = exchangeable_groups(sensors, rates);
  const Eigen::Index n = state_dim(sensors);
  PatternSets out;
  out.method = BoundMethod::sampled;
  out.groups = groups.size();
  const int samples = std::max(1, sampling.samples);
  for (int b = 0; b < std::max(2, sampling.batches); ++b) {
    Rng rng(derive_seed(sampling.seed, "theory-bounds", static_cast<std::uint64_t>(b)));
    std::vector<ArrivalPattern> set;
    set.reserve(static_cast<std::size_t>(samples));
    for (int s = 0; s < samples; ++s) {
      Matrix J = Matrix::Zero(n, n);
      std::vector<int> arrived;
      for (const auto& g : groups) {
        int k = 0;
        for (std::size_t m = 0; m < g.members.size(); ++m)
          if (rng.uniform() < g.rates[m]) {
            ++k;
            arrived.push_back(g.members[m]);
          }
        if (k > 0) J += static_cast<double>(k) * g.information;
      }
      ArrivalPattern p = compressed_pattern(J, 1.0 / samples, n);
      p.sensor_indices = std::move(arrived);
      set.push_back(std::move(p));
    }
    out.sets.push_back(std::move(set));
  }
  return out;
}

PatternSets grouped_arrival_patterns(std::span<const SensorSpec> sensors, std::span<const double> rates,
                                     const SamplingOptions& sampling, std::size_t limit) {
  check(sensors, rates);
  const auto groups = exchangeable_groups(sensors, rates);
  // Count vectors: Π (m_g + 1), stopped as soon as it passes the limit (no overflow).
  std::size_t terms = 1;
  for (const auto& g : groups) {
    terms *= g.members.size() + 1;
    if (terms > limit) return sampled_arrival_patterns(sensors, rates, sampling);
  }
  const Eigen::Index n = state_dim(sensors);
  PatternSets out;
  out.method = groups.size() == sensors.size() ? BoundMethod::enumerated : BoundMethod::grouped;
  out.groups = groups.size();
  std::vector<std::vector<double>> counts;
  for (const auto& g : groups) counts.push_back(count_distribution(g.rates));
  // Count vectors below 1e-17 are not summed; their mass goes to the all-lost pattern. More
  // losses never lower g (Sinopoli Thm 1, Liu-Goldsmith Lemma 3), so the V̄ found still bounds
  // from above, within ~1e-15 relative of the full sum, and a 512-sensor group keeps ~100 terms.
  constexpr double negligible = 1e-17;
  double folded = 0.0;
  std::vector<ArrivalPattern> set;
  std::vector<std::size_t> k(groups.size(), 0);  // mixed-radix counter over count vectors
  for (std::size_t t = 0; t < terms; ++t) {
    double probability = 1.0;
    Matrix J = Matrix::Zero(n, n);
    std::vector<int> arrived;
    for (std::size_t g = 0; g < groups.size(); ++g) {
      probability *= counts[g][k[g]];
      if (k[g] > 0) J += static_cast<double>(k[g]) * groups[g].information;
      for (std::size_t m = 0; m < k[g]; ++m) arrived.push_back(groups[g].members[m]);
    }
    const bool all_lost = t == 0;
    if (probability > 0.0 && probability < negligible && !all_lost) {
      folded += probability;
    } else if (probability > 0.0 || all_lost) {
      ArrivalPattern p = compressed_pattern(J, probability, n);
      p.sensor_indices = std::move(arrived);
      set.push_back(std::move(p));
    }
    for (std::size_t g = 0; g < groups.size(); ++g) {
      if (++k[g] <= groups[g].members.size()) break;
      k[g] = 0;
    }
  }
  set.front().probability += folded;  // the all-lost pattern (t = 0)
  if (set.front().probability <= 0.0) set.erase(set.begin());
  out.sets.push_back(std::move(set));
  return out;
}

UpperBoundEstimate expected_covariance_upper_bound(const Matrix& A, const Matrix& Q, const PatternSets& patterns,
                                                   const UpperBoundOptions& options) {
  UpperBoundEstimate out;
  out.method = patterns.method;
  out.batches = static_cast<int>(patterns.sets.size());
  if (patterns.method != BoundMethod::sampled) {
    out.bound = expected_covariance_upper_bound(A, Q, patterns.sets.front(), options);
    return out;
  }
  out.samples_per_batch = patterns.sets.empty() ? 0 : static_cast<int>(patterns.sets.front().size());
  // Each batch's empirical map has its own fixed point; their spread is the sampling error.
  std::vector<double> traces;
  Matrix sum = Matrix::Zero(A.rows(), A.rows());
  out.bound.status = BoundStatus::bounded;
  for (const auto& set : patterns.sets) {
    const UpperBound b = expected_covariance_upper_bound(A, Q, set, options);
    out.bound.iterations = std::max(out.bound.iterations, b.iterations);
    if (b.status != BoundStatus::bounded) {
      out.bound.status = b.status;
      out.bound.V = b.V;
      return out;
    }
    traces.push_back(b.V.trace());
    sum += b.V;
  }
  const double count = static_cast<double>(traces.size());
  out.bound.V = sum / count;
  const double mean = out.bound.V.trace();
  double ss = 0.0;
  for (double t : traces) ss += (t - mean) * (t - mean);
  out.trace_standard_error = std::sqrt(ss / (count - 1.0) / count);
  return out;
}

}  // namespace netkf::theory
