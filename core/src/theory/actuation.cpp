// The control side of a loop closed over a lossy actuation link (see theory/actuation.hpp).
#include "netkf/theory/actuation.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <variant>

#include "netkf/links/link_delay.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_text.hpp"
#include "netkf/theory/riccati.hpp"

namespace netkf::theory {
namespace {

// Whether the link's family is the i.i.d. one, whose arrival rates reach 0.
bool iid_family(const LinkModel& link) {
  return std::visit(overloaded{[](const BernoulliLink&) { return true; },
                               [](const GilbertElliottLink&) { return false; }},
                    link);
}

// The link's chain: one state for Bernoulli, good and bad for Gilbert-Elliott.
struct Chain {
  Matrix to;                  // to(j, i) = P(j → i)
  std::vector<double> loss;   // per state
  std::vector<double> stationary;
};

Chain chain_of(const LinkModel& link) {
  Chain c;
  std::visit(overloaded{[&](const BernoulliLink& b) {
                          c.to = Matrix::Ones(1, 1);
                          c.loss = {b.loss};
                          c.stationary = {1.0};
                        },
                        [&](const GilbertElliottLink& g) {
                          c.to.resize(2, 2);
                          c.to << 1.0 - g.p, g.p, g.r, 1.0 - g.r;
                          c.loss = {g.loss_good, g.loss_bad};
                          const double sum = g.p + g.r;  // validate_link refuses p = r = 0
                          c.stationary = {g.r / sum, g.p / sum};
                        }},
             link);
  return c;
}

// The operator's matrix: block (i, j) = p_ji ((1 − l_i) F_1 ⊗ F_1 + l_i F_0 ⊗ F_0).
Matrix operator_matrix(const ActuationModes& modes, const Chain& c) {
  const Matrix K1 = kron(modes.delivered, modes.delivered);
  const Matrix K0 = kron(modes.lost, modes.lost);
  const Eigen::Index b = K1.rows();
  const Eigen::Index m = c.to.rows();
  Matrix L = Matrix::Zero(m * b, m * b);
  for (Eigen::Index i = 0; i < m; ++i) {
    const double l = c.loss[static_cast<std::size_t>(i)];
    const Matrix T = (1.0 - l) * K1 + l * K0;
    for (Eigen::Index j = 0; j < m; ++j) L.block(i * b, j * b, b, b) = c.to(j, i) * T;
  }
  return L;
}

// Larger systems: the operator is positive (it maps PSD matrices to PSD matrices), so ρ is
// attained on the PSD cone (Krein-Rutman); applied without forming its matrix. The growth is
// averaged over the last iterations, which also covers periodic (rotating) modes.
double power_radius(const ActuationModes& modes, const Chain& c) {
  const Eigen::Index N = modes.delivered.rows();
  const std::size_t m = c.loss.size();
  std::vector<Matrix> Y(m, Matrix::Identity(N, N));
  constexpr int kIterations = 3000, kAveraged = 500;
  double log_growth = 0.0;
  for (int it = 0; it < kIterations; ++it) {
    std::vector<Matrix> next(m, Matrix::Zero(N, N));
    for (std::size_t i = 0; i < m; ++i) {
      for (std::size_t j = 0; j < m; ++j) {
        const double pji = c.to(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i));
        if (pji == 0.0) continue;
        next[i] += pji * ((1.0 - c.loss[i]) * modes.delivered * Y[j] * modes.delivered.transpose() +
                          c.loss[i] * modes.lost * Y[j] * modes.lost.transpose());
      }
    }
    double t = 0.0;
    for (const auto& y : next) t += y.trace();
    if (!(t > 0.0) || !std::isfinite(t)) return t > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
    if (it >= kIterations - kAveraged) log_growth += std::log(t);
    for (auto& y : next) y /= t;
    Y = std::move(next);
  }
  return std::exp(log_growth / kAveraged);
}

std::string num(double v) { return verdict_number(v); }

// The infimum of the family's rates above which `stable` holds at every rate (scan from the
// top, then bisection between the first unstable point and the stable one above it).
struct FamilyRate {
  enum class Kind { found, stable_everywhere, unstable_at_top, no_family } kind = Kind::no_family;
  double rate = 0.0;
};
FamilyRate critical_along_family(const LinkModel& link, const std::function<bool(const LinkModel&)>& stable,
                                 double tolerance) {
  const auto [lo, hi] = reachable_arrival_rates(link);
  auto stable_at = [&](double rate) {
    const auto model = link_at_arrival_rate(link, rate);
    return model && stable(*model);
  };
  FamilyRate out;
  if (!(hi - lo > 1e-12)) return out;
  if (!stable_at(hi)) {
    out.kind = FamilyRate::Kind::unstable_at_top;
    return out;
  }
  constexpr int kScan = 100;
  double above = hi;
  for (int k = 1; k <= kScan; ++k) {
    const double rate = hi - (hi - lo) * k / kScan;
    if (!stable_at(rate)) {
      double bad = rate, good = above;
      while (good - bad > tolerance) {
        const double mid = 0.5 * (good + bad);
        (stable_at(mid) ? good : bad) = mid;
      }
      out.kind = FamilyRate::Kind::found;
      out.rate = good;
      return out;
    }
    above = rate;
  }
  out.kind = FamilyRate::Kind::stable_everywhere;
  out.rate = lo;
  return out;
}

std::string family_words(const LinkModel& link) {
  return iid_family(link)
             ? "i.i.d. losses"
             : "the link's family (p varied; r, loss_good, loss_bad fixed: the loss at a fixed mean burst for the "
               "simple Gilbert channel)";
}

std::string mode_words(OnLoss on_loss, bool acknowledged) {
  return std::string(on_loss == OnLoss::hold ? "hold" : "zero") + " on loss, " +
         (acknowledged ? "acknowledged (TCP-like)" : "unacknowledged (UDP-like)");
}

// The smallest arrival rate above which the loop with this gain is mean-square stable along
// the link's family, and with zero on loss the necessary one (α² times the lost-run rate < 1).
void add_critical_rates(ActuationReport& r, const LinkModel& model, const ActuationModes& modes, OnLoss on_loss,
                        double alpha) {
  const FamilyRate f = critical_along_family(
      model, [&](const LinkModel& m) { return mss_radius(modes, m) < 1.0; }, 1e-10);
  switch (f.kind) {
    case FamilyRate::Kind::found:
      r.critical_rate = f.rate;
      r.critical_rate_reason = "smallest arrival rate above which the loop with this gain is mean-square stable, "
                               "along " + family_words(model);
      break;
    case FamilyRate::Kind::stable_everywhere:
      if (iid_family(model)) r.critical_rate = 0.0;
      r.critical_rate_reason = "mean-square stable at every arrival rate " +
                               std::string(iid_family(model)
                                               ? "(even when no input arrives)"
                                               : "this family reaches (down to " + num(f.rate) + ")");
      break;
    case FamilyRate::Kind::unstable_at_top:
      r.critical_rate_reason = "not mean-square stable even at the family's highest arrival rate";
      break;
    case FamilyRate::Kind::no_family:
      r.critical_rate_reason = "the link has no family of arrival rates (Gilbert-Elliott with r = 0 or "
                               "loss_good = loss_bad)";
      break;
  }
  if (on_loss == OnLoss::zero && alpha > 1.0) {
    const FamilyRate g = critical_along_family(
        model, [&](const LinkModel& m) { return alpha * alpha * lost_run_rate(m) < 1.0; }, 1e-12);
    if (g.kind == FamilyRate::Kind::found || g.kind == FamilyRate::Kind::stable_everywhere)
      r.critical_rate_lower = g.rate;
  } else if (on_loss == OnLoss::zero) {
    r.critical_rate_lower = reachable_arrival_rates(model).first;
  }
}

// The control side's verdict: the jump system's radius with acknowledgements; without them
// only an open-loop run of lost inputs decides (instability), otherwise unknown.
void decide_control(ActuationReport& r, const ControlSpec& c, bool acknowledged, double radius, double alpha,
                    double lost) {
  const std::string mode = mode_words(c.on_loss, c.acknowledged);
  const std::string at = "at arrival rate " + num(r.arrival_rate);
  const std::string critical = r.critical_rate ? " (critical rate " + num(*r.critical_rate) + ")" : "";
  if (acknowledged) {
    r.stable = radius < 1.0 ? Verdict::yes : Verdict::no;
    r.stable_reason = mode + ": the jump system of the loop with this gain is " +
                      (radius < 1.0 ? "mean-square stable, radius " + num(radius) + " < 1 "
                                    : "not mean-square stable, radius " + num(radius) + " >= 1 ") +
                      at + critical + " (Costa-Fragoso-Marques Thm 3.9)";
  } else if (c.on_loss == OnLoss::zero && alpha * alpha * lost > 1.0 - 1e-12) {
    r.stable = Verdict::no;
    r.stable_reason = mode + ": inputs are lost n in a row with probability ~" + num(lost) +
                      "^n, during which the plant runs open loop: alpha^2 * " + num(lost) + " = " +
                      num(alpha * alpha * lost) + " >= 1, unstable for every controller";
  } else {
    r.stable = Verdict::unknown;
    r.stable_reason = mode + ": no separation, the estimation error depends on inputs the estimator never learns "
                      "were applied (Schenato et al. 2007, Sec. VI); the papers decide stability only for R = 0 with "
                      "C invertible; with acknowledgements the loop would be " +
                      std::string(radius < 1.0 ? "stable" : "unstable") + " (radius " + num(radius) + ") " + at +
                      critical;
  }
}

// The LQ cost's bounds: only for an LQR gain (its weights define the cost) and acknowledged inputs.
void add_cost(ActuationReport& r, const Scenario& scenario, const ActuationModes& modes, const LinkModel& model,
              bool lqr, bool acknowledged, const ActuationOptions& options) {
  const ControlSpec& c = *scenario.plant.control;
  const Matrix& A = scenario.plant.A;
  if (!lqr) {
    r.cost_reason = "cost: needs plant.control.lqr (its weights Qx, Ru define the cost)";
  } else if (!acknowledged) {
    r.cost_reason = "cost: not computed for unacknowledged inputs (no separation; measure it on a run)";
  } else if (options.cost) {
    const auto model_cost = actuation_cost_model(A, scenario.plant.Q, modes, model, *c.lqr_Qx, *c.lqr_Ru);
    const Scenario effective = with_effective_links(scenario);
    std::string why;
    const auto pi = filtered_covariance_bounds(A, scenario.plant.Q, effective.sensors, &why);
    if (!model_cost) {
      r.cost_reason = "cost: infinite (the loop is not mean-square stable)";
    } else if (!pi) {
      r.cost_reason = "cost: " + why;
    } else {
      const auto [lo, hi] = cost_bounds(*model_cost, *pi);
      r.cost_lower = lo;
      r.cost_upper = hi;
      r.cost_reason = "cost: long-run mean of x'Qx x + u'Ru u (u as applied) = tr(S Q) + tr((A'SA + Qx - S) Pi), "
                      "Pi = lim E[P_k|k] between q S-bar and the update of V-bar (Schenato et al. 2007 Sec. V; "
                      "Sinopoli et al. 2005)";
    }
  }
}

ActuationReport build(const Scenario& scenario, const LinkModel& model, ActuationReport r,
                      const ActuationOptions& options) {
  const ControlSpec& c = *scenario.plant.control;
  const Matrix& A = scenario.plant.A;
  const Matrix& B = *scenario.plant.B;
  r.on_loss = c.on_loss;
  r.acknowledged = c.acknowledged;
  const bool lqr = c.lqr_Qx && c.lqr_Ru;
  const double gain_rate = actuation_arrival_rate(scenario);
  r.gain = !lqr ? "given" : gain_rate < 1.0 ? "lqr at the arrival rate" : "lqr";
  if (lqr) r.gain_arrival_rate = gain_rate;

  const ActuationModes modes = actuation_modes(A, B, c.gain, c.on_loss);
  const double radius = mss_radius(modes, model);
  r.mss_radius = radius;
  const double alpha = spectral_radius(A);
  if (options.critical_rate) add_critical_rates(r, model, modes, c.on_loss, alpha);

  // Nothing is lost: every input is applied, acknowledged or not.
  const bool acknowledged = c.acknowledged || r.arrival_rate >= 1.0;
  decide_control(r, c, acknowledged, radius, alpha, lost_run_rate(model));
  if (!acknowledged && r.critical_rate) {
    // The jump system's rate is the acknowledged loop's; without acknowledgements it is not known.
    r.critical_rate_reason = "unknown for unacknowledged inputs; with acknowledgements it would be " +
                             num(*r.critical_rate) + " (" + r.critical_rate_reason + ")";
    r.critical_rate.reset();
  }
  if (lqr && options.optimal) r.optimal = optimal_control_rates(A, B, *c.lqr_Qx, *c.lqr_Ru, options.use_lmi);
  add_cost(r, scenario, modes, model, lqr, acknowledged, options);
  return r;
}

}  // namespace

