// The checkpoint a restarted estimator resumes from: the last estimate its previous life
// published, as a small JSON file written by whoever kept it (`netkf launch`), read at start.
// Only what resuming needs is kept: k, t, x̂, P (row-major) and the run's counters.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "netkf/records/checkpoint.hpp"

namespace netkf {

void write_checkpoint(const std::string& path, const Estimate& c) {
  nlohmann::json j;
  j["k"] = c.k;
  j["t"] = c.t;
  j["x_hat"] = std::vector<double>(c.x_hat.data(), c.x_hat.data() + c.x_hat.size());
  std::vector<double> P;
  for (Eigen::Index r = 0; r < c.P.rows(); ++r)
    for (Eigen::Index col = 0; col < c.P.cols(); ++col) P.push_back(c.P(r, col));
  j["P"] = P;  // row-major
  j["restarts"] = c.restarts;
  j["late_total"] = c.late_total;
  j["rejected_total"] = c.rejected_total;
  // nlohmann writes doubles with 17 significant digits: they read back bit-identical.
  // Written beside and renamed, so a reader never sees half a file.
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << j.dump() << "\n";
    if (!out) throw std::runtime_error("cannot write the estimator checkpoint " + tmp);
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::runtime_error("cannot rename the estimator checkpoint to " + path);
}

Estimate read_checkpoint(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read the estimator checkpoint " + path);
  try {
    const auto j = nlohmann::json::parse(in);
    Estimate c;
    c.k = j.at("k").get<std::uint64_t>();
    c.t = j.at("t").get<double>();
    const auto x = j.at("x_hat").get<std::vector<double>>();
    const auto P = j.at("P").get<std::vector<double>>();
    const auto n = static_cast<Eigen::Index>(x.size());
    if (n == 0 || P.size() != x.size() * x.size())
      throw std::runtime_error("x_hat has " + std::to_string(x.size()) + " entries but P has " +
                               std::to_string(P.size()));
    c.x_hat = Eigen::Map<const Vector>(x.data(), n);
    c.P = Matrix(n, n);
    for (Eigen::Index r = 0; r < n; ++r)
      for (Eigen::Index col = 0; col < n; ++col) c.P(r, col) = P[static_cast<std::size_t>(r * n + col)];
    c.restarts = j.at("restarts").get<std::uint32_t>();
    c.late_total = j.at("late_total").get<std::uint64_t>();
    c.rejected_total = j.at("rejected_total").get<std::uint64_t>();
    if (!std::isfinite(c.t)) throw std::runtime_error("t is not finite");
    return c;
  } catch (const std::exception& e) {
    throw std::runtime_error("estimator checkpoint " + path + ": " + e.what());
  }
}

}  // namespace netkf
