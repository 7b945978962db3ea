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
// x − x̂ computed from a simulated plant (docs/validation.md, "Fig. 7") — but with all
// their digits: the numbers stay O(|e|) instead of O(α^k).
#include "netkf/sim/monte_carlo.hpp"
#include "netkf/support/progress.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "netkf/filter/kalman_filter.hpp"
#include "netkf/links/loss_model.hpp"
#include "netkf/support/gaussian.hpp"
#include "netkf/support/random.hpp"

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
    links.emplace_back(sensor.link.loss, derive_seed(run_seed, "link", static_cast<std::uint64_t>(sensor.id)));
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
      // Every sensor measures every period and the link decides (as in the live network), so
      // the noise stream does not depend on the arrivals.
      const bool dropped = links[i].next_dropped();
      Vector v = setup.R_chol[i] * normals(measurement, s.sensors[i].R.rows());
      if (!dropped) received.push_back({s.sensors[i].id, std::move(v)});
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

// Fixed-size kernel: the same recursion (sequential per-sensor Joseph-form updates, which equal the
// stacked fused update for block-diagonal R — Liu-Goldsmith eq. 9-11) on stack-allocated matrices,
// drawing the same random numbers in the same order as run_reference.
//
// The runs of a chunk advance in lockstep, kBlockRuns at a time. Each run keeps its own streams,
// so every run draws exactly what it would draw alone, and the statistics are added in run order:
// the numbers are those of running the runs one after the other. But one run's step is a chain of
// dependent operations (P_k → gain → P_{k|k} → P_{k+1}, with a division in it); a step first makes
// the random draws of the whole block, then runs the block's arithmetic as one loop of independent
// recursions, which the CPU overlaps (for n = 1 as SIMD arithmetic on Eigen arrays).
constexpr int kBlockRuns = 8;
constexpr std::size_t kMaxFixedSensors = 16;

template <int N>
class FixedKernel {
 public:
  using Mat = Eigen::Matrix<double, N, N>;
  using Vec = Eigen::Matrix<double, N, 1>;
  using Row = Eigen::Matrix<double, 1, N>;

  FixedKernel(const Setup& setup, int first_run, int count)
      : setup_(setup), s_(*setup.scenario), d_(s_.sensors.size()), count_(count), A_(s_.plant.A), Q_(s_.plant.Q),
        Q_root_(setup.Q_root) {
    for (std::size_t i = 0; i < d_; ++i) {
      c_[i] = s_.sensors[i].C;
      r_[i] = s_.sensors[i].R(0, 0);
      r_root_[i] = setup.R_chol[i](0, 0);
    }
    const Mat P0_root = setup.P0_root;
    for (int b = 0; b < count_; ++b) {
      Streams& st = streams_[static_cast<std::size_t>(b)];
      const std::uint64_t run_seed = derive_seed(setup.seed, "monte-carlo", static_cast<std::uint64_t>(first_run + b));
      st.process = Rng(derive_seed(run_seed, "process-noise"));
      st.measurement = Rng(derive_seed(run_seed, "sensor-noise"));
      st.links = make_links(s_, run_seed);
      Vec z0;
      for (int j = 0; j < N; ++j) z0(j) = st.process.standard_normal();
      z(b) = P0_root * z0;
      P(b) = s_.plant.P0;
    }
  }

  void run(ChunkStats& stats, RunOutcome* outcomes) {
    const int last = setup_.steps - 1;
    for (int k = 0; k <= last; ++k) {
      if (setup_.series) {
        for (int b = 0; b < count_; ++b) {
          stats.series_tr[static_cast<std::size_t>(k)].add(P(b).trace());
          stats.series_err[static_cast<std::size_t>(k)].add(z(b).squaredNorm());
        }
      }
      if (k == last) {
        for (int b = 0; b < count_; ++b) {
          outcomes[b].tr_pred = P(b).trace();
          outcomes[b].err_pred = z(b).squaredNorm();
        }
      }
      draw(k < last);
      update();
      if (k < last) {
        predict();
      } else {
        for (int b = 0; b < count_; ++b) {
          outcomes[b].tr_filt = P(b).trace();
          outcomes[b].err_filt = z(b).squaredNorm();
          outcomes[b].diverged = !(outcomes[b].tr_filt <= setup_.divergence_bound);
        }
      }
    }
  }

 private:
  struct Streams {
    Rng process, measurement;
    std::vector<LinkLossProcess> links;
  };

  Eigen::Map<Mat> P(int b) { return Eigen::Map<Mat>(P_.data() + static_cast<std::ptrdiff_t>(b) * N * N); }
  Eigen::Map<Vec> z(int b) { return Eigen::Map<Vec>(z_.data() + static_cast<std::ptrdiff_t>(b) * N); }

