// Fitting a loss model to an arrival trace (netkf/fit/loss_fit.hpp).
#include "netkf/fit/loss_fit.hpp"

#include <algorithm>
#include <array>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <Eigen/Dense>
#include <functional>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "netkf/links/link_statistics.hpp"
#include "netkf/support/random.hpp"

namespace netkf::fit {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kZ95 = 1.959963984540054;  // Φ⁻¹(0.975)
constexpr double kBoundary = 1e-6;           // a probability this close to 0 or 1 is at its boundary
constexpr double kMinExpected = 5.0;         // chi-square bins expect at least this many runs

// The 2-state chain of every family: Good (0), Bad (1); p = P(G→B), r = P(B→G), and the
// drop probability of each state. A Bernoulli link is the chain that stays in Good.
struct Chain {
  double p = 0.0, r = 1.0, loss_good = 0.0, loss_bad = 1.0;
};

Chain chain_of(const LinkModel& link) {
  return std::visit(overloaded{[](const BernoulliLink& b) { return Chain{0.0, 1.0, b.loss, b.loss}; },
                               [](const GilbertElliottLink& g) { return Chain{g.p, g.r, g.loss_good, g.loss_bad}; }},
                    link);
}

std::array<double, 2> stationary(const Chain& c) {
  const double total = c.p + c.r;
  if (total <= 0.0) return {1.0, 0.0};
  return {c.r / total, c.p / total};
}

// P(x | state): x = 1 dropped.
double emission(const Chain& c, int state, bool dropped) {
  const double loss = state == 0 ? c.loss_good : c.loss_bad;
  return dropped ? loss : 1.0 - loss;
}

double logit(double v) { return std::log(v / (1.0 - v)); }
double logistic(double t) { return 1.0 / (1.0 + std::exp(-t)); }

// Sums log c_t over many steps with few logarithms: the product of the c_t (each in (0, 1])
// is kept until it gets small, then its log is added.
class LogSum {
 public:
  void add(double c) {
    if (c < 1e-100) {
      sum_ += std::log(c);
      return;
    }
    product_ *= c;
    if (product_ < 1e-150) flush();
  }
  double total() {
    flush();
    return sum_;
  }

