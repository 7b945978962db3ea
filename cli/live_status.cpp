#include "live_status.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "netkf/analysis/operating_point.hpp"

namespace netkf::cli {

namespace {
constexpr std::int64_t kScoreWindow = 500;  // periods kept for joining truth and estimates

// Short numbers for the status view: 4 significant digits, or 3 decimals for rates.
std::string fmt(double v, bool fixed3 = false) {
  char buf[48];
  if (fixed3) std::snprintf(buf, sizeof buf, "%.3f", v);
  else std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}
}  // namespace

std::optional<LinkModel> link_model_from_status(const LinkStatusRecord& status) {
  if (status.model == "bernoulli" && status.params.size() >= 1) return BernoulliLink{status.params[0]};
  if (status.model == "gilbert_elliott" && status.params.size() >= 4)
    return GilbertElliottLink{status.params[0], status.params[1], status.params[2], status.params[3]};
  return std::nullopt;
}

std::string describe_link(const std::string& model, const std::vector<double>& params) {
  if (model == "bernoulli" && params.size() >= 1) return "bernoulli loss=" + fmt(params[0]);
  if (model == "gilbert_elliott" && params.size() >= 4)
    return "gilbert_elliott p=" + fmt(params[0]) + " r=" + fmt(params[1]) + " loss_good=" + fmt(params[2]) +
           " loss_bad=" + fmt(params[3]);
  return model;
}

std::string render_link_table(const std::vector<LinkStatusRecord>& links) {
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof line, "%-6s %-52s %8s %10s %10s %10s %9s %7s\n", "link", "model", "cfg λ", "samples",
                "delivered", "dropped", "obs loss", "burst");
  out << line;
  for (const auto& l : links) {
    const auto model = link_model_from_status(l);
    const double cfg_rate = model ? 1.0 - stationary_loss(*model) : std::nan("");
    std::snprintf(line, sizeof line, "%-6d %-52s %8.4f %10llu %10llu %10llu %9.4f %7.3f\n", l.sensor_id,
                  describe_link(l.model, l.params).c_str(), cfg_rate,
                  static_cast<unsigned long long>(l.samples_in), static_cast<unsigned long long>(l.delivered),
                  static_cast<unsigned long long>(l.dropped), l.observed_loss, l.mean_burst_length);
    out << line;
    if (!l.rejection_reason.empty())
      out << "       last request " << l.last_request_id << " rejected: " << l.rejection_reason << "\n";
  }
  return out.str();
}

LiveStatus::LiveStatus(Scenario scenario) : scenario_(std::move(scenario)) {}

void LiveStatus::add_truth(const TruthRecord& truth) {
  truth_[truth.k] = truth.x;
  score(truth.k);
}

void LiveStatus::add_estimate(const EstimateRecord& estimate) {
  ++estimates_seen_;
  bool finite = std::isfinite(estimate.trace_P);
  for (double v : estimate.xhat) finite = finite && std::isfinite(v);
  for (double v : estimate.P) finite = finite && std::isfinite(v);
  if (!finite) saw_non_finite_ = true;
  sum_trace_ += estimate.trace_P;
  if (!last_k_ || estimate.k >= *last_k_) {
    last_k_ = estimate.k;
    last_estimate_ = estimate;
  }
  estimates_[estimate.k] = estimate;
  score(estimate.k);
}

void LiveStatus::score(std::int64_t k) {
  auto t = truth_.find(k);
  auto e = estimates_.find(k);
  if (t != truth_.end() && e != estimates_.end() && t->second.size() == e->second.xhat.size()) {
    double sq = 0.0;
    for (std::size_t i = 0; i < t->second.size(); ++i) {
      const double d = t->second[i] - e->second.xhat[i];
      sq += d * d;
    }
    last_error_ = std::sqrt(sq);
    sum_sq_error_ += sq;
    ++scored_;
    truth_.erase(t);
    estimates_.erase(e);
  }
  while (!truth_.empty() && truth_.begin()->first < k - kScoreWindow) truth_.erase(truth_.begin());
  while (!estimates_.empty() && estimates_.begin()->first < k - kScoreWindow) estimates_.erase(estimates_.begin());
}

void LiveStatus::add_link_status(const LinkStatusRecord& status) {
  auto& view = links_[status.sensor_id];
  if (view.last.sensor_id == status.sensor_id && status.samples_in > view.last.samples_in &&
      status.delivered >= view.last.delivered) {
    // Rate over the last report interval: follows a runtime change quickly.
    view.observed_rate = static_cast<double>(status.delivered - view.last.delivered) /
                         static_cast<double>(status.samples_in - view.last.samples_in);
  } else if (status.samples_in > 0 && view.observed_rate < 0) {
    view.observed_rate = 1.0 - status.observed_loss;
  }
  view.last = status;
}

