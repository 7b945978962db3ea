#pragma once
// `netkf analyze S.yaml --link ID=TRACE.csv`: each trace fitted (`auto`, as `netkf fit`),
// its link substituted into the scenario, and the verdict for it with its margins
// (netkf/fit/link_verdict.hpp).
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "netkf/fit/link_verdict.hpp"
#include "netkf/fit/loss_fit.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::cli {

struct MeasuredLink {
  int link_id = 0;
  std::string trace;
  fit::TraceFit fit;
  std::optional<fit::DelaySummary> delay;
  fit::MeasuredLinkVerdict verdict;
};

/// Parses each "ID=TRACE.csv", reads and fits the trace and puts the fitted link into
/// `scenario`. Throws std::invalid_argument (a malformed spec, an unknown or repeated id) or
/// TraceError (the trace's FILE:LINE:COL).
std::vector<MeasuredLink> fit_measured_links(Scenario& scenario, const std::vector<std::string>& specs);

/// The verdict of every measured link, for the scenario with all of them substituted.
void judge_measured_links(const Scenario& scenario, std::vector<MeasuredLink>& links);

nlohmann::json measured_links_json(const std::vector<MeasuredLink>& links);
void print_measured_links(std::ostream& out, const std::vector<MeasuredLink>& links);

}  // namespace netkf::cli
