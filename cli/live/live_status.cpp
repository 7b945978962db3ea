#include "netkf/cli/live/live_status.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <vector>

#include "netkf/cli/live/observed_rate.hpp"
#include "netkf/links/link_text.hpp"
#include "netkf/theory/report.hpp"

namespace netkf::cli {

namespace {

// Up to this many links (and fused ids) the status lists every one; above, a shortlist.
constexpr std::size_t kStatusLinksListed = 16;
constexpr std::size_t kStatusLinksShortlist = 8;

// Short numbers for the status view: 4 significant digits, or 3 decimals for rates.
std::string fmt(double v, bool fixed3 = false) {
  char buf[48];
  if (fixed3) std::snprintf(buf, sizeof buf, "%.3f", v);
  else std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

std::string rate4(double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.4f", v);
  return buf;
}

// The share of delivered samples that came after their period was fused ("-" before any).
std::string late_share_text(std::uint64_t late, std::uint64_t delivered) {
  return delivered > 0 ? fmt(static_cast<double>(late) / static_cast<double>(delivered), true) : std::string("-");
}

void render_assessment(std::ostringstream& out, const char* label, const AssessmentView& a) {
  out << "  theory (" << label << "): stable=" << theory::to_string(a.result.stable);
  out << "  Tr S̄=" << (a.result.lower_trace ? fmt(*a.result.lower_trace) : std::string("∞"));
  out << "  Tr V̄=" << (a.result.upper_trace ? fmt(*a.result.upper_trace) : std::string("∞"));
  if (a.result.upper_trace && a.result.upper_method == theory::BoundMethod::sampled)
    out << " (sampled ±" << fmt(a.result.upper_standard_error) << ")";
  if (a.result.markov_criterion) out << "  Markov criterion=" << fmt(*a.result.markov_criterion);
  // "unknown" alone does not tell a user whether to wait or why there is no answer.
  if (a.result.stable == theory::Verdict::unknown && !a.result.reason.empty()) out << "  (" << a.result.reason << ")";
  out << "\n";
}

// An observed rate as the status shows it: "0.702 = 740/1054" (since change, with its counts),
// "0.690 over 1043" (the window, with its span), "-" before the first sample.
std::string since_change_text(const LinkView& l) {
  if (!l.observed_rate_since_change) return "-";
  return fmt(*l.observed_rate_since_change, true) + " = " + std::to_string(delivered_in_time(l)) + "/" +
         std::to_string(l.samples_in);
}
std::string window_text(const LinkView& l) {
  if (!l.observed_rate_window) return "-";
  return fmt(*l.observed_rate_window, true) + " over " + std::to_string(l.observed_window_samples);
}

// One line over every link of a large network: the since-change rates' mean and minimum.
void render_all_links(std::ostringstream& out, const LiveSnapshot& s) {
  double observed_sum = 0.0, observed_min = std::numeric_limits<double>::infinity();
  std::size_t observed = 0;
  std::uint64_t late_total = 0, delivered_total = 0;
  for (const auto& l : s.links) {
    late_total += l.late_total;
    delivered_total += l.delivered_total;
    if (!l.observed_rate_since_change) continue;
    ++observed;
    observed_sum += *l.observed_rate_since_change;
    observed_min = std::min(observed_min, *l.observed_rate_since_change);
  }
  out << "  all " << s.links.size() << " links: λ since change mean "
      << (observed ? fmt(observed_sum / static_cast<double>(observed), true) : std::string("-")) << ", min "
      << (observed ? fmt(observed_min, true) : std::string("-")) << "; late " << late_share_text(late_total, delivered_total);
  const std::size_t without_rate = s.links.size() - observed;
  if (without_rate) out << "; " << without_rate << " without a rate yet";
  out << "\n";
}

// Per link: the configured arrival rate (1 − loss) · P(delay <= deadline) and the observed one
// over both windows (observed_rate.hpp). late: the share of the link's delivered samples that
// came after their period was fused. A large network shows the links furthest below their
// configured rate since change (no rate yet counts as furthest) and one line over all;
// `netkf ctl status` and the dashboard list every link.
void render_links(std::ostringstream& out, const LiveSnapshot& s) {
  std::vector<const LinkView*> shown;
  for (const auto& l : s.links) shown.push_back(&l);
  const auto shortfall = [](const LinkView* l) {
    return l->observed_rate_since_change ? l->arrival_rate() - *l->observed_rate_since_change
                                         : std::numeric_limits<double>::infinity();
  };
  const bool shortlisted = shown.size() > kStatusLinksListed;
  if (shortlisted) {
    std::stable_sort(shown.begin(), shown.end(),
                     [&](const LinkView* a, const LinkView* b) { return shortfall(a) > shortfall(b); });
    shown.resize(kStatusLinksShortlist);
  }
  // The window's header names its least span; each row gives the span it covers.
  out << "  link   λ cfg  λ since change (in time/samples)  λ last ≥" << kWindowSamples << " samples   late  configured";
  if (shortlisted)
    out << "   (" << shown.size() << " of " << s.links.size() << " links: those furthest below their rate)";
  out << "\n";
  for (const LinkView* l : shown) {
    char line[512];
    const std::string late = late_share_text(l->late_total, l->delivered_total);
    std::snprintf(line, sizeof line, "  %-5s %6.3f  %-32s  %-20s %6s  %s\n", link_name(l->sensor_id).c_str(), l->arrival_rate(),
                  since_change_text(*l).c_str(), window_text(*l).c_str(), late.c_str(), describe_link(l->link).c_str());
    out << line;
  }
  if (shortlisted) render_all_links(out, s);
}

}  // namespace

std::string describe_recent_fit(const fit::RecentLossFit& f) {
  std::ostringstream out;
  out << "fitted to its last " << f.samples << " samples: ";
  // Its family's name; a simple Gilbert chain (the only fit with memory) also its p and r.
  out << fit::to_string(f.family);
  if (f.family == fit::LossFamily::simple_gilbert)
    for (const auto& [name, value] : link_parameters(f.link))
      if (name == "p" || name == "r") out << " " << name << "=" << rate4(value);
  out << ", loss " << rate4(f.loss()) << ", mean burst "
      << (std::isfinite(f.mean_burst()) ? fmt(f.mean_burst()) : std::string("∞"));
  if (!f.aic_gain) out << " (no chain: a transition out of both states not seen yet)";
  else if (f.family == fit::LossFamily::simple_gilbert) out << " (bursty: AIC " << fmt(*f.aic_gain) << " below bernoulli)";
  else out << " (drops look independent: a chain does not lower AIC by more than 2)";
  return out.str();
}

std::string render_link_table(const std::vector<LinkStatus>& links) {
  std::ostringstream out;
  char line[512];
  // printf pads bytes, not glyphs: a header with "λ" (2 bytes) gets one more byte of width.
  // A relayed topic's name is wider than a sensor id: the first column takes the widest.
  int name_width = 6;
  for (const auto& l : links) name_width = std::max(name_width, static_cast<int>(std::min<std::size_t>(l.name().size(), 64)));
  std::snprintf(line, sizeof line, "%-*s %10s %8s %17s %10s %10s %10s %10s %9s %7s %7s %6s  %s\n", name_width, "link", "P(in time)",
                "λ cfg", "λ since change", "samples", "delivered", "in time", "dropped", "obs loss", "burst", "late",
                "held", "link");
  out << line;
  for (const auto& l : links) {
    // late: the share of delivered samples the channel delayed beyond the estimator's deadline.
    const double late = l.delivered > 0 ? static_cast<double>(l.past_deadline) / static_cast<double>(l.delivered) : 0.0;
    const auto since_change = observed_rate_since_change(l);
    std::snprintf(line, sizeof line, "%-*s %10.4f %7.4f %16s %10llu %10llu %10llu %10llu %9.4f %7.3f %7.4f %6llu  %s\n",
                  name_width, l.name().c_str(), l.in_time, l.arrival_rate(), since_change ? rate4(*since_change).c_str() : "-",
                  static_cast<unsigned long long>(l.samples_in), static_cast<unsigned long long>(l.delivered),
                  static_cast<unsigned long long>(delivered_in_time(l)), static_cast<unsigned long long>(l.dropped),
                  l.observed_loss, l.mean_burst_length, late, static_cast<unsigned long long>(l.held),
                  describe_link(l.link).c_str());
    out << line;
    if (l.recent_fit) out << "       " << describe_recent_fit(*l.recent_fit) << "\n";
    if (!l.rejection_reason.empty())
      out << "       last request " << l.last_request_id << " rejected: " << l.rejection_reason << "\n";
  }
  out << "samples to late: since the link's model was set; λ since change = in time / samples (the observed arrival "
         "rate); λ cfg = (1 − loss) · P(in time)\n";
  return out.str();
}

std::string render_status(const LiveSnapshot& s, bool theory_pending) {
  std::ostringstream out;
  if (s.period) {
    const Estimate& p = s.period->estimate;
    out << "period " << p.k << "  t=" << fmt(p.t) << "s  state=" << to_string(p.state) << "  Tr P_k|k=" << fmt(p.trace_P())
        << "  Tr P_k|k-1=" << fmt(p.trace_P_pred) << " (mean " << fmt(s.mean_trace_P_pred) << ")";
    if (s.error_norm) out << "  |x-x̂|=" << fmt(*s.error_norm) << " (rms " << fmt(*s.rms_error) << ")";
    out << "  fused=";
    if (p.fused.size() > kStatusLinksListed) {  // 512 ids would fill the terminal every second
      out << p.fused.size() << "/" << s.links.size();
    } else {
      for (std::size_t i = 0; i < p.fused.size(); ++i) out << (i ? ";" : "") << p.fused[i];
      if (p.fused.empty()) out << "-";
    }
    out << "  late=" << s.late_total << " rejected=" << s.rejected_total;
    if (s.mean_cost) out << "  cost=" << fmt(*s.mean_cost);
    if (s.estimator_restarts)
      out << "  estimator restarts=" << s.estimator_restarts << " (" << s.restart_gap_periods << " periods open-loop)";
    out << "\n";
  } else {
    out << "waiting for the first estimate...\n";
  }
  render_links(out, s);
  if (!s.theory.ready) {
    out << "  theory: pending (being computed)\n";
  } else {
    render_assessment(out, "configured links", s.theory.configured);
    if (s.theory.observed) render_assessment(out, "observed rates since change, i.i.d.", *s.theory.observed);
    if (s.theory.final_estimate) render_assessment(out, "final estimates, late_policy fuse_within", *s.theory.final_estimate);
    out << "  (S̄, V̄ bound E[P_k|k-1], Sinopoli Thm 4/6" << (theory_pending ? "; update pending" : "") << ")\n";
  }
  return out.str();
}

std::string render_status_screen(const std::string& header, const LiveSnapshot& snapshot, bool theory_pending,
                                 const std::vector<std::string>& events) {
  std::ostringstream out;
  out << "\x1b[H\x1b[2J" << header << "\n\n" << render_status(snapshot, theory_pending);
  if (!events.empty()) {
    out << "\nevents:\n";
    for (const auto& e : events) out << "  " << e << "\n";
  }
  return out.str();
}

}  // namespace netkf::cli