ActuationModes actuation_modes(const Matrix& A, const Matrix& B, const Matrix& gain, OnLoss on_loss) {
  const Eigen::Index n = A.rows();
  const Eigen::Index p = B.cols();
  ActuationModes m;
  m.states = n;
  if (on_loss == OnLoss::zero) {
    m.delivered = A - B * gain;
    m.lost = A;
    m.applied_delivered = -gain;
    m.applied_lost = Matrix::Zero(p, n);
    return m;
  }
  const Eigen::Index N = n + p;
  m.delivered = Matrix::Zero(N, N);
  m.delivered.topLeftCorner(n, n) = A - B * gain;
  m.delivered.bottomLeftCorner(p, n) = -gain;
  m.lost = Matrix::Zero(N, N);
  m.lost.topLeftCorner(n, n) = A;
  m.lost.topRightCorner(n, p) = B;
  m.lost.bottomRightCorner(p, p) = Matrix::Identity(p, p);
  m.applied_delivered = Matrix::Zero(p, N);
  m.applied_delivered.leftCols(n) = -gain;
  m.applied_lost = Matrix::Zero(p, N);
  m.applied_lost.rightCols(p) = Matrix::Identity(p, p);
  return m;
}

Matrix second_moment_operator(const ActuationModes& modes, const LinkModel& link) {
  return operator_matrix(modes, chain_of(link));
}