  // Every sensor measures every period and its link decides (as in the live network), so the
  // noise streams do not depend on the arrivals; then the process noise, as run_reference.
  void draw(bool with_process_noise) {
    for (int b = 0; b < count_; ++b) {
      Streams& st = streams_[static_cast<std::size_t>(b)];
      for (std::size_t i = 0; i < d_; ++i) {
        arrived_[i][static_cast<std::size_t>(b)] = static_cast<double>(!st.links[i].next_dropped());
        v_[i][static_cast<std::size_t>(b)] = r_root_[i] * st.measurement.standard_normal();
      }
      if (with_process_noise)
        for (int j = 0; j < N; ++j) w_[static_cast<std::size_t>(b)](j) = st.process.standard_normal();
    }
  }

  // Joseph form (I − K c) P (I − K c)' + r K K' (P − K c P loses positive definiteness by
  // cancellation after long bursts of drops, with P large along unobserved directions), evaluated
  // through its rank-one structure in O(n²) instead of two O(n³) products:
  //   T = (I − K c) P = P − K (P c')',   P⁺ = T (I − K c)' + r K K' = T − (T c') K' + r K K'.
  void update() {
    for (std::size_t i = 0; i < d_; ++i) {
      if constexpr (N == 1) {
        // The same operations over the block's runs as Eigen arrays (SIMD), without a branch on
        // the arrival (a 40 % drop rate is a coin the branch predictor cannot call): a lost sample
        // has gain 0, and then P and z come out unchanged, bit for bit (x − 0·y = x for finite
        // numbers; a run with non-finite numbers is counted as diverged either way).
        using BlockArray = Eigen::Array<double, kBlockRuns, 1>;
        Eigen::Map<BlockArray> p(P_.data()), zb(z_.data());
        const Eigen::Map<const BlockArray> arrived(arrived_[i].data()), v(v_[i].data());
        const double ci = c_[i](0), ri = r_[i];
        const BlockArray pc = p * ci;
        const BlockArray gain = arrived * (pc / (ci * pc + ri));
        const BlockArray t = p - gain * pc;
        p = t - (t * ci) * gain + ri * gain * gain;
        zb += gain * (v - ci * zb);
      } else {
        for (int b = 0; b < count_; ++b) {
          if (arrived_[i][static_cast<std::size_t>(b)] == 0.0) continue;
          auto Pb = P(b);
          const Vec Pc = Pb * c_[i].transpose();
          const Vec K = Pc / (c_[i].dot(Pc) + r_[i]);
          z(b) += K * (v_[i][static_cast<std::size_t>(b)] - c_[i].dot(z(b)));
          const Mat T = Pb - K * Pc.transpose();
          const Vec Tc = T * c_[i].transpose();
          Pb = T - Tc * K.transpose() + r_[i] * K * K.transpose();
          Pb = 0.5 * (Pb + Pb.transpose()).eval();
        }
      }
    }
  }

  void predict() {
    for (int b = 0; b < count_; ++b) {
      z(b) = A_ * z(b) - Q_root_ * w_[static_cast<std::size_t>(b)];
      P(b) = A_ * P(b) * A_.transpose() + Q_;
    }
  }

  const Setup& setup_;
  const Scenario& s_;
  const std::size_t d_;
  const int count_;
  const Mat A_, Q_, Q_root_;
  std::array<Row, kMaxFixedSensors> c_{};
  std::array<double, kMaxFixedSensors> r_{}, r_root_{};
  std::array<Streams, kBlockRuns> streams_;
  // P and z of each run of the block, run after run (slots past count_ stay at 0: computed,
  // never read); for n = 1 the block's P and z are arrays of doubles.
  std::array<double, kBlockRuns * N * N> P_{};
  std::array<double, kBlockRuns * N> z_{};
  // This step's draws, sensor-major so that the n = 1 loop reads them contiguously.
  std::array<std::array<double, kBlockRuns>, kMaxFixedSensors> arrived_{};  // 1: the sample arrived, 0: lost
  std::array<std::array<double, kBlockRuns>, kMaxFixedSensors> v_{};
  std::array<Vec, kBlockRuns> w_{};
};

template <int N>
void run_fixed(const Setup& setup, int first_run, int count, ChunkStats& stats, RunOutcome* outcomes) {
  FixedKernel<N>(setup, first_run, count).run(stats, outcomes);
}

// A kernel advances runs [first_run, first_run + count) (count <= kBlockRuns) and writes their
// outcomes; per-step series go to `stats` in run order within each step.
using Kernel = void (*)(const Setup&, int first_run, int count, ChunkStats& stats, RunOutcome* outcomes);

void run_reference_block(const Setup& setup, int first_run, int count, ChunkStats& stats, RunOutcome* outcomes) {
  for (int b = 0; b < count; ++b) outcomes[b] = run_reference(setup, first_run + b, stats);
}

