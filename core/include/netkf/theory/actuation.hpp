#pragma once
// The control side of a loop closed over a lossy actuation link (plant.control.link,
// docs/scenario-format.md): is the loop with the scenario's gain mean-square stable, at which
// arrival rate does it stop being so, and what does it cost?
//
// With the gain L fixed, the loop is a Markov jump linear system z_{k+1} = F_{ν_k} z_k, ν_k = 1
// when u_k = −L x̂_{k|k} reached the plant in time (actuation_modes):
//   zero on loss: z = x,             F_1 = A − BL,               F_0 = A;
//   hold on loss: z = [x; u_{k−1}],  F_1 = [[A − BL, 0], [−L, 0]], F_0 = [[A, B], [0, I]]
// (u_{k−1}: the input applied at the previous tick). It is mean-square stable iff the spectral
// radius of its second-moment operator is < 1 (Costa, Fragoso & Marques, "Discrete-time Markov
// jump linear systems", 2005, Thm 3.9): for i.i.d. (Bernoulli) losses
//   ρ(ν̄ F_1 ⊗ F_1 + (1 − ν̄) F_0 ⊗ F_0);
// for a Gilbert-Elliott link the operator over the chain's states i (loss l_i, transitions
// p_ji = P(j → i)), in the order the link draws (netkf/links/loss_model.hpp: the chain moves, then
// the input's fate is drawn in the state entered):
//   Y_i' = Σ_j p_ji [(1 − l_i) F_1 Y_j F_1' + l_i F_0 Y_j F_0'],   Y_i = E[z z' 1{state i}].
// Its spectral radius does not depend on that order (the other order is the product of the
// same two factors the other way round); its stationary moments do.
//
// Acknowledged inputs (TCP-like): the estimator knows the input applied, the separation
// principle holds (Schenato et al. 2007, Sec. V; Sinopoli et al., ACC 2005), and x̂_{k|k} moves
// by the same F_ν driven by the innovations: the closed loop is mean-square stable iff the
// estimator is (theory/stability.hpp) and the jump system is. Unacknowledged (UDP-like): the
// estimation error depends on inputs the estimator never learns were applied, no separation
// (Schenato et al. 2007, Sec. VI): decided only where a necessary condition fails.
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "netkf/links/link.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/support/types.hpp"
#include "netkf/theory/critical_rate.hpp"
#include "netkf/theory/stability.hpp"

