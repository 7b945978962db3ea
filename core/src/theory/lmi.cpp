// CSDP wrapper for the stability LMI (see core/src/theory/lmi.hpp).
// CSDP's dual problem is  min a'y  s.t.  Σ y_i A_i − C ⪰ 0  (block-diagonal), i.e. an LMI in
// y; we put Ψ(Y, Z) − tI, I − Y and 1 − t in three blocks and minimise −t.
#include "lmi.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <vector>

extern "C" {
#include <csdp/declarations.h>
}

namespace netkf::theory {
namespace {

// Decision variables: Y (symmetric, upper triangle), Z_S (n x m_S per non-empty pattern), t.
struct Layout {
  Eigen::Index n = 0;
  std::vector<std::pair<Eigen::Index, Eigen::Index>> y_entries;
  std::vector<Eigen::Index> z_offset;  // first variable of Z_S (or -1 when S is empty)
  Eigen::Index t_index = 0;
  Eigen::Index count = 0;
};

Layout make_layout(Eigen::Index n, std::span<const ArrivalPattern> patterns) {
  Layout l;
  l.n = n;
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = i; j < n; ++j) l.y_entries.emplace_back(i, j);
  Eigen::Index next = static_cast<Eigen::Index>(l.y_entries.size());
  for (const auto& s : patterns) {
    if (s.C.rows() == 0) {
      l.z_offset.push_back(-1);
    } else {
      l.z_offset.push_back(next);
      next += n * s.C.rows();
    }
  }
  l.t_index = next;
  l.count = next + 1;
  return l;
}

struct Blocks {
  Matrix psi;        // Ψ(Y, Z) − t I
  Matrix upper;      // I − Y  (constant part included only when with_constant)
  double t_bound;    // 1 − t
};

// The LMI's value at the variable vector v (affine: constant part only when with_constant).
Blocks evaluate(const Matrix& A, std::span<const ArrivalPattern> patterns, const Layout& l, const Vector& v,
                bool with_constant) {
  const Eigen::Index n = l.n;
  Matrix Y = Matrix::Zero(n, n);
  for (std::size_t k = 0; k < l.y_entries.size(); ++k) {
    const auto [i, j] = l.y_entries[k];
    Y(i, j) = v(static_cast<Eigen::Index>(k));
    Y(j, i) = v(static_cast<Eigen::Index>(k));
  }
  const double t = v(l.t_index);
  const Eigen::Index P = static_cast<Eigen::Index>(patterns.size());
  Blocks b;
  b.psi = Matrix::Zero(n * (1 + P), n * (1 + P));
  b.psi.topLeftCorner(n, n) = Y;
  for (Eigen::Index s = 0; s < P; ++s) {
    const auto& pat = patterns[static_cast<std::size_t>(s)];
    Matrix off = Y * A;  // Y F_S with Z_S = Y K_S: Y A + Z_S C_S
    if (pat.C.rows() > 0) {
      const Eigen::Index m = pat.C.rows();
      const Matrix Z = Eigen::Map<const Matrix>(v.data() + l.z_offset[static_cast<std::size_t>(s)], n, m);
      off += Z * pat.C;
    }
    off *= std::sqrt(pat.probability);
    b.psi.block(0, n * (1 + s), n, n) = off;
    b.psi.block(n * (1 + s), 0, n, n) = off.transpose();
    b.psi.block(n * (1 + s), n * (1 + s), n, n) = Y;
  }
  b.psi -= t * Matrix::Identity(b.psi.rows(), b.psi.cols());
  b.upper = -Y;
  if (with_constant) b.upper += Matrix::Identity(n, n);
  b.t_bound = (with_constant ? 1.0 : 0.0) - t;
  return b;
}

// Upper-triangle non-zeros of a dense symmetric block as a CSDP sparse block (1-indexed).
sparseblock* make_sparse_block(const Matrix& m, int blocknum, int constraintnum) {
  std::vector<std::tuple<int, int, double>> nz;
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = i; j < m.cols(); ++j)
      if (m(i, j) != 0.0) nz.emplace_back(static_cast<int>(i) + 1, static_cast<int>(j) + 1, m(i, j));
  if (nz.empty()) return nullptr;
  auto* blk = static_cast<sparseblock*>(std::malloc(sizeof(sparseblock)));
  blk->next = nullptr;
  blk->nextbyblock = nullptr;
  blk->blocknum = blocknum;
  blk->blocksize = static_cast<int>(m.rows());
  blk->constraintnum = constraintnum;
  blk->issparse = 1;
  blk->numentries = static_cast<int>(nz.size());
  blk->entries = static_cast<double*>(std::malloc((nz.size() + 1) * sizeof(double)));
  blk->iindices = static_cast<int*>(std::malloc((nz.size() + 1) * sizeof(int)));
  blk->jindices = static_cast<int*>(std::malloc((nz.size() + 1) * sizeof(int)));
  for (std::size_t e = 0; e < nz.size(); ++e) {
    blk->iindices[e + 1] = std::get<0>(nz[e]);
    blk->jindices[e + 1] = std::get<1>(nz[e]);
    blk->entries[e + 1] = std::get<2>(nz[e]);
  }
  return blk;
}

