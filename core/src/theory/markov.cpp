// Markov-loss stability criterion by the transition-matrix method (see theory/markov.hpp).
#include "netkf/theory/markov.hpp"

#include "netkf/links/link.hpp"
#include "netkf/links/link_statistics.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>
#include <complex>
#include <algorithm>
#include <numbers>
#include <optional>
#include <utility>
#include <sstream>
#include <variant>

namespace netkf::theory {
namespace {

using CMatrix = Eigen::MatrixXcd;
using Complex = std::complex<double>;

// Orthonormal basis (rows) of the row space of `rows`, with a rank tolerance relative to the
// largest singular value (rows whose block part is numerically zero reveal nothing).
CMatrix row_space_basis(const CMatrix& rows) {
  if (rows.rows() == 0) return CMatrix(0, rows.cols());
  Eigen::JacobiSVD<CMatrix> svd(rows, Eigen::ComputeFullV);
  const auto& s = svd.singularValues();
  const double tol = 1e-9 * std::max(1.0, s.size() > 0 ? s(0) : 0.0);
  Eigen::Index r = 0;
  while (r < s.size() && s(r) > tol) ++r;
  return svd.matrixV().leftCols(r).adjoint();
}

// One link's Markov chain: transition matrix and per-state arrival probability.
struct LinkChain {
  Matrix T;
  Vector arrival;
};

LinkChain link_chain(const LinkModel& model) {
  LinkChain c;
  std::visit(overloaded{[&](const BernoulliLink& b) {
                          c.T = Matrix::Ones(1, 1);
                          c.arrival = Vector::Constant(1, 1.0 - b.loss);
                        },
                        [&](const GilbertElliottLink& g) {
                          c.T.resize(2, 2);
                          c.T << 1.0 - g.p, g.p, g.r, 1.0 - g.r;  // row = from (good, bad)
                          c.arrival.resize(2);
                          c.arrival << 1.0 - g.loss_good, 1.0 - g.loss_bad;
                        }},
             model);
  return c;
}

double nonnegative_spectral_radius(const Matrix& M) {
  if (M.rows() == 0) return 0.0;
  if (M.rows() <= 600) return Eigen::EigenSolver<Matrix>(M, false).eigenvalues().cwiseAbs().maxCoeff();
  // Perron-Frobenius: ρ(M) is an eigenvalue of the nonnegative M; power iteration on I + M.
  Vector x = Vector::Ones(M.rows());
  double rho = 0.0;
  for (int it = 0; it < 5000; ++it) {
    Vector y = x + M * x;
    const double norm = y.sum();
    rho = norm / x.sum() - 1.0;
    x = y / norm;
  }
  return rho;
}

struct BlockChainResult {
  bool ok = false;
  double rate = 0.0;
  int states = 0;
};

// ρ of the rank-deficient chain for one eigen-block (see header).
BlockChainResult block_deficiency_rate(const std::vector<CMatrix>& sensor_rows, const CMatrix& U_inv,
                                       const std::vector<LinkChain>& links, int max_states) {
  const Eigen::Index n_i = U_inv.rows();
  const std::size_t d = links.size();
  std::vector<int> stride(d, 1);
  int joint = 1;
  for (std::size_t j = 0; j < d; ++j) {
    stride[j] = joint;
    joint *= static_cast<int>(links[j].T.rows());
  }
  auto link_state = [&](int s, std::size_t j) { return (s / stride[j]) % static_cast<int>(links[j].T.rows()); };

  struct State {
    CMatrix basis;
    CMatrix projector;
    int link;
  };
  std::vector<State> states;
  auto find_or_add = [&](const CMatrix& basis, int link) -> int {
    const CMatrix proj = basis.rows() == 0 ? CMatrix::Zero(n_i, n_i) : CMatrix(basis.adjoint() * basis);
    for (std::size_t k = 0; k < states.size(); ++k)
      if (states[k].link == link && states[k].basis.rows() == basis.rows() &&
          (states[k].projector - proj).norm() < 1e-7)
        return static_cast<int>(k);
    states.push_back({basis, proj, link});
    return static_cast<int>(states.size()) - 1;
  };
  for (int s = 0; s < joint; ++s) find_or_add(CMatrix(0, n_i), s);

  std::vector<std::tuple<int, int, double>> transitions;  // (to, from, probability)
  for (std::size_t k = 0; k < states.size(); ++k) {
    if (static_cast<int>(states.size()) > max_states) return {};
    const CMatrix rotated = states[k].basis * U_inv;
    const int from_link = states[k].link;
    for (int to_link = 0; to_link < joint; ++to_link) {
      double p_link = 1.0;
      for (std::size_t j = 0; j < d && p_link > 0.0; ++j)
        p_link *= links[j].T(link_state(from_link, j), link_state(to_link, j));
      if (p_link <= 0.0) continue;
      for (std::uint32_t mask = 0; mask < (1u << d); ++mask) {
        double p = p_link;
        Eigen::Index extra = 0;
        for (std::size_t j = 0; j < d; ++j) {
          const double a = links[j].arrival(link_state(to_link, j));
          const bool arrived = (mask >> j) & 1u;
          p *= arrived ? a : 1.0 - a;
          if (arrived) extra += sensor_rows[j].rows();
        }
        if (p <= 0.0) continue;
        CMatrix stacked(rotated.rows() + extra, n_i);
        stacked.topRows(rotated.rows()) = rotated;
        Eigen::Index row = rotated.rows();
        for (std::size_t j = 0; j < d; ++j)
          if ((mask >> j) & 1u) {
            stacked.middleRows(row, sensor_rows[j].rows()) = sensor_rows[j];
            row += sensor_rows[j].rows();
          }
        const CMatrix basis = row_space_basis(stacked);
        if (basis.rows() >= n_i) continue;  // full rank: left R_N for good
        const int to = find_or_add(basis, to_link);
        transitions.emplace_back(to, static_cast<int>(k), p);
      }
    }
  }
  Matrix M = Matrix::Zero(static_cast<Eigen::Index>(states.size()), static_cast<Eigen::Index>(states.size()));
  for (const auto& [to, from, p] : transitions) M(to, from) += p;
  return {true, nonnegative_spectral_radius(M), static_cast<int>(states.size())};
}

// ρ(M_j) of one link's lost-chain M_j(to, from) = T(from, to) · loss(to): the growth rate of
// P(lost N times in a row). Bernoulli: its loss.
double lost_chain_rate(const LinkChain& c) {
  Matrix M(c.T.rows(), c.T.rows());
  for (Eigen::Index to = 0; to < M.rows(); ++to)
    for (Eigen::Index from = 0; from < M.cols(); ++from) M(to, from) = c.T(from, to) * (1.0 - c.arrival(to));
  return nonnegative_spectral_radius(M);
}

// Binomial pmf C(m, k) p^k (1 − p)^{m−k}.
double binomial(int m, int k, double p) {
  if (k < 0 || k > m) return 0.0;
  return std::exp(std::lgamma(m + 1.0) - std::lgamma(k + 1.0) - std::lgamma(m - k + 1.0)) *
         (k == 0 ? 1.0 : std::pow(p, k)) * (k == m ? 1.0 : std::pow(1.0 - p, m - k));
}

// One observation class as a single link: it arrives when any member does. Bernoulli members
// merge (loss Π loss_j); identical Gilbert-Elliott members are counted in the bad state (the
// count is an exactly lumpable chain); the class chain is the product over the GE groups.
// nullopt when that product has more than `max_states` states.
std::optional<LinkChain> class_chain(const std::vector<const LinkModel*>& members, int max_states) {
  double bernoulli_loss = 1.0;
  std::vector<std::pair<GilbertElliottLink, int>> ge;  // (parameters, members)
  const auto add_chain = [&](const GilbertElliottLink& g) {
    auto it = std::find_if(ge.begin(), ge.end(), [&](const auto& e) { return e.first == g; });
    if (it == ge.end()) ge.emplace_back(g, 1);
    else ++it->second;
  };
  for (const LinkModel* m : members)
    std::visit(overloaded{[&](const BernoulliLink& b) { bernoulli_loss *= b.loss; }, add_chain}, *m);
  int size = 1;
  for (const auto& [g, m] : ge) {
    size *= m + 1;
    if (size > max_states) return std::nullopt;
  }
  LinkChain c;
  c.T = Matrix::Ones(size, size);
  c.arrival = Vector::Constant(size, 1.0);
  auto count = [&](int state, std::size_t k) {
    for (std::size_t j = 0; j < k; ++j) state /= ge[j].second + 1;
    return state % (ge[k].second + 1);
  };
  for (int from = 0; from < size; ++from) {
    double lost = bernoulli_loss;
    for (std::size_t k = 0; k < ge.size(); ++k) {
      const int bad = count(from, k), m = ge[k].second;
      lost *= std::pow(ge[k].first.loss_bad, bad) * std::pow(ge[k].first.loss_good, m - bad);
    }
    c.arrival(from) = 1.0 - lost;
    for (int to = 0; to < size; ++to)
      for (std::size_t k = 0; k < ge.size(); ++k) {
        // bad → bad' : `stay` of the bad links stay bad (prob 1 − r), bad' − stay good links turn bad (p).
        const int b = count(from, k), b2 = count(to, k), m = ge[k].second;
        double p = 0.0;
        for (int stay = 0; stay <= b; ++stay)
          p += binomial(b, stay, 1.0 - ge[k].first.r) * binomial(m - b, b2 - stay, ge[k].first.p);
        c.T(from, to) *= p;
      }
  }
  return c;
}

struct GroupedBlockResult {
  bool ok = false;        // false: the chain passed its cap (aperiodic block)
  bool exact = true;
  double rate = 0.0;      // exact rate
  double lower = 0.0;     // bounds on the rate when !exact
  double upper = 1.0;
  int states = 0;
  int observing = 0;
  int classes = 0;
  std::string method;
};

// The block's rate by observation classes (theory/markov.hpp).
GroupedBlockResult grouped_block_rate(const std::vector<CMatrix>& rows, const CMatrix& U_inv,
                                      const std::vector<LinkChain>& links, std::span<const SensorSpec> sensors,
                                      const MarkovOptions& options) {
  const Eigen::Index n_i = U_inv.rows();
  GroupedBlockResult out;
  struct Class {
    CMatrix basis, projector;
    std::vector<const LinkModel*> members;
    double all_lost = 1.0;  // stationary P(every member lost), to rank classes by reliability
  };
  std::vector<Class> classes;
  double product_rate = 1.0;
  bool all_full = true;
  for (std::size_t j = 0; j < rows.size(); ++j) {
    const CMatrix basis = row_space_basis(rows[j]);
    if (basis.rows() == 0) continue;  // sensor j never sees block i
    ++out.observing;
    product_rate *= lost_chain_rate(links[j]);
    all_full = all_full && basis.rows() >= n_i;
    const CMatrix proj = basis.adjoint() * basis;
    auto it = std::find_if(classes.begin(), classes.end(),
                           [&](const Class& c) { return (c.projector - proj).norm() < 1e-7; });
    if (it == classes.end()) {
      classes.push_back({basis, proj, {}, 1.0});
      it = classes.end() - 1;
    }
    it->members.push_back(&sensors[j].link.loss);
    it->all_lost *= stationary_loss(sensors[j].link.loss);
  }
  out.classes = static_cast<int>(classes.size());
  out.ok = true;
  if (classes.empty() || (classes.size() == 1 && all_full)) {
    // No sensor sees the block (rate 1), or any arrival reveals it: R_N = "all lost N times".
    out.rate = product_rate;
    out.method = "product";
    return out;
  }
  // Exact chain over the classes if they fit, else over the most reliable ones (an upper bound).
  std::sort(classes.begin(), classes.end(), [](const Class& a, const Class& b) { return a.all_lost < b.all_lost; });
  std::vector<CMatrix> class_rows;
  std::vector<LinkChain> class_links;
  int joint = 1;
  for (const auto& c : classes) {
    if (static_cast<int>(class_rows.size()) >= options.max_classes) break;
    auto chain = class_chain(c.members, options.max_class_link_states);
    if (!chain || joint * chain->T.rows() > options.max_class_link_states) break;
    joint *= static_cast<int>(chain->T.rows());
    class_rows.push_back(c.basis);
    class_links.push_back(std::move(*chain));
  }
  out.exact = class_rows.size() == classes.size();
  out.method = out.exact ? "classes" : "bounds";
  if (class_rows.empty()) {
    out.lower = product_rate;
    out.upper = 1.0;
    return out;
  }
  const BlockChainResult r = block_deficiency_rate(class_rows, U_inv, class_links, options.max_chain_states);
  out.states = r.states;
  if (out.exact) {
    out.ok = r.ok;
    out.rate = r.rate;
    return out;
  }
  out.lower = product_rate;
  out.upper = r.ok ? r.rate : 1.0;
  return out;
}

// The eigenvector matrix's condition number: Assumption 3 (diagonalisable A) needs it small.
double eigenvector_condition(const CMatrix& V) {
  Eigen::JacobiSVD<CMatrix> vsvd(V);
  return vsvd.singularValues()(0) / std::max(vsvd.singularValues()(V.cols() - 1), 1e-300);
}

// Eigen-blocks: eigenvalues of equal modulus (Assumption 3's A_i = α_i diag(e^{iθ})), each the
// indices of its eigenvalues, the first one's modulus the block's.
std::vector<std::vector<Eigen::Index>> eigen_blocks(const Eigen::VectorXcd& lambda) {
  const Eigen::Index n = lambda.size();
  std::vector<std::vector<Eigen::Index>> blocks;
  std::vector<bool> used(static_cast<std::size_t>(n), false);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (used[static_cast<std::size_t>(i)]) continue;
    const double alpha = std::abs(lambda(i));
    std::vector<Eigen::Index> members;
    for (Eigen::Index j = i; j < n; ++j)
      if (!used[static_cast<std::size_t>(j)] && std::abs(std::abs(lambda(j)) - alpha) <= 1e-9 * std::max(1.0, alpha)) {
        members.push_back(j);
        used[static_cast<std::size_t>(j)] = true;
      }
    blocks.push_back(std::move(members));
  }
  return blocks;
}

// The block's deficiency rate: by observation classes, or by the reference enumeration over
// the sensors' arrival masks (not for more than 16 sensors: 2^d masks per state).
GroupedBlockResult block_rate(const CMatrix& V, const Eigen::VectorXcd& lambda, const std::vector<Eigen::Index>& members,
                              double alpha, const std::vector<LinkChain>& links, std::span<const SensorSpec> sensors,
                              const MarkovOptions& options) {
  const Eigen::Index ni = static_cast<Eigen::Index>(members.size());
  CMatrix U_inv = CMatrix::Zero(ni, ni);
  CMatrix Vi(V.rows(), ni);
  for (Eigen::Index k = 0; k < ni; ++k) {
    U_inv(k, k) = alpha / lambda(members[static_cast<std::size_t>(k)]);
    Vi.col(k) = V.col(members[static_cast<std::size_t>(k)]);
  }
  std::vector<CMatrix> rows;
  for (const auto& s : sensors) rows.push_back(s.C.cast<Complex>() * Vi);
  GroupedBlockResult r;
  if (options.group_sensors) {
    r = grouped_block_rate(rows, U_inv, links, sensors, options);
  } else if (sensors.size() > 16) {
    r.ok = false;  // the reference enumeration: 2^d masks per state
  } else {
    const BlockChainResult e = block_deficiency_rate(rows, U_inv, links, options.max_chain_states);
    r.ok = e.ok;
    r.rate = e.rate;
    r.states = e.states;
    r.method = "enumerated";
  }
  return r;
}

// What the blocks decided by bounds only, for the criterion's conclusion.
struct BoundsTally {
  bool unstable_by_bounds = false;
  std::vector<std::string> undecided;  // the blocks whose bounds straddle 1
};

// A block without a rate (aperiodic, or its chain too large): a stable one is bounded by α²,
// an unstable one leaves the criterion inapplicable.
void add_block_without_rate(MarkovCriterion& out, EigenBlockCriterion block, const MarkovOptions& options) {
  const double alpha = block.modulus;
  if (alpha < 1.0) {
    // A stable block never decides instability: α_i² · rate ≤ α_i² < 1.
    block.deficiency_rate = 1.0;
    block.criterion = alpha * alpha;
    out.reasons.push_back("stable eigen-block |λ| = " + std::to_string(alpha) +
                          " is aperiodic; bounded its criterion by α² < 1");
    out.blocks.push_back(block);
    out.value = std::max(out.value, block.criterion);
    return;
  }
  out.applies = false;
  out.reasons.push_back("eigen-block |λ| = " + std::to_string(alpha) +
                        " is aperiodic (no τ with A^τ ∝ I) or its rank-deficient chain passed " +
                        std::to_string(options.max_chain_states) +
                        " states: the transition-matrix method (multi-sensor paper Thm 9) needs a periodic block");
}

// Bounds only (theory/markov.hpp): decided when the sufficient or necessary side does. False
// when they straddle 1: the block is then listed as undecided and counts in no value.
bool decide_block_by_bounds(EigenBlockCriterion& block, const GroupedBlockResult& r, BoundsTally& tally,
                            const MarkovOptions& options) {
  const double alpha = block.modulus;
  block.criterion_lower = alpha * alpha * r.lower;
  block.criterion_upper = alpha * alpha * r.upper;
  if (block.criterion_lower >= 1.0) {
    block.deficiency_rate = r.lower;
    block.criterion = block.criterion_lower;
    tally.unstable_by_bounds = true;
    return true;
  }
  if (block.criterion_upper < 1.0) {
    block.deficiency_rate = r.upper;
    block.criterion = block.criterion_upper;
    return true;
  }
  tally.undecided.push_back("eigen-block |λ| = " + std::to_string(alpha) + " has " + std::to_string(r.classes) +
                            " observation classes (distinct row spaces), more than can be tracked exactly (at most " +
                            std::to_string(options.max_classes) + " classes, " +
                            std::to_string(options.max_class_link_states) + " link states); its criterion lies in [" +
                            std::to_string(block.criterion_lower) + ", " + std::to_string(block.criterion_upper) +
                            "], which straddles 1");
  return false;
}

// One eigen-block's criterion α_i² · rate into the maximum over the blocks.
void add_block(MarkovCriterion& out, EigenBlockCriterion block, const GroupedBlockResult& r, BoundsTally& tally,
               const MarkovOptions& options) {
  block.method = r.method;
  block.observing_sensors = r.observing;
  block.classes = r.classes;
  block.chain_states = r.states;
  if (!r.ok) {
    add_block_without_rate(out, block, options);
    return;
  }
  if (!r.exact) {
    out.exact = false;
    if (!decide_block_by_bounds(block, r, tally, options)) {
      out.blocks.push_back(block);
      return;
    }
  } else {
    block.deficiency_rate = r.rate;
    block.criterion = block.modulus * block.modulus * r.rate;
  }
  out.blocks.push_back(block);
  out.value = std::max(out.value, block.criterion);
}

// An unstable block decides whatever the undecided ones say; otherwise they leave it open.
// Decided by bounds: which side decided it.
void conclude_by_bounds(MarkovCriterion& out, BoundsTally& tally) {
  if (out.applies && !tally.undecided.empty() && !(out.value >= 1.0)) {
    out.applies = false;
    for (auto& u : tally.undecided) out.reasons.push_back(std::move(u));
  }
  if (out.applies && !out.exact) {
    if (tally.unstable_by_bounds)
      out.reasons.push_back("Markov criterion decided unstable by a necessary condition: every sensor observing a "
                            "block lost N times in a row already has rate prod_j rho(M_j) with alpha^2 times it >= 1");
    else if (out.value < 1.0)
      out.reasons.push_back("Markov criterion decided stable by a sufficient condition: the exact chain over the "
                            "most reliable observation classes only (dropping sensors only adds rank-deficient "
                            "sequences)");
  }
}

}  // namespace