double mss_radius(const ActuationModes& modes, const LinkModel& link) {
  const Chain c = chain_of(link);
  const Eigen::Index size = modes.delivered.rows() * modes.delivered.rows() * c.to.rows();
  if (size > 400) return power_radius(modes, c);  // an eigen-solve of more than 400 rows takes seconds
  return spectral_radius(operator_matrix(modes, c));
}

double lost_run_rate(const LinkModel& link) {
  return std::visit(overloaded{[](const BernoulliLink& b) { return b.loss; },
                               [](const GilbertElliottLink& g) {
                                 // M(to, from) = P(from → to) · loss(to): a lost input followed by another lost one.
                                 Matrix M(2, 2);
                                 M << (1.0 - g.p) * g.loss_good, g.r * g.loss_good, g.p * g.loss_bad,
                                     (1.0 - g.r) * g.loss_bad;
                                 return spectral_radius(M);
                               }},
                    link);
}

std::pair<double, double> reachable_arrival_rates(const LinkModel& link) {
  using Rates = std::pair<double, double>;
  return std::visit(overloaded{[](const BernoulliLink&) -> Rates { return {0.0, 1.0}; },
                               [&](const GilbertElliottLink& g) -> Rates {
                                 if (g.r == 0.0 || g.loss_good == g.loss_bad) {
                                   const double own = 1.0 - stationary_loss(link);
                                   return {own, own};
                                 }
                                 // ν(p) = 1 − (r l_g + p l_b)/(p + r), monotone in p.
                                 const double at0 = 1.0 - g.loss_good;
                                 const double at1 = 1.0 - (g.r * g.loss_good + g.loss_bad) / (1.0 + g.r);
                                 return {std::min(at0, at1), std::max(at0, at1)};
                               }},
                    link);
}