// CSDP prints its progress with printf: silence fd 1 for the duration of a solve (serialised,
// so concurrent callers cannot interleave the redirection).
std::mutex& csdp_mutex() {
  static std::mutex m;
  return m;
}

class StdoutSilencer {
 public:
  StdoutSilencer() {
    std::fflush(stdout);
    saved_ = ::dup(1);
    const int devnull = ::open("/dev/null", O_WRONLY);
    if (saved_ >= 0 && devnull >= 0) ::dup2(devnull, 1);
    if (devnull >= 0) ::close(devnull);
  }
  ~StdoutSilencer() {
    std::fflush(stdout);
    if (saved_ >= 0) {
      ::dup2(saved_, 1);
      ::close(saved_);
    }
  }
  StdoutSilencer(const StdoutSilencer&) = delete;
  StdoutSilencer& operator=(const StdoutSilencer&) = delete;

 private:
  int saved_ = -1;
};

// Feasibility of Ψ is invariant under a change of state coordinates x̃ = T x (A → T A T⁻¹,
// C_S → C_S T⁻¹). Badly scaled systems (e.g. Sinopoli's MIMO example with A_23 = 7) otherwise
// need a very ill-conditioned Y and the margin drowns in the solver's tolerance; T = P⁻½ with P
// the full-arrival Riccati solution makes the problem well scaled. T only preconditions: the
// LMI alone decides feasibility.
Matrix preconditioner(const Matrix& A, std::span<const ArrivalPattern> patterns) {
  const Eigen::Index n = A.rows();
  const ArrivalPattern* fullest = &patterns.front();
  for (const auto& s : patterns)
    if (s.C.rows() > fullest->C.rows()) fullest = &s;
  ArrivalPattern all = *fullest;
  all.probability = 1.0;
  const Matrix Q = Matrix::Identity(n, n);  // unit process noise: only the shape of P matters
  const auto P = expected_covariance_upper_bound(A, Q, std::span<const ArrivalPattern>(&all, 1));
  if (P.status != BoundStatus::bounded) return Matrix::Identity(n, n);
  Eigen::SelfAdjointEigenSolver<Matrix> es(P.V);
  if (es.eigenvalues().minCoeff() <= 0.0) return Matrix::Identity(n, n);
  return es.eigenvectors() * es.eigenvalues().cwiseSqrt().cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
}

// The problem in the preconditioned coordinates: A → T A T⁻¹, C_S → C_S T⁻¹.
struct Problem {
  Matrix A;
  std::vector<ArrivalPattern> patterns;
};

Problem preconditioned(const Matrix& A_in, std::span<const ArrivalPattern> patterns_in) {
  const Matrix T = preconditioner(A_in, patterns_in);
  const Matrix T_inv = T.inverse();
  Problem p{T * A_in * T_inv, std::vector<ArrivalPattern>(patterns_in.begin(), patterns_in.end())};
  for (auto& s : p.patterns)
    if (s.C.rows() > 0) s.C = s.C * T_inv;
  return p;
}

// C = −(constant part) so that Σ y_i A_i − C is the LMI (CSDP's blocks are 1-indexed).
blockmatrix constant_matrix(const Blocks& constant, const int (&block_sizes)[3]) {
  blockmatrix C;
  C.nblocks = 3;
  C.blocks = static_cast<blockrec*>(std::malloc(4 * sizeof(blockrec)));
  for (int b = 1; b <= 2; ++b) {
    const Matrix& dense = b == 1 ? constant.psi : constant.upper;
    C.blocks[b].blockcategory = MATRIX;
    C.blocks[b].blocksize = block_sizes[b - 1];
    C.blocks[b].data.mat = static_cast<double*>(std::malloc(sizeof(double) * dense.size()));
    for (Eigen::Index j = 0; j < dense.cols(); ++j)
      for (Eigen::Index i = 0; i < dense.rows(); ++i)
        C.blocks[b].data.mat[ijtok(i + 1, j + 1, dense.rows())] = -dense(i, j);
  }
  C.blocks[3].blockcategory = DIAG;
  C.blocks[3].blocksize = 1;
  C.blocks[3].data.vec = static_cast<double*>(std::malloc(2 * sizeof(double)));
  C.blocks[3].data.vec[1] = -constant.t_bound;
  return C;
}

