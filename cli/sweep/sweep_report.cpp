#include "sweep_report.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

namespace netkf::cli::sweep {
namespace {

using nlohmann::json;

json number(const std::optional<double>& v) { return v && std::isfinite(*v) ? json(*v) : json(nullptr); }

// The data the page's script plots: the points' keys, stats per quantity and theory.
json report_json(const ReportData& d) {
  json j;
  j["scenario"] = d.scenario;
  j["mode"] = d.mode;
  j["seeds"] = d.seeds;
  j["keys"] = json::array();
  for (const auto& v : d.vary) j["keys"].push_back(v.key);
  j["quantities"] = d.quantities;
  j["points"] = json::array();
  for (const auto& p : d.grid) {
    json point{{"index", p.index}, {"values", p.values}, {"stats", json::array()}};
    for (std::size_t q = 0; q < d.quantities.size(); ++q) {
      const Stats s = point_stats(p.index, q, d.rows);
      point["stats"].push_back({number(s.mean), number(s.se), number(s.min), number(s.max), s.n});
    }
    const Theory& t = d.theory[static_cast<std::size_t>(p.index)];
    point["theory"] = {{"stable", t.stable ? json(*t.stable) : json(nullptr)},
                       {"trace_S_bar", number(t.trace_S_bar)},
                       {"trace_V_bar", number(t.trace_V_bar)},
                       {"critical_margin", number(t.critical_margin)},
                       {"trace_P_sampled", number(t.trace_P_sampled)},
                       {"trace_P_sampled_se", number(t.trace_P_sampled_se)}};
    j["points"].push_back(std::move(point));
  }
  return j;
}

// "</" cannot appear inside a <script> element: JSON allows "<\/" for it.
std::string script_safe(std::string text) {
  for (std::size_t pos = 0; (pos = text.find("</", pos)) != std::string::npos; pos += 3) text.replace(pos, 2, "<\\/");
  return text;
}

// Library code: only a literal "</script" would end the element early.
std::string script_safe_js(std::string text) {
  for (std::size_t pos = 0; (pos = text.find("</script", pos)) != std::string::npos; pos += 3) text.replace(pos, 2, "<\\/");
  return text;
}

constexpr const char* kStyle = R"(
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }
h2 { margin-top: 1.6em; font-size: 1.1em; }
.plots { display: flex; flex-wrap: wrap; gap: 1em; }
.plot { border: 1px solid #ddd; padding: .4em; }
table { border-collapse: collapse; font-size: .9em; }
td, th { border: 1px solid #ccc; padding: .2em .5em; text-align: right; }
.note { color: #555; font-size: .9em; max-width: 60em; }
)";

// Builds the plots from DATA: for quantity q and key k, x = k's values, one curve per
// combination of the other keys' values (mean, ±se band, min/max dashed).
constexpr const char* kScript = R"(
const at = (p, f) => p == null ? null : f(p);
// The theory on mean_trace_P_pred (Tr P_k|k-1, what it speaks of): Sinopoli's [Tr S̄, Tr V̄]
// where every link is Bernoulli; with links that have memory the simulated E[Tr P] ± 2
// standard errors (an estimate, not a bound).
const addTheory = (pts, xs, data, series, bands) => {
  const S = xs.map((_, i) => at(pts[i], p => p.theory.trace_S_bar));
  const V = xs.map((_, i) => at(pts[i], p => p.theory.trace_V_bar));
  if (S.some(v => v != null) || V.some(v => v != null)) {
    const tb = data.length;
    data.push(V, S);
    series.push({ label: 'theory Tr V̄', stroke: '#444', dash: [8, 3] }, { label: 'theory Tr S̄', stroke: '#444', dash: [2, 3] });
    bands.push({ series: [tb, tb + 1], fill: '#8882' });
  }
  const E = xs.map((_, i) => at(pts[i], p => p.theory.trace_P_sampled));
  if (E.some(v => v != null)) {
    const tb = data.length, two = (i, s) => at(pts[i], p => p.theory.trace_P_sampled == null ? null :
                                                           p.theory.trace_P_sampled + 2 * s * (p.theory.trace_P_sampled_se || 0));
    data.push(E, xs.map((_, i) => two(i, 1)), xs.map((_, i) => two(i, -1)));
    series.push({ label: 'theory E[Tr P] (sampled)', stroke: '#444', dash: [6, 2, 2, 2] },
                { label: '+2se', stroke: '#444', width: 0.5 }, { label: '-2se', stroke: '#444', width: 0.5 });
    bands.push({ series: [tb + 1, tb + 2], fill: '#8882' });
  }
};
(function () {
  const D = JSON.parse(document.getElementById('sweep-data').textContent);
  const colors = ['#1f77b4', '#d62728', '#2ca02c', '#9467bd', '#ff7f0e', '#8c564b', '#e377c2', '#17becf'];
  const el = (tag, text) => { const e = document.createElement(tag); if (text !== undefined) e.textContent = text; return e; };
  const root = document.getElementById('plots');
  const numeric = vals => vals.every(v => v.trim() !== '' && isFinite(Number(v)));
  D.keys.forEach((key, k) => {
    const xsText = [...new Set(D.points.map(p => p.values[k]))];
    const isNum = numeric(xsText);
    if (isNum) xsText.sort((a, b) => Number(a) - Number(b));
    const xs = xsText.map((v, i) => isNum ? Number(v) : i);
    const groups = new Map();  // other keys' values -> points in x order
    D.points.forEach(p => {
      const label = D.keys.map((o, i) => i === k ? null : o + '=' + p.values[i]).filter(s => s).join(', ') || 'mean over seeds';
      if (!groups.has(label)) groups.set(label, new Array(xs.length).fill(null));
      groups.get(label)[xsText.indexOf(p.values[k])] = p;
    });
    root.appendChild(el('h2', 'against ' + key));
    const box = el('div'); box.className = 'plots'; root.appendChild(box);
    // The theory's critical margin (1 - Markov criterion; > 0 stable), one curve per group.
    const margin = [xs], mseries = [{ label: key }];
    let gm = 0;
    groups.forEach((pts, label) => {
      const m = xs.map((_, i) => pts[i] == null ? null : pts[i].theory.critical_margin);
      if (m.some(v => v != null)) {
        margin.push(m);
        mseries.push({ label: label + ' margin', stroke: colors[gm++ % colors.length], width: 2, points: { show: true } });
      }
    });
    if (margin.length > 1) {
      margin.push(xs.map(() => 0));
      mseries.push({ label: 'stability edge', stroke: '#c00', dash: [6, 4] });
      const div = el('div'); div.className = 'plot'; box.appendChild(div);
      new uPlot({ title: 'theory: critical margin (1 - Markov criterion)', width: 560, height: 300, series: mseries,
                  scales: { x: { time: false } }, axes: [{ label: key, values: (u, vs) => vs.map(v => isNum ? v : (xsText[v] ?? '')) }, {}] },
                margin, div);
    }
    D.quantities.forEach((q, qi) => {
      const data = [xs], series = [{ label: key, value: (u, v) => v == null ? '' : (isNum ? v : xsText[v]) }], bands = [];
      let g = 0, any = false;
      groups.forEach((pts, label) => {
        const c = colors[g++ % colors.length];
        const st = i => at(pts[i], p => p.stats[qi]);
        const mean = xs.map((_, i) => at(st(i), s => s[0]));
        if (mean.some(v => v != null)) any = true;
        const lo = xs.map((_, i) => at(st(i), s => s[0] == null ? null : s[0] - (s[1] || 0)));
        const hi = xs.map((_, i) => at(st(i), s => s[0] == null ? null : s[0] + (s[1] || 0)));
        const base = data.length;
        data.push(mean, hi, lo, xs.map((_, i) => at(st(i), s => s[2])), xs.map((_, i) => at(st(i), s => s[3])));
        series.push({ label: label + ' mean', stroke: c, width: 2, points: { show: true } },
                    { label: '+se', stroke: c, width: 0.5 }, { label: '-se', stroke: c, width: 0.5 },
                    { label: 'min', stroke: c, dash: [4, 4], width: 1 }, { label: 'max', stroke: c, dash: [4, 4], width: 1 });
        bands.push({ series: [base + 1, base + 2], fill: c + '33' });
        if (q === 'mean_trace_P_pred') addTheory(pts, xs, data, series, bands);
      });
      if (!any) return;  // nothing measured (e.g. latency offline)
      const div = el('div'); div.className = 'plot'; box.appendChild(div);
      new uPlot({ title: q, width: 560, height: 300, series, bands,
                  scales: { x: { time: false } }, axes: [{ label: key, values: (u, vs) => vs.map(v => isNum ? v : (xsText[v] ?? '')) }, {}] },
                data, div);
    });
  });
  const table = document.getElementById('points');
  const head = el('tr');
  ['point', ...D.keys, 'seeds', 'theory stable', 'Tr S̄', 'Tr V̄', 'critical margin', 'E[Tr P] sampled', '± se'].forEach(h => head.appendChild(el('th', h)));
  table.appendChild(head);
  const fmt = v => v == null ? '' : (typeof v === 'number' ? Number(v.toPrecision(6)).toString() : String(v));
  D.points.forEach(p => {
    const tr = el('tr');
    [p.index, ...p.values, p.stats.length ? p.stats[0][4] : 0, p.theory.stable, p.theory.trace_S_bar, p.theory.trace_V_bar,
     p.theory.critical_margin, p.theory.trace_P_sampled, p.theory.trace_P_sampled_se].forEach(v => tr.appendChild(el('td', fmt(v))));
    table.appendChild(tr);
  });
})();
)";

std::string escape_html(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else out += c;
  }
  return out;
}

}  // namespace

