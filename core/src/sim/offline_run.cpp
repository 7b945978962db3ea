// One offline run of the networked filter (see offline_run.hpp).
#include "netkf/sim/offline_run.hpp"

#include <Eigen/Cholesky>
#include <stdexcept>

#include "netkf/filter/kalman_filter.hpp"
#include "netkf/links/loss_model.hpp"
#include "netkf/support/random.hpp"

namespace netkf {
namespace {

Vector normals(Rng& rng, Eigen::Index n) {
  Vector v(n);
  for (Eigen::Index i = 0; i < n; ++i) v(i) = rng.standard_normal();
  return v;
}

// A square root of a PSD matrix (Q may be singular): L with L Lᵀ = M, by LDLᵀ.
Matrix psd_root(const Matrix& m) {
  Eigen::LDLT<Matrix> ldlt(m);
  const Vector d = ldlt.vectorD().cwiseMax(0.0).cwiseSqrt();
  Matrix l = ldlt.matrixL();
  return ldlt.transpositionsP().transpose() * l * d.asDiagonal();
}

}  // namespace

void simulate_offline_run(const Scenario& scenario, std::uint64_t seed, std::int64_t periods,
                          const std::function<void(const OfflinePeriod&)>& on_period) {
  if (periods < 1) throw std::invalid_argument("an offline run needs at least one period");
  if (!scenario.events.empty())
    throw std::invalid_argument("the scenario has link events: an offline run has no timeline (run it live)");
  const Scenario s = with_effective_links(scenario);
  const Eigen::Index n = s.state_dim();
  Rng process(derive_seed(seed, "process-noise"));
  Rng measurement(derive_seed(seed, "sensor-noise"));
  std::vector<LinkLossProcess> links;
  std::vector<Matrix> r_root;
  for (const auto& sensor : s.sensors) {
    links.emplace_back(sensor.link.loss, derive_seed(seed, "link", static_cast<std::uint64_t>(sensor.id)));
    r_root.push_back(psd_root(sensor.R));
  }
  const Matrix q_root = psd_root(s.plant.Q);
  const Matrix p0 = s.plant.P0.rows() == n ? s.plant.P0 : Matrix(Matrix::Identity(n, n));

  // The error system (monte_carlo.cpp): prior mean −e_0, measurements the noise alone, and the
  // process noise entering as the input −w through B = I; then x̂ = −e.
  FilterModel model;
  model.A = s.plant.A;
  model.Q = s.plant.Q;
  model.B = Matrix::Identity(n, n);
  for (const auto& sensor : s.sensors) model.sensors.push_back({sensor.id, sensor.C, sensor.R});
  FilterOptions options;
  options.divergence_trace_bound = s.estimator.divergence_trace_bound;
  IntermittentKalmanFilter filter(model, psd_root(p0) * normals(process, n), p0, options);

  OfflinePeriod out;
  std::vector<SensorSample> received;
  for (std::int64_t k = 0; k < periods; ++k) {
    received.clear();
    out.arrived.assign(s.sensors.size(), false);
    for (std::size_t i = 0; i < s.sensors.size(); ++i) {
      // Every sensor measures every period and its link decides, as in the live network.
      const bool dropped = links[i].next_dropped();
      Vector v = r_root[i] * normals(measurement, s.sensors[i].R.rows());
      out.arrived[i] = !dropped;
      if (!dropped) received.push_back({s.sensors[i].id, std::move(v)});
    }
    out.trace_P_pred = filter.trace_P();  // P_{k|k-1}: the update has not run yet
    out.fused = filter.update(received).fused_ids;
    out.k = k;
    out.squared_error = filter.x().squaredNorm();
    out.trace_P = filter.trace_P();
    out.diverging = filter.state() == FilterState::diverging;
    on_period(out);
    const Vector u = -(q_root * normals(process, n));
    filter.predict(&u);
  }
}

}  // namespace netkf