 private:
  void flush() {
    sum_ += std::log(product_);
    product_ = 1.0;
  }
  double sum_ = 0.0, product_ = 1.0;
};

// The scaled forward recursion (Rabiner 1989, Sec. V.A, "Scaling"): alpha[t] =
// P(state_t | x_1..x_t), and log L = Σ log c_t with c_t = P(x_t | x_1..x_{t-1}). `alpha` may be null (likelihood only).
double forward(std::span<const std::uint8_t> dropped, const Chain& c, std::vector<std::array<double, 2>>* alpha,
               std::vector<double>* scale) {
  const auto pi = stationary(c);
  const double P[2][2] = {{1.0 - c.p, c.p}, {c.r, 1.0 - c.r}};
  const double e[2][2] = {{emission(c, 0, false), emission(c, 1, false)},   // [x][state]
                          {emission(c, 0, true), emission(c, 1, true)}};
  LogSum log_l;
  std::array<double, 2> a{};
  for (std::size_t t = 0; t < dropped.size(); ++t) {
    const double* ex = e[dropped[t] != 0];
    const double n0 = (t == 0 ? pi[0] : a[0] * P[0][0] + a[1] * P[1][0]) * ex[0];
    const double n1 = (t == 0 ? pi[1] : a[0] * P[0][1] + a[1] * P[1][1]) * ex[1];
    const double ct = n0 + n1;
    if (!(ct > 0.0)) return -kInf;
    a = {n0 / ct, n1 / ct};
    log_l.add(ct);
    if (alpha) (*alpha)[t] = a;
    if (scale) (*scale)[t] = ct;
  }
  return log_l.total();
}

// Which of a chain's numbers a family fits, by their scenario key names.
std::vector<std::string> free_names(LossFamily f) {
  switch (f) {
    case LossFamily::bernoulli: return {"loss"};
    case LossFamily::simple_gilbert: return {"p", "r"};
    case LossFamily::gilbert: return {"p", "r", "loss_bad"};
    case LossFamily::gilbert_elliott: return {"p", "r", "loss_good", "loss_bad"};
  }
  return {};
}

double get(const Chain& c, const std::string& name) {
  if (name == "p") return c.p;
  if (name == "r") return c.r;
  if (name == "loss_good" || name == "loss") return c.loss_good;
  return c.loss_bad;
}

void set(Chain& c, const std::string& name, double v) {
  if (name == "p") c.p = v;
  else if (name == "r") c.r = v;
  else if (name == "loss") c.loss_good = c.loss_bad = v;  // Bernoulli: both states drop alike
  else if (name == "loss_good") c.loss_good = v;
  else c.loss_bad = v;
}

LinkModel link_of(LossFamily f, const Chain& c) {
  if (f == LossFamily::bernoulli) return BernoulliLink{c.loss_good};
  return GilbertElliottLink{c.p, c.r, c.loss_good, c.loss_bad};
}

// ---- EM (Baum-Welch) for the hidden chain ---------------------------------------------

struct EmState {
  Chain chain;
  double log_likelihood = -kInf;  // of `chain`
  double last_step = -kInf;       // of the chain the last step started from
  int iterations = 0;
  bool converged = false;
};

// One Baum-Welch step from `c`: returns the updated chain and sets `log_l` to the
// log-likelihood of `c`. The backward pass carries beta_t scaled by the forward c_t
// (Rabiner 1989, Sec. V.A); gamma_t(i) = alpha_t(i) beta_t(i), and xi_t(i, j) = alpha_{t-1}(i)
// P_ij e_j(x_t) beta_t(j) / c_t.
Chain baum_welch_step(std::span<const std::uint8_t> dropped, const Chain& c, bool loss_good_free,
                      std::vector<std::array<double, 2>>& alpha, std::vector<double>& scale, double& log_l) {
  const std::size_t n = dropped.size();
  log_l = forward(dropped, c, &alpha, &scale);
  if (!std::isfinite(log_l)) return c;
  const double P[2][2] = {{1.0 - c.p, c.p}, {c.r, 1.0 - c.r}};
  const double e[2][2] = {{emission(c, 0, false), emission(c, 1, false)},  // [x][state]
                          {emission(c, 0, true), emission(c, 1, true)}};
  std::array<double, 2> beta{1.0, 1.0};
  double trans[2][2] = {{0, 0}, {0, 0}};
  double occupancy[2] = {0, 0}, drops_in[2] = {0, 0};
  for (std::size_t t = n; t-- > 0;) {
    const bool x = dropped[t] != 0;
    for (int i = 0; i < 2; ++i) {
      const double g = alpha[t][i] * beta[i];
      occupancy[i] += g;
      if (x) drops_in[i] += g;
    }
    if (t == 0) break;
    const double* ex = e[x];
    const double inv = 1.0 / scale[t];
    const std::array<double, 2> eb = {ex[0] * beta[0] * inv, ex[1] * beta[1] * inv};  // e_j(x_t) beta_t(j) / c_t
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) trans[i][j] += alpha[t - 1][i] * P[i][j] * eb[j];
    beta = {P[0][0] * eb[0] + P[0][1] * eb[1], P[1][0] * eb[0] + P[1][1] * eb[1]};
  }
  Chain next = c;
  const double from_good = trans[0][0] + trans[0][1], from_bad = trans[1][0] + trans[1][1];
  if (from_good > 0.0) next.p = trans[0][1] / from_good;
  if (from_bad > 0.0) next.r = trans[1][0] / from_bad;
  if (loss_good_free && occupancy[0] > 0.0) next.loss_good = drops_in[0] / occupancy[0];
  if (occupancy[1] > 0.0) next.loss_bad = drops_in[1] / occupancy[1];
  return next;
}

