#pragma once
// Sinopoli Thm 5(c) / Liu-Goldsmith Thm 5(c), generalised to d sensors: the LMI
//   Ψ(Y, Z_S) = [ Y                      √π_S (Y A + Z_S C_S) ...  ]
//               [ √π_S (A'Y + C_S'Z_S')   Y                    ...  ]  > 0,   0 < Y ≤ I,
// one off-diagonal block per arrival pattern S (π_∅'s block is √π_∅ Y A). It is
// feasible iff ∃K_S, X > 0 with X > Σ π_S F_S X F_S' (F_S = A + K_S C_S), i.e. iff
// ∃X > g(X) (Thm 5 (a)⇔(c)). Solved with CSDP (Debian libsdp-dev) as
//   maximise t  s.t.  Ψ(Y, Z) − t I ⪰ 0,  I − Y ⪰ 0,  t ≤ 1,
// feasible iff the optimum t* > 0 (checked on the returned point, not trusted blindly:
// λ_min(Ψ) at the returned point must exceed a threshold far above rounding, 1e-11).
#include <span>

#include "netkf/theory/riccati.hpp"

namespace netkf::theory {

struct LmiResult {
  bool solved = false;      // CSDP returned a usable point
  double margin = 0.0;      // λ_min(Ψ(Y, Z)) at the returned point (> 0: strictly feasible)
  int solver_code = -1;     // CSDP's return code (0 = success, 3 = partial success)
  bool feasible(double threshold = 1e-11) const { return solved && margin > threshold; }
};

/// Solve the stability LMI for the given arrival patterns (Q does not enter: Ψ is homogeneous).
/// Thread-safe (CSDP calls are serialised; its progress output is discarded).
LmiResult solve_stability_lmi(const Matrix& A, std::span<const ArrivalPattern> patterns);

}  // namespace netkf::theory
