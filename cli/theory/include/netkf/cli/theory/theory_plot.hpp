#pragma once
// Figures of `netkf analyze --plot` and `netkf simulate --plot`, drawn by gnuplot (spawned
// with a script on its stdin). Data go in gnuplot datablocks; missing values (unbounded
// covariance) are written as NaN, which gnuplot leaves out of the curve.
#include <filesystem>
#include <string>

#include "netkf/fit/loss_fit.hpp"
#include "netkf/sim/monte_carlo.hpp"
#include "netkf/theory/report.hpp"

namespace netkf::cli {

/// Throws std::runtime_error (the reason) unless `out` is a .png or .svg file that can be
/// written. Called before any work, so a bad --plot path fails at once.
void check_plot_output(const std::filesystem::path& out);

/// Sinopoli Figs. 2-4: Tr S̄ and Tr V̄ against λ with the critical rates marked.
void plot_sweep(const theory::AnalysisReport& report, const std::string& title, const std::filesystem::path& out);
/// Liu-Goldsmith Figs. 4-5: the (λ1, λ2) stable / unstable / undecided regions.
void plot_region(const theory::AnalysisReport& report, const std::string& title, const std::filesystem::path& out);
/// The (γ̄, ν̄) region of one sensor and the actuation link: stable above ν_upper, unstable
/// below ν_lower, undecided between.
void plot_actuation_region(const theory::AnalysisReport& report, const std::string& title,
                           const std::filesystem::path& out);
/// Monte Carlo mean Tr P_{k|k-1} and mean squared error with ±2 SE bands, next to S̄ and V̄.
void plot_monte_carlo(const MonteCarloResult& result, const theory::AnalysisReport& bounds, const std::string& title,
                      const std::filesystem::path& out);

/// `netkf fit --plot`: the trace's burst-length histogram (runs of drops, in the fit's
/// chi-square bins) as bars beside the fitted model's expected counts.
void plot_burst_histogram(const fit::LossFit& fit, const std::string& title, const std::filesystem::path& out);

}  // namespace netkf::cli
