#pragma once
// report.html of a sweep: one self-contained page (uPlot and the data inlined; no network) with
// a plot of each quantity against each varied key: the mean over seeds with a band of ± one
// standard error and the min/max as dashed lines, one curve per combination of the other keys;
// on mean_trace_P the theory's band [Tr S̄, Tr V̄] where the analysis gives it; and a table of the
// points with the theory's verdict and critical margin.
#include <string>
#include <string_view>
#include <vector>

#include "netkf/cli/sweep/sweep_spec.hpp"
#include "sweep_table.hpp"

namespace netkf::cli::sweep {

struct ReportData {
  std::string scenario;
  std::string mode;  // live | offline
  int seeds = 0;
  std::vector<Vary> vary;
  std::vector<Point> grid;
  std::vector<std::string> quantities;
  std::vector<RunRow> rows;
  std::vector<Theory> theory;  // per point
};

/// The page. `uplot_js`, `uplot_css`: uPlot's dist files, inlined.
std::string render_report(const ReportData& data, std::string_view uplot_js, std::string_view uplot_css);

}  // namespace netkf::cli::sweep