// Good is the state that drops less: swap the labels when EM found them the other way.
Chain ordered(Chain c) {
  if (c.loss_good > c.loss_bad) c = {c.r, c.p, c.loss_bad, c.loss_good};
  return c;
}

void run_em(std::span<const std::uint8_t> dropped, bool loss_good_free, EmState& s, int iterations, double tolerance,
            std::vector<std::array<double, 2>>& alpha, std::vector<double>& scale) {
  for (int i = 0; i < iterations && !s.converged; ++i) {
    double log_l = 0.0;
    const Chain next = baum_welch_step(dropped, s.chain, loss_good_free, alpha, scale, log_l);
    const double gain = log_l - s.last_step;  // of this step's chain over the last step's
    s.chain = next;
    s.last_step = log_l;
    ++s.iterations;
    if (std::isfinite(log_l) && std::abs(gain) <= tolerance * std::max(1.0, std::abs(log_l))) s.converged = true;
  }
  s.log_likelihood = forward(dropped, s.chain, nullptr, nullptr);
}

Chain random_start(Rng& rng, bool loss_good_free) {
  Chain c;
  c.p = 0.005 + 0.3 * rng.uniform();
  c.r = 0.05 + 0.85 * rng.uniform();
  c.loss_bad = 0.5 + 0.49 * rng.uniform();
  c.loss_good = loss_good_free ? 0.3 * c.loss_bad * rng.uniform() : 0.0;
  return c;
}

EmState fit_hidden_chain(std::span<const std::uint8_t> dropped, const Chain& simple, bool loss_good_free,
                         const LossFitOptions& o) {
  std::vector<std::array<double, 2>> alpha(dropped.size());
  std::vector<double> scale(dropped.size());
  std::vector<EmState> starts;
  for (int i = 0; i < std::max(1, o.starts); ++i) {
    EmState s;
    if (i == 0) {
      // From the simple Gilbert fit, off the boundary (EM cannot leave loss_bad = 1).
      s.chain = {simple.p, simple.r, loss_good_free ? 0.02 : 0.0, 0.95};
    } else {
      Rng rng(derive_seed(o.seed, "loss-fit", static_cast<std::uint64_t>(i)));
      s.chain = random_start(rng, loss_good_free);
    }
    run_em(dropped, loss_good_free, s, o.start_iterations, o.tolerance, alpha, scale);
    starts.push_back(s);
  }
  auto best = *std::max_element(starts.begin(), starts.end(), [](const EmState& a, const EmState& b) {
    return a.log_likelihood < b.log_likelihood;
  });
  run_em(dropped, loss_good_free, best, o.max_iterations - best.iterations, o.tolerance, alpha, scale);
  best.chain = ordered(best.chain);
  // The nested fits are points of this family too, on its boundary, where EM only creeps
  // (it cannot reach loss_bad = 1): the family's fit is never worse than theirs.
  const double loss = static_cast<double>(std::count(dropped.begin(), dropped.end(), 1)) / dropped.size();
  std::vector<Chain> nested = {simple};
  if (loss_good_free) nested.push_back({simple.p, simple.r, loss, loss});
  for (const Chain& c : nested) {
    const double log_l = forward(dropped, c, nullptr, nullptr);
    if (log_l > best.log_likelihood) {
      best.chain = c;
      best.log_likelihood = log_l;
      best.converged = true;
    }
  }
  return best;
}

// ---- standard errors ----------------------------------------------------------------

