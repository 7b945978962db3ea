// Monte Carlo of the intermittent Kalman filter (see monte_carlo.hpp).
//
// Why the runs simulate the error and not the state. With unstable A, x_k ~ α^k: at α = 1.25
// x − x̂ has no correct digit left after ~150 steps. The filter is linear in its data, so run
// it on the error system instead: give it the prior mean z_0 = −e_0 (e_0 = x_0 − x̂_{0|−1} ~
// N(0, P0)), the measurement y_i = v_i (the noise alone) and, at the time update, the input
// u = −w through B = I. By induction z_k = −e_k exactly: the update gives
//   z⁺ = z + K(v − C z) = −[(I − K C) e − K v] = −e⁺          (Sinopoli eq. 14-15)
// and the prediction z_{k+1} = A z⁺ − w = −(A e⁺ + w) = −e_{k+1}. P and the gains do not
// depend on the data, so they are the filter's own, and the errors have the same law as
// x − x̂ computed from a simulated plant (published-numbers.md, Fig. 7) — but with all
// their digits: the numbers stay O(|e|) instead of O(α^k).
#include "netkf/monte_carlo.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "netkf/kalman_filter.hpp"
#include "netkf/loss_model.hpp"
#include "netkf/random.hpp"

namespace netkf {
namespace {

constexpr int kChunkRuns = 32;  // runs per chunk: fixed, so results do not depend on threads

// Welford accumulator, merged with Chan et al.'s formula (fixed order => deterministic).
struct Moments {
  double n = 0.0, mean = 0.0, m2 = 0.0;
  void add(double x) {
    n += 1.0;
    const double d = x - mean;
    mean += d / n;
    m2 += d * (x - mean);
  }
  void merge(const Moments& o) {
    if (o.n == 0.0) return;
    if (n == 0.0) {
      *this = o;
      return;
    }
    const double total = n + o.n;
    const double d = o.mean - mean;
    mean += d * o.n / total;
    m2 += o.m2 + d * d * n * o.n / total;
    n = total;
  }
  MeanSe result() const {
    MeanSe r;
    r.mean = n > 0 ? mean : 0.0;
    r.se = n > 1 ? std::sqrt(m2 / (n - 1.0) / n) : 0.0;
    return r;
  }
};

struct ChunkStats {
  Moments tr_pred, tr_filt, err_pred, err_filt;
  int diverged = 0;
  std::vector<Moments> series_tr, series_err;
};

struct RunOutcome {
  double tr_pred = 0, tr_filt = 0, err_pred = 0, err_filt = 0;
  bool diverged = false;
};

// Q^{1/2} (any square root S with S S' = Q; Q may be singular) and per-sensor Cholesky of R.
Matrix psd_root(const Matrix& M) {
  Eigen::SelfAdjointEigenSolver<Matrix> es(M);
  return es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
}

struct Setup {
  const Scenario* scenario = nullptr;
  std::uint64_t seed = 0;
  int steps = 0;
  bool series = false;
  Matrix Q_root, P0_root;
  std::vector<Matrix> R_chol;
  double divergence_bound = 1e6;
};

Vector normals(Rng& rng, Eigen::Index n) {
  Vector v(n);
  for (Eigen::Index i = 0; i < n; ++i) v(i) = rng.standard_normal();
  return v;
}

std::vector<LinkLossProcess> make_links(const Scenario& s, std::uint64_t run_seed) {
  std::vector<LinkLossProcess> links;
  links.reserve(s.sensors.size());
  for (const auto& sensor : s.sensors)
    links.emplace_back(sensor.link, derive_seed(run_seed, "link", static_cast<std::uint64_t>(sensor.id)));
  return links;
}

// Reference kernel: the core IntermittentKalmanFilter itself.
RunOutcome run_reference(const Setup& setup, int run, ChunkStats& stats) {
  const Scenario& s = *setup.scenario;
  const Eigen::Index n = s.state_dim();
  const std::uint64_t run_seed = derive_seed(setup.seed, "monte-carlo", static_cast<std::uint64_t>(run));
  Rng process(derive_seed(run_seed, "process-noise"));
  Rng measurement(derive_seed(run_seed, "sensor-noise"));
  auto links = make_links(s, run_seed);

  FilterModel model;
  model.A = s.plant.A;
  model.Q = s.plant.Q;
  model.B = Matrix::Identity(n, n);  // carries u = −w (see the file comment)
  for (const auto& sensor : s.sensors) model.sensors.push_back({sensor.id, sensor.C, sensor.R});
  FilterOptions fo;
  fo.divergence_trace_bound = setup.divergence_bound;
  const Vector z0 = setup.P0_root * normals(process, n);  // −e_0, same law as e_0
  IntermittentKalmanFilter filter(model, z0, s.plant.P0, fo);

  RunOutcome out;
  std::vector<SensorSample> received;
  for (int k = 0; k < setup.steps; ++k) {
    received.clear();
    for (std::size_t i = 0; i < s.sensors.size(); ++i) {
      if (links[i].next_dropped()) continue;
      received.push_back({s.sensors[i].id, setup.R_chol[i] * normals(measurement, s.sensors[i].R.rows())});
    }
    out.tr_pred = filter.trace_P();
    out.err_pred = filter.x().squaredNorm();
    if (setup.series) {
      stats.series_tr[static_cast<std::size_t>(k)].add(out.tr_pred);
      stats.series_err[static_cast<std::size_t>(k)].add(out.err_pred);
    }
    filter.update(received);
    out.tr_filt = filter.trace_P();
    out.err_filt = filter.x().squaredNorm();
    if (k + 1 < setup.steps) {
      const Vector u = -(setup.Q_root * normals(process, n));
      filter.predict(&u);
    }
  }
  out.diverged = filter.state() == FilterState::diverging;
  return out;
}

// Fixed-size kernel: the same recursion (sequential per-sensor Joseph-form updates, which equal the stacked
// fused update for block-diagonal R — Liu-Goldsmith eq. 9-11) on stack-allocated matrices, drawing
// the same random numbers in the same order as run_reference.
template <int N>
RunOutcome run_fixed(const Setup& setup, int run, ChunkStats& stats) {
  using Mat = Eigen::Matrix<double, N, N>;
  using Vec = Eigen::Matrix<double, N, 1>;
  using Row = Eigen::Matrix<double, 1, N>;
  const Scenario& s = *setup.scenario;
  const std::size_t d = s.sensors.size();
  const std::uint64_t run_seed = derive_seed(setup.seed, "monte-carlo", static_cast<std::uint64_t>(run));
  Rng process(derive_seed(run_seed, "process-noise"));
  Rng measurement(derive_seed(run_seed, "sensor-noise"));
  auto links = make_links(s, run_seed);

  const Mat A = s.plant.A;
  const Mat Q = s.plant.Q;
  const Mat Q_root = setup.Q_root;
  std::array<Row, 16> c{};
  std::array<double, 16> r{}, r_root{};
  for (std::size_t i = 0; i < d; ++i) {
    c[i] = s.sensors[i].C;
    r[i] = s.sensors[i].R(0, 0);
    r_root[i] = setup.R_chol[i](0, 0);
  }
  Vec z;
  for (int i = 0; i < N; ++i) z(i) = process.standard_normal();
  z = Mat(setup.P0_root) * z;
  Mat P = s.plant.P0;
  RunOutcome out;
  for (int k = 0; k < setup.steps; ++k) {
    out.tr_pred = P.trace();
    out.err_pred = z.squaredNorm();
    if (setup.series) {
      stats.series_tr[static_cast<std::size_t>(k)].add(out.tr_pred);
      stats.series_err[static_cast<std::size_t>(k)].add(out.err_pred);
    }
    for (std::size_t i = 0; i < d; ++i) {
      if (links[i].next_dropped()) continue;
      const double v = r_root[i] * measurement.standard_normal();
      const Vec Pc = P * c[i].transpose();
      const double innovation_var = c[i].dot(Pc) + r[i];
      const Vec K = Pc / innovation_var;
      z += K * (v - c[i].dot(z));
      // Joseph form (I − K c) P (I − K c)' + K r K': P − K c P loses positive definiteness by
      // cancellation after long bursts of drops (P large along unobserved directions).
      const Mat IKc = Mat::Identity() - K * c[i];
      P = IKc * P * IKc.transpose() + r[i] * K * K.transpose();
      P = 0.5 * (P + P.transpose()).eval();
    }
    out.tr_filt = P.trace();
    out.err_filt = z.squaredNorm();
    if (k + 1 < setup.steps) {
      Vec w;
      for (int i = 0; i < N; ++i) w(i) = process.standard_normal();
      z = A * z - Q_root * w;
      P = A * P * A.transpose() + Q;
    }
  }
  out.diverged = !(out.tr_filt <= setup.divergence_bound);
  return out;
}

using Kernel = RunOutcome (*)(const Setup&, int, ChunkStats&);

Kernel fixed_kernel(const Scenario& s) {
  if (s.sensors.size() > 16) return nullptr;
  for (const auto& sensor : s.sensors)
    if (sensor.C.rows() != 1) return nullptr;
  switch (s.state_dim()) {
    case 1: return &run_fixed<1>;
    case 2: return &run_fixed<2>;
    case 3: return &run_fixed<3>;
    case 4: return &run_fixed<4>;
    case 5: return &run_fixed<5>;
    case 6: return &run_fixed<6>;
    default: return nullptr;
  }
}

}  // namespace

MonteCarloResult run_monte_carlo(const Scenario& scenario, const MonteCarloOptions& options) {
  if (options.runs < 1) throw std::invalid_argument("monte carlo: runs must be at least 1");
  if (options.steps < 1) throw std::invalid_argument("monte carlo: steps must be at least 1");
  Setup setup;
  setup.scenario = &scenario;
  setup.seed = options.seed.value_or(scenario.seed);
  setup.steps = options.steps;
  setup.series = options.record_series;
  setup.Q_root = psd_root(scenario.plant.Q);
  setup.P0_root = psd_root(scenario.plant.P0);
  setup.divergence_bound = scenario.estimator.divergence_trace_bound;
  for (const auto& sensor : scenario.sensors) setup.R_chol.push_back(Eigen::LLT<Matrix>(sensor.R).matrixL());

  Kernel kernel = &run_reference;
  const Kernel fast = fixed_kernel(scenario);
  if (options.kernel == MonteCarloOptions::Kernel::fixed_size) {
    if (!fast) throw std::invalid_argument("monte carlo: the fixed-size kernel needs n <= 6 and one output per sensor");
    kernel = fast;
  } else if (options.kernel == MonteCarloOptions::Kernel::automatic && fast) {
    kernel = fast;
  }

  const int chunks = (options.runs + kChunkRuns - 1) / kChunkRuns;
  std::vector<ChunkStats> chunk_stats(static_cast<std::size_t>(chunks));
  std::atomic<int> next{0};
  auto worker = [&] {
    for (int c = next.fetch_add(1); c < chunks; c = next.fetch_add(1)) {
      ChunkStats& st = chunk_stats[static_cast<std::size_t>(c)];
      if (setup.series) {
        st.series_tr.assign(static_cast<std::size_t>(setup.steps), {});
        st.series_err.assign(static_cast<std::size_t>(setup.steps), {});
      }
      const int end = std::min(options.runs, (c + 1) * kChunkRuns);
      for (int run = c * kChunkRuns; run < end; ++run) {
        const RunOutcome o = kernel(setup, run, st);
        const bool finite = std::isfinite(o.tr_pred) && std::isfinite(o.tr_filt) && std::isfinite(o.err_pred) &&
                            std::isfinite(o.err_filt);
        if (o.diverged || !finite) ++st.diverged;
        if (!finite) continue;
        st.tr_pred.add(o.tr_pred);
        st.tr_filt.add(o.tr_filt);
        st.err_pred.add(o.err_pred);
        st.err_filt.add(o.err_filt);
      }
    }
  };
  int threads = options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, chunks);
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();

