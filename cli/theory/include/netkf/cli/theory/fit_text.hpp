#pragma once
// What `netkf fit` prints: the fit of a link trace as a readable table or as JSON (keys in
// docs/cli.md, "netkf fit"; JSON has no NaN or infinity: a missing number is null).
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>

#include "netkf/fit/loss_fit.hpp"

namespace netkf::cli {

/// The fitted link as a scenario's `link:` takes it: model and its keys ({model, loss} or
/// {model, p, r, loss_good, loss_bad}), and, when the trace had delays, the delay as a
/// normal distribution of its mean and jitter (delay_ms, jitter_ms, delay_distribution).
nlohmann::json fitted_link_json(const fit::LossFit& fit, const std::optional<fit::DelaySummary>& delay);

/// The same as one line of YAML: "{ model: gilbert_elliott, p: 0.03, r: 0.25, ... }".
std::string fitted_link_text(const fit::LossFit& fit, const std::optional<fit::DelaySummary>& delay);

/// The whole fit: the chosen fit's keys flat (model, its link keys, loss, mean_burst,
/// stderr, ci95, log_likelihood, aic, gof), `family`, `link` (the pasteable object), `why`,
/// every candidate, and the delay summary.
nlohmann::json fit_json(const std::string& trace_name, const fit::TraceFit& fit,
                        const std::optional<fit::DelaySummary>& delay);

void print_fit(std::ostream& out, const std::string& trace_name, const fit::TraceFit& fit,
               const std::optional<fit::DelaySummary>& delay);

}  // namespace netkf::cli
