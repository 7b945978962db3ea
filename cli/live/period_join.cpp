#include "netkf/cli/live/period_join.hpp"

namespace netkf::cli {

std::optional<double> PeriodJoin::add_truth(std::int64_t k, std::vector<double> x) {
  auto& t = truth_[k];
  if (t.scored) return std::nullopt;  // a repeated truth of a scored period
  t.x = std::move(x);
  return join(k);
}

std::optional<double> PeriodJoin::add_estimate(std::int64_t k, const Vector& x_hat) {
  if (auto t = truth_.find(k); t != truth_.end() && t->second.scored) return std::nullopt;
  x_hat_[k] = x_hat;
  return join(k);
}

const std::vector<double>* PeriodJoin::truth(std::int64_t k) const {
  auto t = truth_.find(k);
  return t == truth_.end() || t->second.x.empty() ? nullptr : &t->second.x;
}

std::optional<double> PeriodJoin::join(std::int64_t k) {
  std::optional<double> squared_error;
  auto t = truth_.find(k);
  auto e = x_hat_.find(k);
  if (t != truth_.end() && !t->second.x.empty() && e != x_hat_.end()) {
    if (static_cast<Eigen::Index>(t->second.x.size()) == e->second.size()) {
      double sq = 0.0;
      for (std::size_t i = 0; i < t->second.x.size(); ++i) {
        const double d = t->second.x[i] - e->second(static_cast<Eigen::Index>(i));
        sq += d * d;
      }
      squared_error = sq;
    }
    t->second.scored = true;
    x_hat_.erase(e);
  }
  forget_before(k - kWindow);
  return squared_error;
}

void PeriodJoin::forget_before(std::int64_t k) {
  while (!truth_.empty() && truth_.begin()->first < k) truth_.erase(truth_.begin());
  while (!x_hat_.empty() && x_hat_.begin()->first < k) x_hat_.erase(x_hat_.begin());
}

}  // namespace netkf::cli
