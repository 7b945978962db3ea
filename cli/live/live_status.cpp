#include "live_status.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <vector>

#include "netkf/analysis/report.hpp"

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

// The share of delivered samples that came after their period was fused ("-" before any).
std::string late_share_text(std::uint64_t late, std::uint64_t delivered) {
  return delivered > 0 ? fmt(static_cast<double>(late) / static_cast<double>(delivered), true) : std::string("-");
}

void render_assessment(std::ostringstream& out, const char* label, const AssessmentView& a) {
  out << "  theory (" << label << "): stable=" << analysis::to_string(a.result.stable);
  out << "  Tr S̄=" << (a.result.lower_trace ? fmt(*a.result.lower_trace) : std::string("∞"));
  out << "  Tr V̄=" << (a.result.upper_trace ? fmt(*a.result.upper_trace) : std::string("∞"));
  if (a.result.markov_criterion) out << "  Markov criterion=" << fmt(*a.result.markov_criterion);
  // "unknown" alone does not tell a user whether to wait or why there is no answer.
  if (a.result.stable == analysis::Verdict::unknown && !a.result.reason.empty()) out << "  (" << a.result.reason << ")";
  out << "\n";
}

}  // namespace

std::string render_link_table(const std::vector<LinkStatusRecord>& links) {
  std::ostringstream out;
  char line[256];
  // late: the share of delivered samples the channel delayed beyond the estimator's deadline.
  std::snprintf(line, sizeof line, "%-6s %8s %8s %10s %10s %10s %9s %7s %7s %6s  %s\n", "link", "in time", "eff λ",
                "samples", "delivered", "dropped", "obs loss", "burst", "late", "held", "link");
  out << line;
  for (const auto& l : links) {
    // eff λ: the arrival rate the estimator gets, (1 − loss) · P(delay <= deadline).
    const double late = l.delivered > 0 ? static_cast<double>(l.past_deadline) / static_cast<double>(l.delivered) : 0.0;
    std::snprintf(line, sizeof line, "%-6d %8.4f %8.4f %10llu %10llu %10llu %9.4f %7.3f %7.4f %6llu  %s\n", l.sensor_id,
                  l.in_time, l.arrival_rate(),
                  static_cast<unsigned long long>(l.samples_in), static_cast<unsigned long long>(l.delivered),
                  static_cast<unsigned long long>(l.dropped), l.observed_loss, l.mean_burst_length, late,
                  static_cast<unsigned long long>(l.held), describe_link(l.link).c_str());
    out << line;
    if (!l.rejection_reason.empty())
      out << "       last request " << l.last_request_id << " rejected: " << l.rejection_reason << "\n";
  }
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
    if (s.estimator_restarts)
      out << "  estimator restarts=" << s.estimator_restarts << " (" << s.restart_gap_periods << " periods open-loop)";
    out << "\n";
  } else {
    out << "waiting for the first estimate...\n";
  }
  // Per link: configured (effective: (1 − loss) · P(delay <= deadline)) and observed arrival rate.
  // late: the share of the link's delivered samples that came after their period was fused.
  // A large network shows the links furthest below their configured rate (no rate yet counts
  // as furthest) and one line over all; `netkf ctl status` and the dashboard list every link.
  std::vector<const LinkView*> shown;
  for (const auto& l : s.links) shown.push_back(&l);
  const auto shortfall = [](const LinkView* l) {
    return l->observed_arrival_rate ? l->arrival_rate() - *l->observed_arrival_rate
                                    : std::numeric_limits<double>::infinity();
  };
  const bool shortlisted = shown.size() > kStatusLinksListed;
  if (shortlisted) {
    std::stable_sort(shown.begin(), shown.end(),
                     [&](const LinkView* a, const LinkView* b) { return shortfall(a) > shortfall(b); });
    shown.resize(kStatusLinksShortlist);
  }
  out << "  link   λ cfg   λ obs    late  configured";
  if (shortlisted)
    out << "   (" << shown.size() << " of " << s.links.size() << " links: those furthest below their rate)";
  out << "\n";
  for (const LinkView* l : shown) {
    char line[256];
    const std::string late = late_share_text(l->late_total, l->delivered_total);
    std::snprintf(line, sizeof line, "  %-5d %6.3f  %6s  %6s  %s\n", l->sensor_id, l->arrival_rate(),
                  l->observed_arrival_rate ? fmt(*l->observed_arrival_rate, true).c_str() : "-", late.c_str(),
                  describe_link(l->link).c_str());
    out << line;
  }
  if (shortlisted) {
    double observed_sum = 0.0, observed_min = std::numeric_limits<double>::infinity();
    std::size_t observed = 0;
    std::uint64_t late_total = 0, delivered_total = 0;
    for (const auto& l : s.links) {
      late_total += l.late_total;
      delivered_total += l.delivered_total;
      if (!l.observed_arrival_rate) continue;
      ++observed;
      observed_sum += *l.observed_arrival_rate;
      observed_min = std::min(observed_min, *l.observed_arrival_rate);
    }
    out << "  all " << s.links.size() << " links: λ obs mean "
        << (observed ? fmt(observed_sum / static_cast<double>(observed), true) : std::string("-")) << ", min "
        << (observed ? fmt(observed_min, true) : std::string("-")) << "; late "
        << late_share_text(late_total, delivered_total);
    const std::size_t without_rate = s.links.size() - observed;
    if (without_rate) out << "; " << without_rate << " without a rate yet";
    out << "\n";
  }
  if (!s.theory.ready) {
    out << "  theory: pending (being computed)\n";
  } else {
    render_assessment(out, "configured links", s.theory.configured);
    if (s.theory.observed) render_assessment(out, "observed rates, i.i.d.", *s.theory.observed);
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
