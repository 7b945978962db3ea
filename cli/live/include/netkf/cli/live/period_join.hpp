#pragma once
// The truth x_k and the estimate x̂_{k|k} of one period arrive on different topics in either
// order; the live view and the run summary both score the estimate against the truth of
// the same period. This is that one join, with one window.
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "netkf/support/types.hpp"

namespace netkf::cli {

class PeriodJoin {
 public:
  /// Periods further than this behind the newest one are forgotten (a sample lost for good).
  static constexpr std::int64_t kWindow = 2000;

  /// Each returns |x_k − x̂_{k|k}|² when this completes period k's pair (once per period;
  /// nothing when the sizes differ, which the bus's validation should make impossible).
  std::optional<double> add_truth(std::int64_t k, std::vector<double> x);
  std::optional<double> add_estimate(std::int64_t k, const Vector& x_hat);

  /// The truth of period k while it is within the window (nullptr: not arrived or forgotten).
  const std::vector<double>* truth(std::int64_t k) const;

 private:
  std::optional<double> join(std::int64_t k);
  void forget_before(std::int64_t k);

  struct Truth {
    std::vector<double> x;
    bool scored = false;
  };
  std::map<std::int64_t, Truth> truth_;  // kept after scoring: the newest period's view shows it
  std::map<std::int64_t, Vector> x_hat_;  // waiting for their truth
};

}  // namespace netkf::cli