// Covariance of the logits of `names` (free, off their boundaries) from the observed
// information: the negated Hessian of log L by central differences, inverted. nullopt when
// it is not positive definite.
std::optional<Eigen::MatrixXd> logit_covariance(std::span<const std::uint8_t> dropped, const Chain& c,
                                                const std::vector<std::string>& names) {
  const int k = static_cast<int>(names.size());
  if (k == 0) return Eigen::MatrixXd(0, 0);
  Eigen::VectorXd theta(k);
  for (int i = 0; i < k; ++i) theta[i] = logit(get(c, names[i]));
  const auto log_l = [&](const Eigen::VectorXd& t) {
    Chain moved = c;
    for (int i = 0; i < k; ++i) set(moved, names[i], logistic(t[i]));
    return forward(dropped, moved, nullptr, nullptr);
  };
  constexpr double h = 1e-3;
  const double f0 = log_l(theta);
  Eigen::MatrixXd H(k, k);
  for (int i = 0; i < k; ++i) {
    for (int j = i; j < k; ++j) {
      Eigen::VectorXd t = theta;
      if (i == j) {
        t[i] += h;
        const double up = log_l(t);
        t[i] -= 2 * h;
        H(i, i) = (up - 2 * f0 + log_l(t)) / (h * h);
        continue;
      }
      double sum = 0.0;
      for (const auto& [si, sj] : {std::pair{1, 1}, {1, -1}, {-1, 1}, {-1, -1}}) {
        t = theta;
        t[i] += si * h;
        t[j] += sj * h;
        sum += si * sj * log_l(t);
      }
      H(i, j) = H(j, i) = sum / (4 * h * h);
    }
  }
  const Eigen::MatrixXd information = -H;
  Eigen::LLT<Eigen::MatrixXd> llt(information);
  if (llt.info() != Eigen::Success || !information.allFinite()) return std::nullopt;
  return llt.solve(Eigen::MatrixXd::Identity(k, k));
}

// Standard error and 95% interval of g(theta) by the delta method, with the interval in
// the scale `to` (logit for a probability, log(x − 1) for a mean burst) mapped back.
void delta_interval(FittedValue& out, const std::function<double(const Eigen::VectorXd&)>& g,
                    const Eigen::VectorXd& theta, const Eigen::MatrixXd& cov, const std::function<double(double)>& to,
                    const std::function<double(double)>& back) {
  const int k = static_cast<int>(theta.size());
  constexpr double h = 1e-5;
  Eigen::VectorXd grad(k), grad_scaled(k);
  for (int i = 0; i < k; ++i) {
    Eigen::VectorXd up = theta, down = theta;
    up[i] += h;
    down[i] -= h;
    const double gu = g(up), gd = g(down);
    grad[i] = (gu - gd) / (2 * h);
    grad_scaled[i] = (to(gu) - to(gd)) / (2 * h);
  }
  const double var = grad.dot(cov * grad), var_scaled = grad_scaled.dot(cov * grad_scaled);
  if (!(var >= 0.0) || !std::isfinite(var)) return;
  out.stderr_value = std::sqrt(var);
  const double centre = to(out.value);
  if (std::isfinite(centre) && var_scaled >= 0.0 && std::isfinite(var_scaled)) {
    const double half = kZ95 * std::sqrt(var_scaled);
    out.ci_low = back(centre - half);
    out.ci_high = back(centre + half);
  } else {  // at the edge of the scale (a mean burst of 1): the plain Wald interval
    out.ci_low = out.value - kZ95 * *out.stderr_value;
    out.ci_high = out.value + kZ95 * *out.stderr_value;
  }
}

}  // namespace