std::optional<LinkModel> link_at_arrival_rate(const LinkModel& link, double arrival_rate) {
  if (!(arrival_rate >= 0.0 && arrival_rate <= 1.0)) return std::nullopt;
  using Model = std::optional<LinkModel>;
  return std::visit(
      overloaded{[&](const BernoulliLink&) -> Model { return LinkModel(BernoulliLink{1.0 - arrival_rate}); },
                 [&](GilbertElliottLink g) -> Model {
                   const auto [lo, hi] = reachable_arrival_rates(link);
                   if (arrival_rate < lo - 1e-15 || arrival_rate > hi + 1e-15) return std::nullopt;
                   if (hi - lo <= 0.0) return LinkModel(g);
                   // (1 − ν)(p + r) = r l_g + p l_b  ⇒  p = r ((1 − ν) − l_g) / (l_b − (1 − ν)).
                   const double loss = 1.0 - arrival_rate;
                   g.p = std::clamp(g.r * (loss - g.loss_good) / (g.loss_bad - loss), 0.0, 1.0);
                   if (!std::isfinite(g.p)) return std::nullopt;
                   return LinkModel(g);
                 }},
      link);
}

RateResult actuation_critical_rate(const ActuationModes& modes, const LinkModel& link, double tolerance) {
  const FamilyRate f = critical_along_family(
      link, [&](const LinkModel& m) { return mss_radius(modes, m) < 1.0; }, tolerance);
  RateResult r;
  switch (f.kind) {
    case FamilyRate::Kind::found: r.rate = f.rate; r.reason = "found"; break;
    case FamilyRate::Kind::stable_everywhere:
      if (iid_family(link)) r.rate = 0.0;
      r.reason = "stable at every reachable arrival rate (down to " + num(f.rate) + ")";
      break;
    case FamilyRate::Kind::unstable_at_top: r.reason = "not stable even at the highest reachable arrival rate"; break;
    case FamilyRate::Kind::no_family: r.reason = "no family of arrival rates"; break;
  }
  return r;
}

