// The verdict for a measured link (netkf/fit/link_verdict.hpp).
#include "netkf/fit/link_verdict.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>

#include "netkf/links/link_keys.hpp"
#include "netkf/theory/markov.hpp"

namespace netkf::fit {
namespace {

constexpr int kBisections = 60;
constexpr double kMaxMeanBurst = 1e4;  // the search for a critical mean burst stops here

std::string g6(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

// The Markov criterion of `scenario` with link `index`'s loss model replaced by `model`.
std::optional<double> criterion_with(const Scenario& scenario, std::size_t index, const LinkModel& model) {
  Scenario s = scenario;
  s.sensors[index].link.loss = model;
  const Scenario effective = with_effective_links(s);
  const theory::MarkovCriterion m = theory::markov_stability_criterion(effective.plant.A, effective.sensors);
  if (!m.applies) return std::nullopt;
  return m.value;
}

// The simple Gilbert channel of a loss and a mean burst (netkf/links/link_keys.hpp's loss + mean_burst
// form); nullopt where that form has no link (loss above B/(B+1)).
std::optional<LinkModel> simple_gilbert(double loss, double mean_burst) {
  try {
    return apply_link_keys(LinkSpec{}, {{"model", std::string("gilbert_elliott")}, {"loss", loss}, {"mean_burst", mean_burst}})
        .loss;
  } catch (const LinkError&) {
    return std::nullopt;
  }
}

// The boundary along x in [from, to] (either order): where stable(x) flips, by bisection.
// `value(x)` is the criterion; nullopt when it does not apply somewhere on the way.
std::optional<double> bisect(const std::function<std::optional<double>(double)>& value, double stable_x,
                             double unstable_x, bool log_scale) {
  double a = stable_x, b = unstable_x;
  for (int i = 0; i < kBisections; ++i) {
    const double mid = log_scale ? std::sqrt(a * b) : 0.5 * (a + b);
    const auto v = value(mid);
    if (!v) return std::nullopt;
    (*v < 1.0 ? a : b) = mid;
  }
  return 0.5 * (a + b);
}

LinkBoundary find_boundary(const std::function<std::optional<double>(double)>& value, double at, double worst,
                           double best, bool log_scale, const std::string& name, const std::string& unit) {
  LinkBoundary out;
  const auto here = value(at);
  if (!here) {
    out.text = "the Markov criterion does not apply: no margin";
    return out;
  }
  const bool stable_here = *here < 1.0;
  out.limit = stable_here ? worst : best;
  const auto end = value(out.limit);
  if (!end || (*end < 1.0) == stable_here) {
    out.text = stable_here ? "stable up to the largest " + name + " searched (" + g6(worst) + unit + ")"
                           : "unstable down to the smallest " + name + " searched (" + g6(best) + unit + ")";
    return out;
  }
  out.critical = stable_here ? bisect(value, at, worst, log_scale) : bisect(value, out.limit, at, log_scale);
  if (!out.critical) {
    out.text = "the Markov criterion stops applying on the way: no margin";
    return out;
  }
  out.text = (stable_here ? "stable until " : "unstable: needs ") + name + (stable_here ? " " : " below ") +
             g6(*out.critical) + unit + " (now " + g6(at) + unit + ")";
  return out;
}

}  // namespace

LinkSpec fitted_link_spec(const LinkSpec& configured, const LossFit& fit, const std::optional<DelaySummary>& delay) {
  LinkSpec link = configured;
  link.loss = fit.link;
  if (delay) link.delay = LinkDelay{delay->mean_ms, delay->jitter_ms, DelayDistribution::normal};
  validate_link(link);
  return link;
}

MeasuredLinkVerdict measured_link_verdict(const Scenario& scenario, int link_id, const LossFit& fit) {
  const auto it = std::find_if(scenario.sensors.begin(), scenario.sensors.end(),
                               [&](const SensorSpec& s) { return s.id == link_id; });
  if (it == scenario.sensors.end()) throw std::invalid_argument("no link " + std::to_string(link_id) + " in the scenario");
  const std::size_t index = static_cast<std::size_t>(it - scenario.sensors.begin());
  MeasuredLinkVerdict v;
  v.link_id = link_id;
  v.link = it->link;
  v.loss = fit.loss.value;
  v.mean_burst = fit.mean_burst.value;
  v.criterion = criterion_with(scenario, index, it->link.loss);
  v.stable = !v.criterion ? theory::Verdict::unknown : *v.criterion < 1.0 ? theory::Verdict::yes : theory::Verdict::no;
  const bool iid = fit.family == LossFamily::bernoulli;
  // The links the margins move along: i.i.d. for a bernoulli fit's loss, else the simple Gilbert form.
  const auto at = [&](double loss, double burst) -> std::optional<double> {
    if (iid && burst == v.mean_burst) return criterion_with(scenario, index, BernoulliLink{loss});
    const auto m = simple_gilbert(loss, burst);
    return m ? criterion_with(scenario, index, *m) : std::nullopt;
  };
  v.equivalent_criterion = at(v.loss, v.mean_burst);
  if (!std::isfinite(v.mean_burst)) {
    v.loss_boundary.text = v.burst_boundary.text = "the link never delivers after a drop: no margin";
  } else {
    const double loss_cap = iid ? 1.0 : v.mean_burst / (v.mean_burst + 1.0);
    v.loss_boundary = find_boundary([&](double l) { return at(l, v.mean_burst); }, v.loss, loss_cap, 0.0, false,
                                    "loss", "");
    const double burst_floor = std::max(1.0, v.loss / (1.0 - v.loss));
    v.burst_boundary = find_boundary([&](double b) { return at(v.loss, b); }, v.mean_burst, kMaxMeanBurst,
                                     burst_floor, true, "mean burst", " samples");
  }
  // Across the intervals: the box's corners (the worst is high loss, long bursts).
  if (!fit.loss.ci_low || !fit.mean_burst.ci_low) {
    v.across_interval = "no interval for the fit's loss and mean burst: the verdict is for the estimate only";
    return v;
  }
  int stable = 0, unstable = 0, unknown = 0;
  for (double l : {*fit.loss.ci_low, *fit.loss.ci_high}) {
    for (double b : {*fit.mean_burst.ci_low, *fit.mean_burst.ci_high}) {
      const double burst = iid ? v.mean_burst : b;  // an i.i.d. link's burst follows from its loss
      const auto c = iid ? criterion_with(scenario, index, BernoulliLink{l}) : at(l, burst);
      v.interval_corners.push_back({l, burst, c});
      (!c ? unknown : *c < 1.0 ? stable : unstable) += 1;
    }
  }
  const std::string box = "the 95% intervals of loss [" + g6(*fit.loss.ci_low) + ", " + g6(*fit.loss.ci_high) +
                          "] and mean burst [" + g6(*fit.mean_burst.ci_low) + ", " + g6(*fit.mean_burst.ci_high) + "]";
  if (unknown > 0) v.across_interval = "undecided within " + box + ": the criterion does not apply at a corner";
  else if (unstable == 0) v.across_interval = "stable across " + box;
  else if (stable == 0) v.across_interval = "unstable across " + box;
  else v.across_interval = "undecided within " + box + ": stable at " + std::to_string(stable) + " of its 4 corners";
  return v;
}

}  // namespace netkf::fit