namespace {

// ---- goodness of fit ------------------------------------------------------------------

RunLengthTest run_length_test(std::span<const std::uint8_t> delivered, const LinkModel& link, bool dropped,
                              int fitted_parameters) {
  RunLengthTest test;
  const auto lengths = run_lengths(delivered, dropped);
  test.runs = lengths.size();
  if (lengths.empty()) return test;
  const std::size_t longest = *std::max_element(lengths.begin(), lengths.end());
  // The model's probabilities far enough to hold all but 1e-9 of the mass, or the longest run.
  constexpr int kMaxLength = 1'000'000;
  const auto pmf = run_length_distribution(link, dropped, static_cast<int>(std::min<std::size_t>(
                                                              std::max<std::size_t>(longest, 64) * 4, kMaxLength)));
  std::vector<double> observed(pmf.size() + 2, 0.0);
  for (auto L : lengths) observed[std::min<std::size_t>(L, pmf.size() + 1)] += 1.0;
  const double n = static_cast<double>(lengths.size());
  double tail = 1.0;  // P(length >= from)
  int from = 1;
  double exp_acc = 0.0, obs_acc = 0.0;
  for (int L = 1; L <= static_cast<int>(pmf.size()); ++L) {
    exp_acc += n * pmf[L - 1];
    obs_acc += observed[L];
    const double rest = tail * n - exp_acc;  // expected runs longer than L
    if (exp_acc >= kMinExpected && rest >= kMinExpected) {
      test.bins.push_back({from, L, obs_acc, exp_acc});
      tail -= exp_acc / n;
      from = L + 1;
      exp_acc = obs_acc = 0.0;
    } else if (rest < kMinExpected) {
      break;
    }
  }
  // The open last bin: everything from `from` on.
  double obs_rest = 0.0;
  for (std::size_t L = static_cast<std::size_t>(from); L < observed.size(); ++L) obs_rest += observed[L];
  test.bins.push_back({from, -1, obs_rest, std::max(0.0, tail) * n});
  if (test.bins.size() < 2) return test;
  double chi = 0.0;
  for (const auto& b : test.bins) {
    if (b.expected > 0.0) chi += (b.observed - b.expected) * (b.observed - b.expected) / b.expected;
    else if (b.observed > 0.0) chi = kInf;
  }
  test.chi_square = chi;
  test.degrees_of_freedom = std::max(1, static_cast<int>(test.bins.size()) - 1 - fitted_parameters);
  test.p_value = std::isfinite(chi) ? chi_square_upper_tail(chi, test.degrees_of_freedom) : 0.0;
  return test;
}

// ---- one family's fit -------------------------------------------------------------------

bool at_boundary(double v) { return v < kBoundary || v > 1.0 - kBoundary; }

// Everything of a fit but the estimate itself: values, errors, likelihood, AIC, tests.
LossFit finish_fit(std::span<const std::uint8_t> delivered, std::span<const std::uint8_t> dropped, LossFamily f,
                   const Chain& c) {
  LossFit fit;
  fit.family = f;
  fit.link = link_of(f, c);
  validate_link_model(fit.link);
  std::vector<std::string> free;  // fitted and off the boundary: these get intervals
  const std::vector<std::string> fitted = free_names(f);
  const std::vector<std::string> keys =
      f == LossFamily::bernoulli ? std::vector<std::string>{"loss"}
                                 : std::vector<std::string>{"p", "r", "loss_good", "loss_bad"};
  for (const auto& name : fitted) {
    if (at_boundary(get(c, name))) fit.notes.push_back(name + " is at its boundary: no interval for it");
    else free.push_back(name);
  }
  const auto cov = logit_covariance(dropped, c, free);
  if (!cov) fit.notes.push_back("the observed information is not positive definite: no standard errors");
  Eigen::VectorXd theta(static_cast<int>(free.size()));
  for (std::size_t i = 0; i < free.size(); ++i) theta[static_cast<int>(i)] = logit(get(c, free[i]));
  const auto chain_at = [&](const Eigen::VectorXd& t) {
    Chain moved = c;
    for (std::size_t i = 0; i < free.size(); ++i) set(moved, free[i], logistic(t[static_cast<int>(i)]));
    return link_of(f, moved);
  };
  for (const auto& name : keys) {
    FittedValue v{name, get(c, name), std::find(fitted.begin(), fitted.end(), name) != fitted.end(), {}, {}, {}};
    const auto it = std::find(free.begin(), free.end(), name);
    if (cov && it != free.end()) {
      const int i = static_cast<int>(it - free.begin());
      const auto g = [&, i](const Eigen::VectorXd& t) { return logistic(t[i]); };
      delta_interval(v, g, theta, *cov, logit, logistic);
    }
    fit.parameters.push_back(v);
  }
  fit.loss = {"loss", stationary_loss(fit.link), true, {}, {}, {}};
  fit.mean_burst = {"mean_burst", mean_burst_length(fit.link), true, {}, {}, {}};
  if (cov && !free.empty()) {
    delta_interval(fit.loss, [&](const Eigen::VectorXd& t) { return stationary_loss(chain_at(t)); }, theta, *cov,
                   logit, logistic);
    delta_interval(fit.mean_burst, [&](const Eigen::VectorXd& t) { return mean_burst_length(chain_at(t)); }, theta,
                   *cov, [](double b) { return std::log(b - 1.0); }, [](double u) { return 1.0 + std::exp(u); });
  }
  fit.log_likelihood = forward(dropped, c, nullptr, nullptr);
  fit.aic = 2.0 * free_parameters(f) - 2.0 * fit.log_likelihood;
  fit.bursts = run_length_test(delivered, fit.link, true, free_parameters(f));
  fit.gaps = run_length_test(delivered, fit.link, false, free_parameters(f));
  return fit;
}

struct Counts {
  std::size_t n = 0, dropped = 0;
  double trans[2][2] = {{0, 0}, {0, 0}};  // [from][to], 1 = dropped
};

Counts count(std::span<const std::uint8_t> dropped) {
  Counts k;
  k.n = dropped.size();
  for (std::size_t t = 0; t < dropped.size(); ++t) {
    k.dropped += dropped[t];
    if (t > 0) k.trans[dropped[t - 1]][dropped[t]] += 1.0;
  }
  return k;
}

// The simple Gilbert chain seen directly: p and r are the transition frequencies (the
// maximum likelihood given the first sample; their standard errors sqrt(p(1 − p)/n_from)
// come out of the same observed information below).
Chain simple_gilbert_estimate(const Counts& k) {
  const double from_good = k.trans[0][0] + k.trans[0][1], from_bad = k.trans[1][0] + k.trans[1][1];
  return {k.trans[0][1] / from_good, k.trans[1][0] / from_bad, 0.0, 1.0};
}

std::string fixed(double v, int digits = 1) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

// The rule of `auto`: the least AIC, except that a simpler family within kParsimony of it
// is preferred (Burnham & Anderson 2002, their rule of thumb: a model within 2 of the best has
// substantial support). Without it, one spurious extra parameter wins for an i.i.d. trace
// whenever its log-likelihood gain exceeds 1: P(χ²₁ > 2) = 16% of such traces would be
// called bursty; with it, P(χ²₁ > 4) = 4.6% for the simple Gilbert alternative.
constexpr double kParsimony = 2.0;

std::size_t choose_by_aic(const std::vector<LossFit>& candidates) {
  double least = kInf;
  for (const auto& c : candidates) least = std::min(least, c.aic);
  for (std::size_t i = 0; i < candidates.size(); ++i)  // in LossFamily order: simplest first
    if (candidates[i].aic <= least + kParsimony) return i;
  return 0;
}

std::string why_chosen(const TraceFit& r) {
  const LossFit& chosen = r.fit();
  const LossFit* least = &chosen;
  for (const auto& c : r.candidates)
    if (c.aic < least->aic) least = &c;
  std::string why = std::string(to_string(least->family)) + " has the least AIC (" + fixed(least->aic) + ")";
  std::string others;
  for (const auto& c : r.candidates) {
    if (&c == least) continue;
    others += (others.empty() ? "" : ", ") + std::string(to_string(c.family)) + " +" + fixed(c.aic - least->aic);
  }
  if (!others.empty()) why += "; " + others;
  if (least != &chosen)
    why += ". " + std::string(to_string(chosen.family)) + " is within " + fixed(kParsimony, 0) +
           " of it with fewer parameters, so it is taken";
  const LossFit& bernoulli = r.candidates.front();
  if (chosen.family == LossFamily::bernoulli) {
    why += ". No chain with memory lowers AIC by more than " + fixed(kParsimony, 0) +
           ": the drops look independent (not bursty)";
  } else {
    why += ". Bursty: memory lowers AIC by " + fixed(bernoulli.aic - chosen.aic) + " against bernoulli";
  }
  return why;
}

}  // namespace