OptimalControlRates optimal_control_rates(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru,
                                          bool use_lmi) {
  // The dual estimation problem: state matrix A', one "sensor" C = B', R = Ru, whose arrival
  // rate is the input's (lqr.hpp, solve_lossy_dare).
  SensorSpec dual;
  dual.C = B.transpose();
  dual.R = Ru;
  const std::vector<SensorSpec> sensors{dual};
  const Matrix At = A.transpose();
  OptimalControlRates r;
  r.lower = critical_rate_lower_bound(spectral_radius(A), 1);
  r.upper_iteration = upper_rate_iteration(At, Qx, sensors, shared_rate(1), r.lower);
  r.upper = use_lmi ? upper_rate_lmi(At, sensors, shared_rate(1), r.lower) : r.upper_iteration;
  return r;
}

std::optional<CostModel> actuation_cost_model(const Matrix& A, const Matrix& Q, const ActuationModes& modes,
                                              const LinkModel& link, const Matrix& Qx, const Matrix& Ru) {
  const Chain c = chain_of(link);
  const Matrix L = operator_matrix(modes, c);
  if (!(spectral_radius(L) < 1.0)) return std::nullopt;
  const Eigen::Index N = modes.delivered.rows();
  const Eigen::Index n = modes.states;
  const Eigen::Index m = c.to.rows();
  Matrix W = Matrix::Zero(N, N);
  W.topLeftCorner(n, n) = Qx;
  const Matrix C1 = W + modes.applied_delivered.transpose() * Ru * modes.applied_delivered;
  const Matrix C0 = W + modes.applied_lost.transpose() * Ru * modes.applied_lost;
  // The cost of a step taken from chain state j: K_j = Σ_i p_ji ((1 − l_i) C_1 + l_i C_0).
  Vector k(m * N * N);
  for (Eigen::Index j = 0; j < m; ++j) {
    Matrix K = Matrix::Zero(N, N);
    for (Eigen::Index i = 0; i < m; ++i) {
      const double l = c.loss[static_cast<std::size_t>(i)];
      K += c.to(j, i) * ((1.0 - l) * C1 + l * C0);
    }
    k.segment(j * N * N, N * N) = Eigen::Map<const Vector>(K.data(), N * N);
  }
  // The adjoint (cost-to-go) S = (I − L')^{-1} k: the stationary cost is ⟨S, noise⟩, and the
  // noise (the innovations) enters x in chain state i with weight π_i.
  const Vector s = (Matrix::Identity(L.rows(), L.cols()) - L.transpose()).partialPivLu().solve(k);
  Matrix Sx = Matrix::Zero(n, n);
  for (Eigen::Index i = 0; i < m; ++i) {
    const Matrix Si = Eigen::Map<const Matrix>(s.data() + i * N * N, N, N);
    Sx += c.stationary[static_cast<std::size_t>(i)] * Si.topLeftCorner(n, n);
  }
  Sx = 0.5 * (Sx + Sx.transpose());
  CostModel out;
  out.constant = (Sx * Q).trace();
  out.weight = A.transpose() * Sx * A - Sx + Qx;
  out.weight = 0.5 * (out.weight + out.weight.transpose());
  return out;
}

