#pragma once
// The stability verdict for a measured link (`netkf analyze S.yaml --link ID=TRACE.csv`,
// docs/cli.md): the scenario with the link's fitted loss model, the Markov criterion for it
// (multi-sensor paper Thm 7: E[P_{k|k-1}] bounded iff the criterion is < 1), how far the
// link is from the critical boundary in loss and in mean burst, and whether the verdict
// holds across the fit's 95% intervals.
//
// Margins move the link along the loss / mean-burst form of netkf/links/link_keys.hpp (the simple
// Gilbert channel with that stationary loss and mean burst, as `ctl set-link --loss` would
// make it; a bernoulli fit moves its loss along i.i.d. links instead), the link's delay and
// every other link kept. They assume the criterion grows with the loss and with the mean
// burst (more loss, longer bursts: a harder link), and find the boundary by bisection.
#include <optional>
#include <string>
#include <vector>

#include "netkf/fit/loss_fit.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/theory/stability.hpp"

namespace netkf::fit {

/// The criterion at one point of the (loss, mean burst) plane.
struct LinkVerdictPoint {
  double loss = 0.0;
  double mean_burst = 1.0;
  std::optional<double> criterion;  // nullopt: the Markov criterion does not apply
};

/// Where the criterion crosses 1 along one direction, from the fitted point.
struct LinkBoundary {
  std::optional<double> critical;  // the loss (or mean burst) at the boundary; nullopt: none in range
  double limit = 0.0;              // the end of the range searched (the boundary is not before it when nullopt)
  std::string text;                // one line: the margin in words
};

struct MeasuredLinkVerdict {
  int link_id = 0;
  LinkSpec link;                    // the link substituted into the scenario (fitted loss model, delay)
  std::optional<double> criterion;  // Markov criterion of the scenario with the fitted link(s)
  theory::Verdict stable = theory::Verdict::unknown;
  double loss = 0.0;                // the fit's stationary loss and mean burst
  double mean_burst = 1.0;
  std::optional<double> equivalent_criterion;  // with the link in the form the margins move along
  LinkBoundary loss_boundary;       // at the fitted mean burst
  LinkBoundary burst_boundary;      // at the fitted loss
  std::vector<LinkVerdictPoint> interval_corners;  // the corners of the 95% loss × mean-burst box
  std::string across_interval;      // "stable across ...", "unstable across ...", "undecided within ...", or why not
};

/// The link of `configured` with `fit`'s loss model; with `delay`, a normal delay of its mean
/// and jitter (as `netkf fit --scenario` writes it), else the configured delay.
LinkSpec fitted_link_spec(const LinkSpec& configured, const LossFit& fit, const std::optional<DelaySummary>& delay);

/// The verdict for link `link_id` of `scenario` (which already has the fitted link(s)).
/// Throws std::invalid_argument for an unknown link id.
MeasuredLinkVerdict measured_link_verdict(const Scenario& scenario, int link_id, const LossFit& fit);

}  // namespace netkf::fit