// The objective a (1-indexed): minimise −t.
double* objective(const Layout& layout) {
  const int k = static_cast<int>(layout.count);
  auto* a = static_cast<double*>(std::malloc((k + 1) * sizeof(double)));
  for (int i = 1; i <= k; ++i) a[i] = (i - 1 == layout.t_index) ? -1.0 : 0.0;
  return a;
}

// Constraint i (1-indexed): the LMI's linear part in variable i − 1, its three blocks sparse.
constraintmatrix* constraint_matrices(const Problem& p, const Layout& layout) {
  const int k = static_cast<int>(layout.count);
  auto* constraints = static_cast<constraintmatrix*>(std::malloc((k + 1) * sizeof(constraintmatrix)));
  for (int i = 1; i <= k; ++i) {
    Vector unit = Vector::Zero(layout.count);
    unit(i - 1) = 1.0;
    const Blocks lin = evaluate(p.A, p.patterns, layout, unit, false);
    Matrix t_block(1, 1);
    t_block(0, 0) = lin.t_bound;
    sparseblock* head = nullptr;
    sparseblock** tail = &head;
    const Matrix* parts[3] = {&lin.psi, &lin.upper, &t_block};
    for (int b = 0; b < 3; ++b) {
      if (sparseblock* blk = make_sparse_block(*parts[b], b + 1, i)) {
        *tail = blk;
        tail = &blk->next;
      }
    }
    constraints[i].blocks = head;
  }
  return constraints;
}

// Verify on the returned point y (1-indexed): Ψ(Y, Z) itself (t removed) must be positive definite.
void check_solution(LmiResult& result, const double* y, const Problem& p, const Layout& layout) {
  Vector v(layout.count);
  for (Eigen::Index i = 1; i <= layout.count; ++i) v(i - 1) = y[i];
  v(layout.t_index) = 0.0;
  const Blocks at = evaluate(p.A, p.patterns, layout, v, true);
  const double psi_min = Eigen::SelfAdjointEigenSolver<Matrix>(at.psi, Eigen::EigenvaluesOnly).eigenvalues().minCoeff();
  // Y ≤ I only normalises the homogeneous Ψ (Sinopoli Thm 5 proof), so it is not re-checked.
  result.solved = std::isfinite(psi_min);
  result.margin = psi_min;  // Y is a diagonal block of Ψ, so this bounds λ_min(Y) too
}

}  // namespace

LmiResult solve_stability_lmi(const Matrix& A_in, std::span<const ArrivalPattern> patterns_in) {
  LmiResult result;
  const Eigen::Index n = A_in.rows();
  if (n == 0 || patterns_in.empty()) return result;
  const Problem p = preconditioned(A_in, patterns_in);
  const Layout layout = make_layout(n, p.patterns);
  const Vector zero = Vector::Zero(layout.count);
  const Blocks constant = evaluate(p.A, p.patterns, layout, zero, true);
  const int k = static_cast<int>(layout.count);
  const int block_sizes[3] = {static_cast<int>(constant.psi.rows()), static_cast<int>(n), 1};
  const int total = block_sizes[0] + block_sizes[1] + block_sizes[2];
  blockmatrix C = constant_matrix(constant, block_sizes);
  double* a = objective(layout);
  constraintmatrix* constraints = constraint_matrices(p, layout);

  blockmatrix X{0, nullptr}, Z{0, nullptr};
  double* y = nullptr;
  double pobj = 0.0, dobj = 0.0;
  int code = -1;
  {
    std::lock_guard lock(csdp_mutex());
    StdoutSilencer quiet;
    initsoln(total, k, C, a, constraints, &X, &y, &Z);  // easy_sdp starts from (X, y, Z)
    code = easy_sdp(total, k, C, a, constraints, 0.0, &X, &y, &Z, &pobj, &dobj);
  }
  result.solver_code = code;
  if (y != nullptr && (code == 0 || code == 3 || code == 4)) check_solution(result, y, p, layout);
  free_prob(total, k, C, a, constraints, X, y, Z);
  return result;
}

}  // namespace netkf::theory