std::optional<FilteredCovarianceBounds> filtered_covariance_bounds(const Matrix& A, const Matrix& Q,
                                                                   std::span<const SensorSpec> sensors,
                                                                   std::string* why_not) {
  auto no = [&](const std::string& why) -> std::optional<FilteredCovarianceBounds> {
    if (why_not) *why_not = why;
    return std::nullopt;
  };
  if (sensors.empty()) return no("no sensors: the estimate is an open-loop prediction");
  if (sensors.size() > 16) return no("the bounds on E[P_k|k] sum the 2^d arrival patterns: too many for " +
                                     std::to_string(sensors.size()) + " sensors");
  std::vector<double> rates;
  for (const auto& s : sensors) {
    const auto rate = iid_arrival_rate(s.link.loss);
    if (!rate) return no("the bounds on E[P_k|k] assume i.i.d. sensor links; a Gilbert-Elliott link has memory");
    rates.push_back(*rate);
  }
  const auto patterns = independent_arrival_patterns(sensors, rates);
  const double q = all_lost_probability(rates);
  const auto lower = lyapunov_lower_bound(A, Q, q);
  const UpperBound upper = expected_covariance_upper_bound(A, Q, patterns);
  if (!lower || upper.status != BoundStatus::bounded)
    return no("E[P_k|k] is not bounded (or its bound undecided) at these sensor rates");
  FilteredCovarianceBounds out;
  out.upper = Matrix::Zero(A.rows(), A.rows());
  for (const auto& s : patterns) {
    Matrix phi = upper.V;
    if (s.C.rows() > 0) {
      const Matrix CV = s.C * upper.V;
      phi -= CV.transpose() * (s.C * upper.V * s.C.transpose() + s.R).ldlt().solve(CV);
    }
    out.upper += s.probability * phi;
  }
  out.upper = 0.5 * (out.upper + out.upper.transpose());
  const bool surely = std::all_of(rates.begin(), rates.end(), [](double r) { return r >= 1.0; });
  out.lower = surely ? out.upper : Matrix(q * *lower);
  return out;
}

std::pair<double, double> cost_bounds(const CostModel& model, const FilteredCovarianceBounds& bounds) {
  const double base = model.constant + (model.weight * bounds.lower).trace();
  const Matrix D = bounds.upper - bounds.lower;
  Eigen::SelfAdjointEigenSolver<Matrix> es(model.weight);
  const Vector ev = es.eigenvalues();
  const Matrix& V = es.eigenvectors();
  const Matrix plus = V * ev.cwiseMax(0.0).asDiagonal() * V.transpose();
  const Matrix minus = V * (-ev).cwiseMax(0.0).asDiagonal() * V.transpose();
  return {base - (minus * D).trace(), base + (plus * D).trace()};
}

std::optional<ActuationReport> analyze_actuation(const Scenario& scenario, const ActuationOptions& options) {
  const LinkSpec* link = scenario.actuation_link();
  if (!link) return std::nullopt;
  ActuationReport r;
  r.link = describe_link(*link);
  r.deadline_ms = scenario.actuation_deadline_ms();
  r.loss = stationary_loss(link->loss);
  r.in_time = probability_within(link->delay, r.deadline_ms);
  r.arrival_rate = arrival_rate(link->loss, r.in_time);
  // What reaches the plant in time: delays fold into the loss, as for the sensors.
  return build(scenario, effective_loss_model(*link, r.deadline_ms), r, options);
}