std::string render_report(const ReportData& data, std::string_view uplot_js, std::string_view uplot_css) {
  std::string html = "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>netkf sweep: " +
                     escape_html(data.scenario) + "</title>\n<style>\n";
  html += uplot_css;
  html += kStyle;
  html += "</style>\n<script>\n";
  html += script_safe_js(std::string(uplot_js));
  html += "\n</script>\n</head><body>\n<h1>netkf sweep: " + escape_html(data.scenario) + "</h1>\n";
  html += "<p class=\"note\">" + escape_html(data.mode) + " runs, " + std::to_string(data.seeds) +
          " seed(s) per point. Each plot: the mean over the seeds (points), a band of &plusmn; one standard "
          "error, min and max dashed. On mean_trace_P_pred (Tr P<sub>k|k&minus;1</sub>) the grey band is the "
          "theory's [Tr S&#772;, Tr V&#772;], the bounds on lim E[P<sub>k|k&minus;1</sub>] (Sinopoli Thm 4), where the "
          "analysis gives them (every link Bernoulli); with links that have memory (Gilbert-Elliott) it is "
          "the SAMPLED E[Tr P<sub>k|k&minus;1</sub>] &plusmn; two standard errors, simulated over the links' own "
          "loss sequences: an estimate, not a bound. Critical margin: 1 &minus; the Markov criterion "
          "(&gt; 0: stable by the multi-sensor Markov criterion, Thm 7/9), plotted first against each key.</p>\n";
  html += "<div id=\"plots\"></div>\n<h2>Points and theory</h2>\n<table id=\"points\"></table>\n";
  html += "<script type=\"application/json\" id=\"sweep-data\">" + script_safe(report_json(data).dump()) + "</script>\n";
  html += "<script>" + std::string(kScript) + "</script>\n</body></html>\n";
  return html;
}

}  // namespace netkf::cli::sweep