const char* to_string(LossFamily family) {
  switch (family) {
    case LossFamily::bernoulli: return "bernoulli";
    case LossFamily::simple_gilbert: return "simple_gilbert";
    case LossFamily::gilbert: return "gilbert";
    case LossFamily::gilbert_elliott: return "gilbert_elliott";
  }
  return "?";
}

std::optional<LossFamily> parse_loss_family(const std::string& name) {
  for (auto f : {LossFamily::bernoulli, LossFamily::simple_gilbert, LossFamily::gilbert, LossFamily::gilbert_elliott})
    if (name == to_string(f)) return f;
  return std::nullopt;
}

int free_parameters(LossFamily family) { return static_cast<int>(free_names(family).size()); }

TraceFit fit_loss_model(std::span<const std::uint8_t> delivered, const LossFitOptions& options) {
  if (delivered.empty()) throw std::invalid_argument("cannot fit a loss model to an empty trace");
  std::vector<std::uint8_t> dropped(delivered.size());
  for (std::size_t t = 0; t < delivered.size(); ++t) dropped[t] = delivered[t] ? 0 : 1;
  const Counts k = count(dropped);
  TraceFit r;
  r.samples = k.n;
  r.dropped = k.dropped;
  const bool chain_fits = k.trans[0][0] + k.trans[0][1] > 0 && k.trans[1][0] + k.trans[1][1] > 0;
  const auto wanted = [&](LossFamily f) { return !options.family || *options.family == f; };
  const double loss = static_cast<double>(k.dropped) / static_cast<double>(k.n);
  if (wanted(LossFamily::bernoulli)) r.candidates.push_back(finish_fit(delivered, dropped, LossFamily::bernoulli,
                                                                       {0.0, 1.0, loss, loss}));
  if (!chain_fits) {
    r.notes.push_back(k.dropped == 0 ? "the trace has no drops: only bernoulli (loss 0) can be fitted"
                      : k.dropped == k.n ? "the trace has no deliveries: only bernoulli (loss 1) can be fitted"
                                         : "a chain needs a sample followed by another after both a delivery and a "
                                           "drop: only bernoulli can be fitted");
    if (r.candidates.empty())
      throw std::invalid_argument(std::string(to_string(*options.family)) + " cannot be fitted: " + r.notes.back());
    r.why = options.family ? "asked for" : r.notes.back();
    return r;
  }
  const Chain simple = simple_gilbert_estimate(k);
  if (wanted(LossFamily::simple_gilbert))
    r.candidates.push_back(finish_fit(delivered, dropped, LossFamily::simple_gilbert, simple));
  for (auto f : {LossFamily::gilbert, LossFamily::gilbert_elliott}) {
    if (!wanted(f)) continue;
    const EmState em = fit_hidden_chain(dropped, simple, f == LossFamily::gilbert_elliott, options);
    LossFit fit = finish_fit(delivered, dropped, f, em.chain);
    fit.iterations = em.iterations;
    fit.starts = std::max(1, options.starts);
    fit.converged = em.converged;
    if (!em.converged)
      fit.notes.push_back("EM stopped after " + std::to_string(em.iterations) + " iterations before its tolerance");
    r.candidates.push_back(std::move(fit));
  }
  if (options.family) {
    r.why = "asked for";
    return r;
  }
  r.chosen = choose_by_aic(r.candidates);
  r.why = why_chosen(r);
  return r;
}