std::optional<ActuationReport> analyze_actuation_at(const Scenario& scenario, double rate,
                                                    const ActuationOptions& options) {
  if (!scenario.actuation_link()) return std::nullopt;
  const double nu = std::isfinite(rate) ? std::clamp(rate, 0.0, 1.0) : 0.0;
  ActuationReport r;
  const LinkModel model = BernoulliLink{1.0 - nu};
  r.link = describe_link_model(model);
  r.deadline_ms = scenario.actuation_deadline_ms();
  r.loss = 1.0 - nu;
  r.arrival_rate = nu;
  return build(scenario, model, r, options);
}

ClosedLoopVerdict closed_loop_verdict(Verdict estimator, const std::string& estimator_reason,
                                      const ActuationReport& actuation) {
  ClosedLoopVerdict v;
  if (estimator == Verdict::no || actuation.stable == Verdict::no) v.stable = Verdict::no;
  else if (estimator == Verdict::yes && actuation.stable == Verdict::yes) v.stable = Verdict::yes;
  v.reason = "closed loop " + std::string(to_string(v.stable)) + ": estimator: " + estimator_reason +
             "; actuation: " + actuation.stable_reason;
  return v;
}

ActuationRegion actuation_region(const Scenario& scenario, int sensor_id, int points,
                                 const ProgressCallback& progress) {
  ActuationRegion region;
  region.sensor_id = sensor_id;
  const Scenario effective = with_effective_links(scenario);
  std::size_t index = effective.sensors.size();
  for (std::size_t i = 0; i < effective.sensors.size(); ++i)
    if (effective.sensors[i].id == sensor_id) index = i;
  const auto act = analyze_actuation(scenario, {true, false, false, false});
  if (index == effective.sensors.size() || !act) return region;

  auto estimator_at = [&](double gamma) {
    std::vector<SensorSpec> sensors = effective.sensors;
    sensors[index].link = BernoulliLink{1.0 - gamma};
    return decide_stability(effective.plant.A, effective.plant.Q, sensors, effective.seed).stable;
  };
  // The actuation side does not depend on γ̄ (separation): its family's ends decide the
  // columns where no critical rate was found.
  const LinkModel model = effective_loss_model(*scenario.actuation_link(), scenario.actuation_deadline_ms());
  const ActuationModes modes =
      actuation_modes(scenario.plant.A, *scenario.plant.B, scenario.plant.control->gain, scenario.plant.control->on_loss);
  const auto [lo, hi] = reachable_arrival_rates(model);
  const auto at_top = link_at_arrival_rate(model, hi);
  const bool stable_at_top = at_top && mss_radius(modes, *at_top) < 1.0;
  const bool acknowledged = act->acknowledged || act->arrival_rate >= 1.0;

  const int n = std::max(2, points);
  ProgressReporter report(progress, n);
  for (int k = 0; k < n; ++k) {
    ActuationRegionPoint p;
    p.gamma = static_cast<double>(k) / (n - 1);
    p.estimator = estimator_at(p.gamma);
    p.nu_lower = 1.0;
    if (p.estimator != Verdict::no) {
      if (acknowledged) {
        const double critical = act->critical_rate ? *act->critical_rate : stable_at_top ? lo : 1.0;
        p.nu_lower = critical;
        if (p.estimator == Verdict::yes && (act->critical_rate || stable_at_top)) p.nu_upper = critical;
      } else {
        p.nu_lower = act->critical_rate_lower.value_or(0.0);
      }
    }
    region.points.push_back(p);
    report.add(1);
  }
  region.gamma_lower = infimum_stable_rate([&](double g) { return estimator_at(g) != Verdict::no; }, 0.0, 1.0, 1e-6);
  region.gamma_upper = infimum_stable_rate([&](double g) { return estimator_at(g) == Verdict::yes; }, 0.0, 1.0, 1e-6);
  return region;
}

}  // namespace netkf::theory
