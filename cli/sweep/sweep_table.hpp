#pragma once
// A sweep's numbers and their files (docs/experiments.md, "Sweeps"; the Python reader in
// python/netkf/ reads them, so the columns are a contract):
//   runs.csv    point,seed,<varied keys>,status,<every summary quantity>     one row per run
//   points.csv  point,<varied keys>,seeds,<q_mean,q_se,q_min,q_max per quantity>,
//               theory_stable,theory_trace_S_bar,theory_trace_V_bar,theory_critical_margin,
//               theory_trace_P_sampled,theory_trace_P_sampled_se
// An empty cell is a quantity with no value (null in the run's summary).
#include <iosfwd>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "netkf/cli/sweep/sweep_spec.hpp"

namespace netkf::cli::sweep {

/// One run of the sweep: point index, seed index (1..N), and the summary's quantities in the
/// order of `quantities` (summary_names), or a run that could not run.
struct RunRow {
  int point = 0;
  int seed = 0;
  bool ok = false;
  std::vector<std::optional<double>> values;
};

/// Mean, standard error of the mean (sample standard deviation / √n), min and max over the
/// values that exist; n the number of those. The mean with n ≥ 1, the standard error with n ≥ 2.
struct Stats {
  int n = 0;
  std::optional<double> mean, se, min, max;
};
Stats aggregate(const std::vector<std::optional<double>>& values);

/// What the core analysis says of a point's scenario (empty where it does not apply).
struct Theory {
  std::optional<bool> stable;          // the verdict; empty when unknown
  std::optional<double> trace_S_bar;   // Tr S̄, lower bound on lim E[P_{k|k−1}] (Sinopoli Thm 4)
  std::optional<double> trace_V_bar;   // Tr V̄, upper bound
  std::optional<double> critical_margin;  // 1 − Markov criterion (> 0: stable; multi-sensor Thm 7/9)
  // Links with memory (no i.i.d. bound): lim E[Tr P_{k|k−1}] estimated by simulation, ± its
  // standard error (core/src/theory/sampled_covariance.hpp): an estimate, not a bound.
  std::optional<double> trace_P_sampled;
  std::optional<double> trace_P_sampled_se;
};

/// A number as the files write it: an integer exactly, anything else with 17 significant
/// digits (round-trips); empty for none or a non-finite value.
std::string cell(const std::optional<double>& v);

std::string runs_header(const std::vector<Vary>& vary, const std::vector<std::string>& quantities);
std::string runs_line(const RunRow& row, const Point& point);
std::string points_header(const std::vector<Vary>& vary, const std::vector<std::string>& quantities);
/// A point's line: its ok runs aggregated per quantity (`rows` may hold other points' rows).
std::string points_line(const Point& point, std::size_t quantities, const std::vector<RunRow>& rows,
                        const Theory& theory);
/// The stats of quantity `q` over a point's ok runs.
Stats point_stats(int point, std::size_t q, const std::vector<RunRow>& rows);

/// Reads a runs.csv written for this grid and quantities: its rows, in file order. Throws
/// std::runtime_error when the header differs (another sweep's file) or a line is malformed.
std::vector<RunRow> read_runs_csv(std::istream& in, const std::vector<Vary>& vary,
                                  const std::vector<std::string>& quantities);
/// The runs a resumed sweep skips: those with status ok (a failed run is run again).
std::set<std::pair<int, int>> done_runs(const std::vector<RunRow>& rows);

}  // namespace netkf::cli::sweep