namespace netkf::theory {

/// The jump system of the loop (see above), and the input the plant applies in each mode:
/// u^a = applied_delivered · z when the input arrived, applied_lost · z when it did not.
struct ActuationModes {
  Matrix delivered;          // F_1
  Matrix lost;               // F_0
  Matrix applied_delivered;  // p x N: −L (zero) or [−L, 0] (hold)
  Matrix applied_lost;       // p x N: 0 (zero) or [0, I] (hold)
  Eigen::Index states = 0;   // n: the first n entries of z are x
};
ActuationModes actuation_modes(const Matrix& A, const Matrix& B, const Matrix& gain, OnLoss on_loss);

/// The second-moment operator as a matrix on the stacked vec(Y_i) (column-major vec; one
/// state for a Bernoulli link, good then bad for Gilbert-Elliott).
Matrix second_moment_operator(const ActuationModes& modes, const LinkModel& link);
/// Its spectral radius: < 1 iff the loop is mean-square stable.
double mss_radius(const ActuationModes& modes, const LinkModel& link);

/// limsup_N P(N inputs in a row are lost)^{1/N}: 1 − ν̄ for a Bernoulli link, the spectral
/// radius of the chain restricted to losses for Gilbert-Elliott. With zero on loss, every
/// controller needs α² times it below 1 (while inputs are lost the plant runs open loop).
double lost_run_rate(const LinkModel& link);

/// The links an actuation link's critical rate is taken along: Bernoulli, loss = 1 − ν̄;
/// Gilbert-Elliott, p (how often a bad spell starts) varied with r, loss_good and loss_bad
/// fixed — for the simple Gilbert channel that is the loss at a fixed mean burst, the user's
/// form. nullopt when no link of the family has arrival rate ν̄.
std::optional<LinkModel> link_at_arrival_rate(const LinkModel& link, double arrival_rate);
/// The arrival rates the family reaches: [0, 1] for Bernoulli, p from 1 to 0 for Gilbert-Elliott.
std::pair<double, double> reachable_arrival_rates(const LinkModel& link);

struct RateResult {
  std::optional<double> rate;
  std::string reason;  // how it was found, or why there is none
};
/// ν_c for the gain: the smallest arrival rate above which every rate of the family is
/// mean-square stable (a scan of 200 points from the top, then bisection to `tolerance`: the
/// radius need not be monotone in ν̄). 0 for a Bernoulli link stable at every rate.
RateResult actuation_critical_rate(const ActuationModes& modes, const LinkModel& link, double tolerance = 1e-10);

/// The optimal controller's critical rates (TCP-like, zero on loss, Bernoulli link; needs the
/// LQR weights): the rate below which the control Riccati equation of lossy_lqr_gain has no
/// solution, i.e. no controller has finite cost. By duality it is the estimator's λ̄ of the
/// system (A', B') (Schenato et al. 2007, Sec. V), found like it (theory/critical_rate.hpp).
struct OptimalControlRates {
  double lower = 0.0;                     // ν_min = 1 − 1/α² (α = max |eig A|); = ν_c when B is square and invertible
  std::optional<double> upper;            // bisection on the LMI (CSDP; Sinopoli Thm 5 for the dual)
  std::optional<double> upper_iteration;  // bisection on whether the Riccati iteration has a fixed point
};
OptimalControlRates optimal_control_rates(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru,
                                          bool use_lmi = true);

/// The long-run mean cost J = lim (1/N) Σ E[x_k'Qx x_k + u^a_k' Ru u^a_k] (u^a: the input applied)
/// of the acknowledged loop, as a function of Π = lim E[P_{k|k}]:  J = constant + tr(weight Π),
///   constant = tr(S_x Q),  weight = A'S_x A − S_x + Qx,
/// where S_x is the x-block of the jump system's cost matrix (its stationary solution, averaged
/// over the chain). For the optimal gain at ν̄ this is Schenato et al. 2007 / Sinopoli et al.
/// 2005's J = tr(SQ) + tr((A'SA + W − S) Π), with weight = ν̄ A'SB(B'SB + U)^{-1}B'SA ⪰ 0.
/// nullopt when the jump system is not mean-square stable (J infinite).
struct CostModel {
  double constant = 0.0;
  Matrix weight;
};
std::optional<CostModel> actuation_cost_model(const Matrix& A, const Matrix& Q, const ActuationModes& modes,
                                              const LinkModel& link, const Matrix& Qx, const Matrix& Ru);

/// Bounds on Π = lim E[P_{k|k}] for i.i.d. sensor links: q S̄ ⪯ Π ⪯ Σ_S π_S φ_S(V̄), with S̄, V̄
/// the bounds on E[P_{k|k−1}] (Sinopoli Thm 4, 6; Liu-Goldsmith Thm 4), q the probability that
/// nothing arrives and φ_S the update with the samples of S (concave: Jensen). Exact (both
/// bounds the standard filter's) when every sensor arrives surely.
struct FilteredCovarianceBounds {
  Matrix lower;
  Matrix upper;
};
std::optional<FilteredCovarianceBounds> filtered_covariance_bounds(const Matrix& A, const Matrix& Q,
                                                                   std::span<const SensorSpec> sensors,
                                                                   std::string* why_not = nullptr);

/// [lower, upper] of constant + tr(weight Π) over lower ⪯ Π ⪯ upper: for weight ⪰ 0 the two
/// ends; otherwise weight = W₊ − W₋ gives tr(weight Π) ∈ tr(weight lower) + [−tr(W₋ D), tr(W₊ D)],
/// D = upper − lower.
std::pair<double, double> cost_bounds(const CostModel& model, const FilteredCovarianceBounds& bounds);

struct ActuationOptions {
  bool critical_rate = true;
  bool optimal = true;   // OptimalControlRates (with LQR weights)
  bool use_lmi = true;
  bool cost = true;
};

/// What `netkf analyze` reports of the actuation link (JSON `actuation`, docs/cli.md).
struct ActuationReport {
  OnLoss on_loss = OnLoss::zero;
  bool acknowledged = true;
  std::string link;                  // describe_link of the configured link
  double deadline_ms = 0.0;          // actuation_deadline_ms
  double loss = 0.0;                 // stationary loss of the configured model
  double in_time = 1.0;              // P(delay ≤ deadline_ms)
  double arrival_rate = 1.0;         // ν̄ = (1 − loss) · in_time
  std::optional<double> mss_radius;  // of the jump system with the scenario's gain
  std::optional<double> critical_rate;
  std::string critical_rate_reason;
  std::optional<double> critical_rate_lower;  // zero on loss: below it no controller is stable
  Verdict stable = Verdict::unknown;          // the control side (closed_loop_verdict combines)
  std::string stable_reason;
  std::string gain;                  // "given", "lqr" or "lqr at the arrival rate"
  std::optional<double> gain_arrival_rate;    // the ν̄ an LQR gain was computed for
  std::optional<OptimalControlRates> optimal;
  std::optional<double> cost_lower;  // bounds on J (acknowledged, LQR weights, i.i.d. sensors)
  std::optional<double> cost_upper;
  std::string cost_reason;           // how, or why not
};

/// The actuation link's report for a validated scenario; nullopt without an actuation link.
/// Never throws for a valid scenario.
std::optional<ActuationReport> analyze_actuation(const Scenario& scenario, const ActuationOptions& options = {});

/// The same with the actuation link replaced by i.i.d. losses at `arrival_rate` (an observed
/// rate; the live status), without delay.
std::optional<ActuationReport> analyze_actuation_at(const Scenario& scenario, double arrival_rate,
                                                    const ActuationOptions& options = {});

/// The closed loop's verdict from the estimator's and the actuation link's: no when either is
/// no, yes when both are yes, else unknown; the reason says both.
struct ClosedLoopVerdict {
  Verdict stable = Verdict::unknown;
  std::string reason;
};
ClosedLoopVerdict closed_loop_verdict(Verdict estimator, const std::string& estimator_reason,
                                      const ActuationReport& actuation);

/// `analyze --region` for one sensor and the actuation link: for each arrival rate γ̄ of the
/// sensor (its link i.i.d. at γ̄, the other sensors as configured), the actuation rates ν̄
/// below which the loop is unstable and above which it is stable.
struct ActuationRegionPoint {
  double gamma = 0.0;
  Verdict estimator = Verdict::unknown;  // the estimator's verdict at γ̄
  double nu_lower = 0.0;                 // below: not stable (1 when no ν̄ is)
  std::optional<double> nu_upper;        // above: stable (nullopt: no ν̄ is shown stable)
};
struct ActuationRegion {
  int sensor_id = 0;
  std::optional<double> gamma_lower;  // the estimator's critical rate: unstable below (bisection on the verdict)
  std::optional<double> gamma_upper;  // stable above
  std::vector<ActuationRegionPoint> points;
};
ActuationRegion actuation_region(const Scenario& scenario, int sensor_id, int points = 21,
                                 const ProgressCallback& progress = {});

}  // namespace netkf::theory