double trace_log_likelihood(std::span<const std::uint8_t> delivered, const LinkModel& link) {
  std::vector<std::uint8_t> dropped(delivered.size());
  for (std::size_t t = 0; t < delivered.size(); ++t) dropped[t] = delivered[t] ? 0 : 1;
  return forward(dropped, chain_of(link), nullptr, nullptr);
}

// A run of drops starts where a delivery is followed by a drop: with the row vector
// s = π D₀ P D₁ (D₁ = diag(loss), D₀ = I − D₁), P(length = L) ∝ s (P D₁)^{L−1} P D₀ 1 and
// the normaliser is s 1. Runs of deliveries: D₀ and D₁ swapped.
std::vector<double> run_length_distribution(const LinkModel& link, bool dropped, int max_length) {
  const Chain c = chain_of(link);
  const auto pi = stationary(c);
  const double P[2][2] = {{1.0 - c.p, c.p}, {c.r, 1.0 - c.r}};
  const double in_run[2] = {emission(c, 0, dropped), emission(c, 1, dropped)};
  const double out_run[2] = {1.0 - in_run[0], 1.0 - in_run[1]};
  std::array<double, 2> s{};  // P(run starts now, state now)
  for (int j = 0; j < 2; ++j) s[j] = (pi[0] * out_run[0] * P[0][j] + pi[1] * out_run[1] * P[1][j]) * in_run[j];
  const double starts = s[0] + s[1];
  std::vector<double> pmf;
  if (!(starts > 0.0)) return pmf;
  s = {s[0] / starts, s[1] / starts};
  for (int L = 1; L <= max_length; ++L) {
    // P(run ends after L | run of length >= L, state)
    const double end0 = P[0][0] * out_run[0] + P[0][1] * out_run[1];
    const double end1 = P[1][0] * out_run[0] + P[1][1] * out_run[1];
    pmf.push_back(s[0] * end0 + s[1] * end1);
    s = {(s[0] * P[0][0] + s[1] * P[1][0]) * in_run[0], (s[0] * P[0][1] + s[1] * P[1][1]) * in_run[1]};
    if (s[0] + s[1] < 1e-12) break;
  }
  return pmf;
}