std::vector<std::string> LiveStatus::take_warnings() {
  auto w = std::move(warnings_);
  warnings_.clear();
  return w;
}

std::string LiveStatus::render(bool with_theory) {
  std::ostringstream out;
  if (last_estimate_) {
    const auto& e = *last_estimate_;
    out << "period " << e.k << "  t=" << fmt(e.t) << "s  state=" << e.state << "  Tr P=" << fmt(e.trace_P)
        << " (mean " << fmt(sum_trace_ / static_cast<double>(estimates_seen_)) << ")";
    if (last_error_)
      out << "  |x-x̂|=" << fmt(*last_error_) << " (rms " << fmt(std::sqrt(sum_sq_error_ / static_cast<double>(scored_)))
          << ")";
    out << "  fused=";
    for (std::size_t i = 0; i < e.fused.size(); ++i) out << (i ? ";" : "") << e.fused[i];
    if (e.fused.empty()) out << "-";
    out << "  late=" << e.late << " rejected=" << e.rejected << "\n";
  } else {
    out << "waiting for the first estimate...\n";
  }

  // Per-link configured vs observed arrival rate (λ_i = 1 − loss).
  Scenario configured = scenario_;
  std::vector<double> observed_rates;
  bool all_observed = !scenario_.sensors.empty();
  out << "  link  configured                                           λ cfg   λ obs\n";
  for (auto& sensor : configured.sensors) {
    auto it = links_.find(sensor.id);
    std::string cfg_text;
    if (it != links_.end()) {
      if (auto model = link_model_from_status(it->second.last)) sensor.link = *model;
    }
    cfg_text = describe_link(link_model_name(sensor.link),
                             std::holds_alternative<BernoulliLink>(sensor.link)
                                 ? std::vector<double>{std::get<BernoulliLink>(sensor.link).loss}
                                 : std::vector<double>{std::get<GilbertElliottLink>(sensor.link).p,
                                                       std::get<GilbertElliottLink>(sensor.link).r,
                                                       std::get<GilbertElliottLink>(sensor.link).loss_good,
                                                       std::get<GilbertElliottLink>(sensor.link).loss_bad});
    const double cfg_rate = 1.0 - stationary_loss(sensor.link);
    const double obs = it != links_.end() ? it->second.observed_rate : -1.0;
    if (obs < 0) all_observed = false;
    observed_rates.push_back(obs < 0 ? cfg_rate : obs);
    char line[200];
    std::snprintf(line, sizeof line, "  %-5d %-52s %6.3f  %6s\n", sensor.id, cfg_text.c_str(), cfg_rate,
                  obs < 0 ? "-" : fmt(obs, true).c_str());
    out << line;
  }

  if (with_theory) {
    // Theory bounds are on the prediction covariance P_{k|k-1} (Sinopoli Thm 4/6);
    // the estimator's Tr P above is P_{k|k}, which is smaller.
    try {
      const auto cfg = analysis::assess_configured_links(configured);
      out << "  theory (configured links): stable=" << analysis::to_string(cfg.stable);
      if (cfg.lower_trace) out << "  Tr S̄=" << fmt(*cfg.lower_trace);
      if (cfg.upper_trace) out << "  Tr V̄=" << fmt(*cfg.upper_trace);
      out << "\n";
      const std::string verdict = analysis::to_string(cfg.stable);
      if (last_configured_verdict_ == "yes" && verdict == "no")
        warnings_.push_back("link change moved the network below the critical arrival rate: " + cfg.reason);
      if (last_configured_verdict_ == "no" && verdict == "yes")
        warnings_.push_back("links are back above the critical arrival rate");
      last_configured_verdict_ = verdict;
      if (all_observed) {
        const auto obs = analysis::assess_operating_point(configured, observed_rates);
        out << "  theory (observed rates, i.i.d.): stable=" << analysis::to_string(obs.stable);
        if (obs.lower_trace) out << "  Tr S̄=" << fmt(*obs.lower_trace);
        if (obs.upper_trace) out << "  Tr V̄=" << fmt(*obs.upper_trace);
        out << "\n";
      }
      out << "  (S̄, V̄ bound E[P_{k|k-1}], Sinopoli Thm 4/6)\n";
    } catch (const std::exception& ex) {
      out << "  theory: unavailable (" << ex.what() << ")\n";
    }
  }
  return out.str();
}

}  // namespace netkf::cli