  ChunkStats total;
  if (setup.series) {
    total.series_tr.assign(static_cast<std::size_t>(setup.steps), {});
    total.series_err.assign(static_cast<std::size_t>(setup.steps), {});
  }
  for (const auto& st : chunk_stats) {
    total.tr_pred.merge(st.tr_pred);
    total.tr_filt.merge(st.tr_filt);
    total.err_pred.merge(st.err_pred);
    total.err_filt.merge(st.err_filt);
    total.diverged += st.diverged;
    for (std::size_t k = 0; k < total.series_tr.size(); ++k) {
      total.series_tr[k].merge(st.series_tr[k]);
      total.series_err[k].merge(st.series_err[k]);
    }
  }
  MonteCarloResult result;
  result.runs = options.runs;
  result.steps = options.steps;
  result.seed = setup.seed;
  result.trace_P_pred = total.tr_pred.result();
  result.trace_P_filt = total.tr_filt.result();
  result.sq_error_pred = total.err_pred.result();
  result.sq_error_filt = total.err_filt.result();
  result.diverged_fraction = static_cast<double>(total.diverged) / options.runs;
  result.finite_runs = static_cast<int>(total.tr_pred.n);
  result.used_fixed_size_kernel = kernel != &run_reference;
  for (std::size_t k = 0; k < total.series_tr.size(); ++k)
    result.series.push_back({static_cast<int>(k), total.series_tr[k].result(), total.series_err[k].result()});
  return result;
}

}  // namespace netkf
