#pragma once
// A loss model fitted to a measured arrival trace (`netkf fit`, docs/cli.md): which link
// of netkf/links/link.hpp explains the trace, with standard errors, 95% intervals, the
// log-likelihood, AIC and a goodness of fit of the burst and gap lengths.
//
// Families (each a link a scenario can take):
//  - bernoulli: i.i.d. drops, loss. Closed form.
//  - simple_gilbert: Gilbert-Elliott with loss_good 0, loss_bad 1 — the chain's state is
//    seen (a drop is Bad), so p and r are transition frequencies. Closed form.
//  - gilbert: loss_good 0, loss_bad free (p, r, loss_bad);
//  - gilbert_elliott: p, r, loss_good, loss_bad.
//    Both by maximum likelihood of the 2-state hidden Markov chain: Baum-Welch (EM with the
//    scaled forward-backward recursions: L. R. Rabiner, "A tutorial on hidden Markov models",
//    Proc. IEEE 77(2), 1989, Sec. III.C and V.A) from several seeded starts
//    (a few iterations each, then the best one to convergence), the nested fits (simple
//    Gilbert; for gilbert_elliott also Bernoulli) taken when they are better: EM cannot
//    reach the boundary loss_bad = 1.
//
// Likelihood, the same for every family so that their AIC compare: log P(x_1..x_n) with the
// chain started in its stationary distribution, as netkf/links/link_statistics.hpp's stationary_loss() reads
// a link, and, as LinkLossProcess draws, the chain first moves, then the sample is dropped
// with the new state's loss. (The closed forms and the EM's M-step maximise the likelihood
// given the first state, which differs from it by the first sample's term only, O(1/n).)
//
// Intervals: the observed information, a numerical Hessian (central differences) of the
// log-likelihood in the logit of each free probability, inverted; a 95% Wald interval in
// logit space mapped back, so it stays inside (0, 1). A derived number (loss, mean_burst)
// gets its standard error by the delta method. A parameter at its boundary (estimate
// within 1e-6 of 0 or 1) has no interval (the Wald interval does not hold there).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "netkf/links/link.hpp"

namespace netkf::fit {

enum class LossFamily { bernoulli, simple_gilbert, gilbert, gilbert_elliott };
/// "bernoulli", "simple_gilbert", "gilbert", "gilbert_elliott".
const char* to_string(LossFamily family);
/// nullopt for anything else.
std::optional<LossFamily> parse_loss_family(const std::string& name);
/// Free parameters of the family (its k in AIC = 2k − 2 log L).
int free_parameters(LossFamily family);

/// One fitted number under its scenario key name (loss, p, r, loss_good, loss_bad) or a
/// derived one (mean_burst). No standard error / interval: nullopt (fixed by the family, at
/// a boundary, or the information matrix is singular there).
struct FittedValue {
  std::string name;
  double value = 0.0;
  bool free = true;  // estimated (false: fixed by the family, e.g. simple_gilbert's loss_bad 1)
  std::optional<double> stderr_value;
  std::optional<double> ci_low, ci_high;  // 95%
};

/// Observed against the fitted model's expected count of runs of one length range.
struct RunBin {
  int from = 1;
  int to = 1;  // inclusive; -1: "from and longer"
  double observed = 0.0;
  double expected = 0.0;
};

/// Pearson's chi-square of a run-length histogram: lengths 1, 2, ... in bins pooled until
/// each expects at least 5 runs, the last bin open ("K and longer"); degrees of freedom =
/// bins − 1 − the family's free parameters (at least 1). Runs touching either end of the
/// trace are left out (their length is censored). nullopt statistic: fewer than 2 bins.
struct RunLengthTest {
  std::size_t runs = 0;  // complete runs in the trace
  std::vector<RunBin> bins;
  std::optional<double> chi_square;
  int degrees_of_freedom = 0;
  std::optional<double> p_value;
};

struct LossFit {
  LossFamily family = LossFamily::bernoulli;
  LinkModel link;                   // the fitted link, as a scenario takes it
  std::vector<FittedValue> parameters;  // the link's keys: {loss} or {p, r, loss_good, loss_bad}
  FittedValue loss;                 // stationary loss (stationary_loss of `link`)
  FittedValue mean_burst;           // mean run of drops (mean_burst_length of `link`)
  double log_likelihood = 0.0;
  double aic = 0.0;                 // 2 · free_parameters − 2 · log_likelihood
  RunLengthTest bursts;             // runs of drops
  RunLengthTest gaps;               // runs of deliveries
  int iterations = 0;               // EM iterations of the best start (0: closed form)
  int starts = 0;                   // EM starts tried (0: closed form)
  bool converged = true;            // EM met its tolerance
  std::vector<std::string> notes;   // boundaries, singular information, ...
};

/// The delay column of a trace, over the delivered samples.
struct DelaySummary {
  std::size_t samples = 0;
  double mean_ms = 0.0;
  double jitter_ms = 0.0;  // standard deviation (n − 1)
  std::vector<std::pair<double, double>> quantiles;  // (q, delay): q = 0, .05, .25, .5, .75, .95, .99, 1
};

struct LossFitOptions {
  /// The family to fit; nullopt: every family, and pick by AIC (`auto`): the least AIC,
  /// but a simpler family within 2 of it is preferred (parsimony).
  std::optional<LossFamily> family;
  int starts = 8;                 // EM starts: one from the simple Gilbert fit, the rest random
  std::uint64_t seed = 1;         // of the random starts (derive_seed(seed, "loss-fit", start))
  int start_iterations = 30;      // EM iterations of every start before the best one goes on
  int max_iterations = 5000;      // EM iterations of the best start in all
  double tolerance = 1e-10;       // stop when log L changes by less than this, relative, per iteration
};

struct TraceFit {
  std::size_t samples = 0;
  std::size_t dropped = 0;
  std::vector<LossFit> candidates;  // the families fitted, in LossFamily order
  std::size_t chosen = 0;           // index into candidates
  std::string why;                  // why this family (AIC comparison, or "asked for")
  std::vector<std::string> notes;   // families that could not be fitted, and why
  const LossFit& fit() const { return candidates.at(chosen); }
};

/// Fit a trace of arrivals (delivered[t] = 1 when sample t arrived). Throws
/// std::invalid_argument for an empty trace.
TraceFit fit_loss_model(std::span<const std::uint8_t> delivered, const LossFitOptions& options = {});

/// Exact log P(x_1..x_n) of the trace under a link (the likelihood above); -inf when the
/// link cannot produce the trace.
double trace_log_likelihood(std::span<const std::uint8_t> delivered, const LinkModel& link);

/// The fitted link's distribution of run lengths: P(a run of drops (dropped = true) or of
/// deliveries has length L), L = 1 .. max_length, for the stationary chain.
std::vector<double> run_length_distribution(const LinkModel& link, bool dropped, int max_length);

/// The lengths of the complete runs of drops (dropped) or deliveries in a trace.
std::vector<std::size_t> run_lengths(std::span<const std::uint8_t> delivered, bool dropped);

/// Mean, jitter and quantiles of the delays of the delivered samples (NaN entries skipped).
/// nullopt when no sample has a delay.
std::optional<DelaySummary> summarize_delays(std::span<const double> delay_ms);

/// The upper tail of the chi-square distribution: P(X >= x), X ~ χ²(k).
double chi_square_upper_tail(double x, int degrees_of_freedom);

}  // namespace netkf::fit