std::vector<std::size_t> run_lengths(std::span<const std::uint8_t> delivered, bool dropped) {
  std::vector<std::size_t> out;
  const std::uint8_t in_run = dropped ? 0 : 1;
  std::size_t t = 0;
  while (t < delivered.size() && delivered[t] == in_run) ++t;  // a run at the start is censored
  while (t < delivered.size()) {
    while (t < delivered.size() && delivered[t] != in_run) ++t;
    const std::size_t start = t;
    while (t < delivered.size() && delivered[t] == in_run) ++t;
    if (t < delivered.size()) out.push_back(t - start);  // else it runs into the end: censored
  }
  return out;
}

std::optional<DelaySummary> summarize_delays(std::span<const double> delay_ms) {
  std::vector<double> d;
  for (double v : delay_ms)
    if (std::isfinite(v)) d.push_back(v);
  if (d.empty()) return std::nullopt;
  std::sort(d.begin(), d.end());
  DelaySummary s;
  s.samples = d.size();
  s.mean_ms = std::accumulate(d.begin(), d.end(), 0.0) / static_cast<double>(d.size());
  double ss = 0.0;
  for (double v : d) ss += (v - s.mean_ms) * (v - s.mean_ms);
  s.jitter_ms = d.size() > 1 ? std::sqrt(ss / static_cast<double>(d.size() - 1)) : 0.0;
  for (double q : {0.0, 0.05, 0.25, 0.5, 0.75, 0.95, 0.99, 1.0}) {
    // Linear interpolation between order statistics (Hyndman-Fan type 7, NumPy's default).
    const double h = q * static_cast<double>(d.size() - 1);
    const auto lo = static_cast<std::size_t>(std::floor(h));
    const std::size_t hi = std::min(lo + 1, d.size() - 1);
    s.quantiles.emplace_back(q, d[lo] + (h - static_cast<double>(lo)) * (d[hi] - d[lo]));
  }
  return s;
}

double chi_square_upper_tail(double x, int degrees_of_freedom) {
  if (!(x > 0.0)) return 1.0;
  if (!std::isfinite(x)) return 0.0;
  const boost::math::chi_squared_distribution<double> dist(degrees_of_freedom);
  return boost::math::cdf(boost::math::complement(dist, x));
}

}  // namespace netkf::fit
