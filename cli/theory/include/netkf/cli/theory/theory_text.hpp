#pragma once
// What `netkf analyze` and `netkf simulate` print: the report as a readable table or as JSON
// (the keys are a contract: docs/architecture.md, "Contracts"). JSON has no NaN or infinity:
// a non-finite or missing number is null.
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>

#include "netkf/model/scenario.hpp"
#include "netkf/sim/monte_carlo.hpp"
#include "netkf/theory/report.hpp"

namespace netkf::cli {

/// The analysis as JSON, with the region's and the sweep's grids when asked for.
nlohmann::json analysis_json(const theory::AnalysisReport& report, bool with_region, bool with_sweep);
void print_analysis(std::ostream& out, const Scenario& scenario, const theory::AnalysisReport& report);

nlohmann::json monte_carlo_json(const MonteCarloResult& result);
void print_monte_carlo(std::ostream& out, const Scenario& scenario, const MonteCarloResult& result);

/// A number for JSON, or null when absent or not finite (JSON has no inf or NaN).
nlohmann::json number_or_null(const std::optional<double>& v);

}  // namespace netkf::cli