MarkovCriterion markov_stability_criterion(const Matrix& A, std::span<const SensorSpec> sensors,
                                           const MarkovOptions& options) {
  MarkovCriterion out;
  Eigen::ComplexEigenSolver<CMatrix> es(A.cast<Complex>());
  if (es.info() != Eigen::Success) {
    out.reasons.push_back("eigen-decomposition of A failed");
    return out;
  }
  const CMatrix V = es.eigenvectors();
  const Eigen::VectorXcd lambda = es.eigenvalues();
  // Assumption 3 (diagonalisable A): the eigenvector matrix must be well conditioned.
  if (!(eigenvector_condition(V) < 1e8)) {
    out.reasons.push_back("A is not diagonalisable (Jordan block): the Markov criterion (multi-sensor paper "
                          "Assumption 3, Thm 7) needs a diagonalisable A");
    return out;
  }
  std::vector<LinkChain> links;
  for (const auto& s : sensors) links.push_back(link_chain(s.link.loss));  // delay-free links (with_effective_links)

  out.applies = true;
  out.value = 0.0;
  BoundsTally tally;
  for (const auto& members : eigen_blocks(lambda)) {
    const double alpha = std::abs(lambda(members.front()));
    EigenBlockCriterion block;
    block.modulus = alpha;
    block.dimension = static_cast<int>(members.size());
    if (alpha < 1e-12) {
      // A nilpotent-free zero block: the state component vanishes after one step.
      block.deficiency_rate = 0.0;
      block.criterion = 0.0;
      out.blocks.push_back(block);
      continue;
    }
    add_block(out, block, block_rate(V, lambda, members, alpha, links, sensors, options), tally, options);
  }
  conclude_by_bounds(out, tally);
  return out;
}