Kernel fixed_kernel(const Scenario& s) {
  if (s.sensors.size() > kMaxFixedSensors) return nullptr;
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

// What every run shares: the seed, the noises' square roots, the divergence bound.
Setup make_setup(const Scenario& scenario, const MonteCarloOptions& options) {
  Setup setup;
  setup.scenario = &scenario;
  setup.seed = options.seed.value_or(scenario.seed);
  setup.steps = options.steps;
  setup.series = options.record_series;
  setup.Q_root = psd_square_root(scenario.plant.Q);  // Q may be singular
  setup.P0_root = psd_square_root(scenario.plant.P0);
  setup.divergence_bound = scenario.estimator.divergence_trace_bound;
  for (const auto& sensor : scenario.sensors) setup.R_chol.push_back(Eigen::LLT<Matrix>(sensor.R).matrixL());
  return setup;
}

// The kernel asked for: the fixed-size one where it fits (automatic) or where demanded.
Kernel choose_kernel(const Scenario& scenario, MonteCarloOptions::Kernel wanted) {
  Kernel kernel = &run_reference_block;
  const Kernel fast = fixed_kernel(scenario);
  if (wanted == MonteCarloOptions::Kernel::fixed_size) {
    if (!fast) throw std::invalid_argument("monte carlo: the fixed-size kernel needs n <= 6 and one output per sensor");
    kernel = fast;
  } else if (wanted == MonteCarloOptions::Kernel::automatic && fast) {
    kernel = fast;
  }
  return kernel;
}

// Per-step series of `steps` empty accumulators, when the series are recorded.
void size_series(ChunkStats& stats, const Setup& setup) {
  if (!setup.series) return;
  stats.series_tr.assign(static_cast<std::size_t>(setup.steps), {});
  stats.series_err.assign(static_cast<std::size_t>(setup.steps), {});
}

// Chunk c's runs, block by block; a run with a non-finite result counts as diverged and in
// no mean.
void run_chunk(const Setup& setup, Kernel kernel, int c, int runs, ChunkStats& st,
               std::array<RunOutcome, kBlockRuns>& outcomes, ProgressReporter& progress) {
  size_series(st, setup);
  const int end = std::min(runs, (c + 1) * kChunkRuns);
  for (int first = c * kChunkRuns; first < end; first += kBlockRuns) {
    const int count = std::min(kBlockRuns, end - first);
    kernel(setup, first, count, st, outcomes.data());
    for (int b = 0; b < count; ++b) {
      const RunOutcome& o = outcomes[static_cast<std::size_t>(b)];
      const bool finite = std::isfinite(o.tr_pred) && std::isfinite(o.tr_filt) && std::isfinite(o.err_pred) &&
                          std::isfinite(o.err_filt);
      if (o.diverged || !finite) ++st.diverged;
      if (!finite) continue;
      st.tr_pred.add(o.tr_pred);
      st.tr_filt.add(o.tr_filt);
      st.err_pred.add(o.err_pred);
      st.err_filt.add(o.err_filt);
    }
    progress.add(count);
  }
}

// The chunks on `threads` workers (this one among them), each taking the next chunk; the
// statistics stay per chunk so that merging them in order does not depend on the threads.
std::vector<ChunkStats> run_chunks(const Setup& setup, Kernel kernel, const MonteCarloOptions& options) {
  const int chunks = (options.runs + kChunkRuns - 1) / kChunkRuns;
  std::vector<ChunkStats> chunk_stats(static_cast<std::size_t>(chunks));
  std::atomic<int> next{0};
  ProgressReporter progress(options.progress, options.runs);
  auto worker = [&] {
    std::array<RunOutcome, kBlockRuns> outcomes;
    for (int c = next.fetch_add(1); c < chunks; c = next.fetch_add(1))
      run_chunk(setup, kernel, c, options.runs, chunk_stats[static_cast<std::size_t>(c)], outcomes, progress);
  };
  int threads = options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, chunks);
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  return chunk_stats;
}

// The chunks' statistics merged in chunk order (fixed order => deterministic).
ChunkStats merge_chunks(const std::vector<ChunkStats>& chunk_stats, const Setup& setup) {
  ChunkStats total;
  size_series(total, setup);
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
  return total;
}

MonteCarloResult make_result(const ChunkStats& total, const Setup& setup, const MonteCarloOptions& options,
                             bool used_fixed_size_kernel) {
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
  result.used_fixed_size_kernel = used_fixed_size_kernel;
  for (std::size_t k = 0; k < total.series_tr.size(); ++k)
    result.series.push_back({static_cast<int>(k), total.series_tr[k].result(), total.series_err[k].result()});
  return result;
}

}  // namespace

MonteCarloResult run_monte_carlo(const Scenario& configured, const MonteCarloOptions& options) {
  // A late sample is a lost one: the simulated links are the effective loss models (exact in
  // distribution for i.i.d. delays, see netkf/links/link_statistics.hpp).
  const Scenario scenario = with_effective_links(configured);
  if (options.runs < 1) throw std::invalid_argument("monte carlo: runs must be at least 1");
  if (options.steps < 1) throw std::invalid_argument("monte carlo: steps must be at least 1");
  const Setup setup = make_setup(scenario, options);
  const Kernel kernel = choose_kernel(scenario, options.kernel);
  const ChunkStats total = merge_chunks(run_chunks(setup, kernel, options), setup);
  return make_result(total, setup, options, kernel != &run_reference_block);
}

}  // namespace netkf