std::optional<double> second_order_iid_criterion(const Matrix& A, std::span<const SensorSpec> sensors,
                                                 std::span<const double> arrival_rates, std::string* why_not,
                                                 int* period) {
  auto fail = [&](const std::string& why) -> std::optional<double> {
    if (why_not) *why_not = why;
    return std::nullopt;
  };
  if (A.rows() != 2) return fail("Thm 12 needs a second-order system (n = 2)");
  if (arrival_rates.size() != sensors.size() || sensors.empty()) return fail("Thm 12 needs one i.i.d. rate per sensor");
  Eigen::ComplexEigenSolver<CMatrix> es(A.cast<Complex>());
  const Complex l1 = es.eigenvalues()(0), l2 = es.eigenvalues()(1);
  const double alpha = std::abs(l1);
  if (std::abs(std::abs(l2) - alpha) > 1e-9 * std::max(1.0, alpha))
    return fail("Thm 12 (Assumption 5) needs both eigenvalues of A of the same modulus");
  if (std::abs(l1 - l2) <= 1e-9 * std::max(1.0, alpha)) return fail("Thm 12 (Assumption 5) needs θ1 ≠ θ2");
  // τ: least τ with e^{i(θ1−θ2)τ} = 1 (A^τ a real multiple of I); 0 = aperiodic.
  const Complex ratio = (l1 / l2) / std::abs(l1 / l2);
  int tau = 0;
  Complex power = ratio;
  for (int k = 1; k <= 10000; ++k) {
    if (std::abs(power - 1.0) < 1e-9) {
      tau = k;
      break;
    }
    power *= ratio;
  }
  if (period) *period = tau;
  // Assumption 6: each C_i one effective row with (A, C_i) observable; rank col{C_i, C_j} = 2.
  std::vector<Eigen::RowVector2d> c;
  for (const auto& s : sensors) {
    Eigen::JacobiSVD<Matrix> svd(s.C, Eigen::ComputeFullV);
    const auto& sv = svd.singularValues();
    if (sv.size() == 0 || sv(0) <= 0.0 || (sv.size() > 1 && sv(1) > 1e-9 * sv(0)))
      return fail("Thm 12 (Assumption 6) needs every C_i of rank one");
    const Eigen::RowVector2d row = svd.matrixV().col(0).transpose();
    Eigen::Matrix2d obs;
    obs << row, row * A;
    if (std::abs(obs.determinant()) <= 1e-9 * obs.norm() * obs.norm())
      return fail("Thm 12 (Assumption 6) needs (A, C_i) observable for every sensor");
    c.push_back(row);
  }
  for (std::size_t i = 0; i < c.size(); ++i)
    for (std::size_t j = i + 1; j < c.size(); ++j) {
      Eigen::Matrix2d m;
      m << c[i], c[j];
      if (std::abs(m.determinant()) <= 1e-9)
        return fail("Thm 12 (Assumption 6) needs rank col{C_i, C_j} = 2 (combine collinear sensors, Remark 11)");
    }
  // Congruent sets (Definition 1) and p*_i (eq. 37).
  const int horizon = tau > 0 ? tau : 1000;
  double min_p_star = 1.0;
  double all_lost = 1.0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    all_lost *= 1.0 - arrival_rates[i];
    double p_star = 1.0;
    for (std::size_t j = 0; j < c.size(); ++j) {
      Eigen::RowVector2d cj = c[j];
      bool congruent = false;
      for (int k = 0; k < horizon && !congruent; ++k) {
        Eigen::Matrix2d m;
        m << c[i], cj;
        congruent = std::abs(m.determinant()) <= 1e-9 * cj.norm();
        cj = cj * A;
        cj /= cj.norm();
      }
      if (congruent) p_star *= 1.0 - arrival_rates[j];
    }
    min_p_star = std::min(min_p_star, p_star);
  }
  if (all_lost == 0.0) return 0.0;
  if (tau == 0) return alpha * alpha * all_lost;  // τ → ∞ limit of eq. (38)
  // eq. (38), taken to the power 1/τ: α² (Π(1 − p_i)^τ / min_j p*_j)^{1/τ}.
  return alpha * alpha * std::pow(std::pow(all_lost, tau) / min_p_star, 1.0 / tau);
}

}  // namespace netkf::theory
