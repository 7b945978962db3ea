// The time charts (uPlot): Tr P with the theory band, and each state's truth and estimate ± 2σ,
// over the plotted window; more periods than pixels are drawn as each bucket's envelope.
// Also what every chart and canvas of the page shares: the time axis, the synced cursor and
// the widths that follow their boxes.
import { COLOR } from './constants.js';
import { $, el } from './dom.js';
import { fmt, isNum } from './format.js';
import { dash } from './probe.js';
import { redraw } from './redraw.js';
import { currentTime, store, view, windowPeriods } from './state.js';

const charts = { trace: null, states: [] };
const syncKey = 'netkf-time';
const emptyData = (seriesCount) => Array.from({ length: seriesCount + 1 }, () => []);

// A chart over the plotted window's time (x in seconds) in `box`, as wide as the box.
export function timeChart(box, height, series, scales, hooks, options) {
  const opts = options || {};
  const width = Math.max(200, box.clientWidth || 400);
  const chart = new uPlot({
    width,
    height,
    cursor: { sync: { key: syncKey }, drag: { x: false, y: false }, points: { size: 5 } },
    legend: { show: opts.legend !== false, live: false },
    scales: Object.assign({ x: { time: false, range: () => [view.tLo, view.tHi] } }, scales || {}),
    axes: [
      { stroke: COLOR.axis, grid: { stroke: COLOR.grid, width: 1 }, ticks: { stroke: COLOR.grid }, size: 28,
        font: '11px system-ui, sans-serif', values: (u, splits) => splits.map((v) => v + ' s') },
      { stroke: COLOR.axis, grid: { stroke: COLOR.grid, width: 1 }, ticks: { stroke: COLOR.grid }, size: 52, space: 20,
        font: '11px system-ui, sans-serif', values: opts.yValues || compactTicks },
    ],
    series: [{ label: 't' }, ...series],
    bands: opts.bands,
    hooks: hooks || {},
  }, emptyData(series.length), box);
  observeWidth(box, chart, height);
  return chart;
}

// Charts follow their box's width; the resize runs in the next frame so that
// ResizeObserver never sees a size change made inside its own callback.
// Widths come from the observer, so drawing never forces a layout to read them.
const resizeTargets = new Map();
const knownWidth = new WeakMap();
const resizeObserver = new ResizeObserver((entries) => {
  for (const entry of entries) {
    knownWidth.set(entry.target, Math.floor(entry.contentRect.width));
    const target = resizeTargets.get(entry.target);
    if (target) target.wanted = Math.floor(entry.contentRect.width);
  }
  requestAnimationFrame(() => {
    for (const [box, target] of resizeTargets) {
      if (!box.isConnected) { resizeObserver.unobserve(box); resizeTargets.delete(box); continue; }
      if (target.wanted && target.wanted !== target.chart.width) target.chart.setSize({ width: Math.max(200, target.wanted), height: target.height });
    }
    redraw('links', 'region');
  });
});
function observeWidth(box, chart, height) {
  resizeTargets.set(box, { chart, height, wanted: 0 });
  resizeObserver.observe(box);
}
function widthOf(element) {
  if (!knownWidth.has(element)) {
    resizeObserver.observe(element);
    knownWidth.set(element, element.clientWidth);   // once, until the observer reports
  }
  return knownWidth.get(element);
}

// A canvas as wide as its parent and cssHeight high, cleared, for drawing in CSS pixels.
export function canvasContext(canvas, cssHeight) {
  const ratio = window.devicePixelRatio || 1;
  const width = Math.max(150, widthOf(canvas.parentElement));
  if (canvas.width !== Math.floor(width * ratio) || canvas.height !== Math.floor(cssHeight * ratio)) {
    canvas.width = Math.floor(width * ratio);
    canvas.height = Math.floor(cssHeight * ratio);
    canvas.style.width = width + 'px';
    canvas.style.height = cssHeight + 'px';
  }
  const ctx = canvas.getContext('2d');
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  ctx.clearRect(0, 0, width, cssHeight);
  return { ctx, width, height: cssHeight };
}

export function buildStateCharts(n) {
  for (const chart of charts.states) chart.destroy();
  charts.states = [];
  const box = $('state-charts');
  box.replaceChildren();
  box.dataset.count = String(n);
  for (let c = 0; c < n; c++) {
    const holder = el('div', { class: 'state-chart' }, [el('div', { class: 'subhead', text: 'x' + (c + 1) })]);
    const chartBox = el('div', { class: 'chart' });
    holder.appendChild(chartBox);
    box.appendChild(holder);
    const series = [
      { label: 'truth x', stroke: COLOR.truth, width: 1.25, points: { show: false } },
      { label: store.fuseWithin ? 'in-time x̂' : 'estimate x̂', stroke: COLOR.estimate, width: 1.5, points: { show: false } },
      { label: 'x̂ + 2σ', stroke: COLOR.sigmaEdge, width: 1, points: { show: false } },
      { label: 'x̂ − 2σ', stroke: COLOR.sigmaEdge, width: 1, points: { show: false } },
    ];
    if (store.fuseWithin) series.push({ label: 'final x̂ (revised)', stroke: COLOR.final, width: 1.25, dash: [5, 3], points: { show: false } });
    charts.states.push(timeChart(chartBox, n > 2 ? 120 : 140, series, null, null, { bands: [{ series: [3, 4], fill: COLOR.sigmaBand }] }));
  }
}

// Row annotations of the trace chart for its drawClear hook (theory band, diverging spans).
const traceRows = { theory: [], diverging: [] };

// With late_policy fuse_within the chart also carries the final estimates' Tr P k|k−1 and
// their theory band (each link's arrival rate at the horizon deadline + D periods).
export function buildTraceChart() {
  const box = $('trace-chart');
  if (charts.trace) charts.trace.destroy();
  box.replaceChildren();
  const series = [
    { label: 'Tr P k|k−1', stroke: COLOR.tracePred, width: 1.5, points: { show: false } },
    { label: 'Tr P k|k', stroke: COLOR.traceFiltered, width: 1, points: { show: false } },
    { label: 'Tr S̄ configured', stroke: COLOR.configured, width: 1.5, points: { show: false } },
    { label: 'Tr V̄ configured', stroke: COLOR.configured, width: 1.5, dash: [6, 4], points: { show: false } },
    { label: 'Tr S̄ observed (since change)', stroke: COLOR.observed, width: 1.25, points: { show: false } },
    { label: 'Tr V̄ observed (since change)', stroke: COLOR.observed, width: 1.25, dash: [6, 4], points: { show: false } },
  ];
  if (store.fuseWithin) {
    series.push({ label: 'Tr P k|k−1 final', stroke: COLOR.final, width: 1.25, points: { show: false } },
      { label: 'Tr S̄ final', stroke: COLOR.final, width: 1, dash: [2, 3], points: { show: false } },
      { label: 'Tr V̄ final', stroke: COLOR.final, width: 1, dash: [6, 4], points: { show: false } });
  }
  dash.finalSeries = store.fuseWithin;
  charts.trace = timeChart(box, 190, series, { y: { distr: 3, log: 10 } }, { drawClear: [drawTraceBackground] }, {
    yValues: (u, splits) => splits.map((v) => (v === null ? '' : fmtTick(v))),
  });
}

// Tick labels that fit the 52 px axis whatever the magnitude (a diverging estimate).
function compactTicks(u, splits) {
  return splits.map((v) => {
    if (v === null || v === undefined) return '';
    const a = Math.abs(v);
    if (a !== 0 && (a >= 1e4 || a < 1e-3)) return v.toExponential(0);
    return String(+v.toPrecision(4));
  });
}

function fmtTick(v) {
  if (v >= 1e4 || v < 1e-2) return v.toExponential(0);
  return String(+v.toPrecision(3));
}

// Below the series: shaded periods where the filter said "diverging", and the theory
// band (an unbounded Tr V̄ fills up to the top of the plot).
function drawTraceBackground(u) {
  const xs = u.data[0];
  if (!xs || !xs.length) return;
  const ctx = u.ctx;
  const top = u.bbox.top;
  const bottom = u.bbox.top + u.bbox.height;
  const halfStep = Math.max(1, (u.valToPos(store.periodS, 'x', true) - u.valToPos(0, 'x', true)) / 2);
  ctx.save();
  ctx.beginPath();
  ctx.rect(u.bbox.left, u.bbox.top, u.bbox.width, u.bbox.height);
  ctx.clip();
  const spans = (flagOf, paint) => {
    let start = -1;
    let startKey = null;
    for (let j = 0; j <= xs.length; j++) {
      const key = j < xs.length ? flagOf(j) : null;
      if (key !== startKey) {
        if (start >= 0 && startKey !== null) paint(startKey, u.valToPos(xs[start], 'x', true) - halfStep, u.valToPos(xs[j - 1], 'x', true) + halfStep);
        start = j;
        startKey = key;
      }
    }
  };
  ctx.fillStyle = COLOR.diverging;
  spans((j) => (traceRows.diverging[j] ? 1 : null), (key, x0, x1) => ctx.fillRect(x0, top, x1 - x0, bottom - top));
  const band = (lowerKey, upperKey, validKey, color) => {
    ctx.fillStyle = color;
    spans((j) => {
      const entry = traceRows.theory[j];
      return entry && entry[validKey] && isNum(entry[lowerKey]) ? entry : null;
    }, (entry, x0, x1) => {
      const yLow = Math.min(bottom, u.valToPos(entry[lowerKey], 'y', true));
      const yHigh = isNum(entry[upperKey]) ? Math.max(top, u.valToPos(entry[upperKey], 'y', true)) : top;
      if (yLow > yHigh) ctx.fillRect(x0, yHigh, x1 - x0, yLow - yHigh);
    });
  };
  band('confLower', 'confUpper', 'confValid', COLOR.configuredBand);
  band('obsLower', 'obsUpper', 'obsValid', COLOR.observedBand);
  if (store.fuseWithin) band('finLower', 'finUpper', 'finValid', COLOR.finalBand);
  ctx.restore();
}

// The smallest and largest value of one series in one bucket of periods, in the order
// they occurred: a bucket narrower than a pixel then draws as the stroke it would cover.
class Envelope {
  constructor() { this.reset(); }
  reset() { this.min = Infinity; this.max = -Infinity; this.minAt = 0; this.maxAt = 0; this.any = false; }
  add(v, k) {
    if (v === null) return;
    this.any = true;
    if (v < this.min) { this.min = v; this.minAt = k; }
    if (v > this.max) { this.max = v; this.maxAt = k; }
  }
  emitOne(out) { out.push(this.any ? this.min : null); }
  emitTwo(out) {
    if (!this.any) out.push(null, null);
    else if (this.minAt <= this.maxAt) out.push(this.min, this.max);
    else out.push(this.max, this.min);
  }
}

// The theory band's columns of the trace chart: the entry in force for period k is the last
// one computed at or before k (rows are asked for in increasing k).
class TheoryColumns {
  constructor(theory) {
    this.theory = theory;
    this.index = -1;
    for (const key of ['confLower', 'confUpper', 'obsLower', 'obsUpper', 'finLower', 'finUpper']) this[key] = [];
  }
  push(k) {
    const theory = this.theory;
    while (this.index + 1 < theory.length && theory.at(this.index + 1).k <= k) this.index++;
    const entry = this.index >= 0 ? theory.at(this.index) : null;
    traceRows.theory.push(entry);
    for (const key of ['confLower', 'confUpper', 'obsLower', 'obsUpper', 'finLower', 'finUpper']) {
      this[key].push(entry && isNum(entry[key]) ? entry[key] : null);
    }
  }
}

const num = (v) => (Number.isNaN(v) ? null : v);
const timeOf = (ring, k) => {
  const i = ring.find(k);
  return i >= 0 ? ring.t[i] : k * store.periodS;
};

function showEmptyCharts() {
  view.tLo = 0;
  view.tHi = view.windowS;
  charts.trace.setData(emptyData(charts.trace.series.length - 1));
  for (const chart of charts.states) chart.setData(emptyData(chart.series.length - 1));
  dash.pointsPlotted = 0;
  dash.finalPointsPlotted = 0;
  dash.plotLengths = { trace: 0, states: charts.states.map(() => 0) };
}

export function renderTimeCharts() {
  if (!charts.trace) return;
  const ring = store.ring;
  const w = windowPeriods();
  if (!w) { showEmptyCharts(); return; }
  // The window ends now; until it has filled it starts at the oldest period held.
  const tNow = currentTime();
  view.tHi = tNow;
  view.tLo = Math.max(tNow - view.windowS, Math.min(timeOf(ring, w.kLo), tNow - 1));
  // More periods than pixels: buckets of `stride` periods (aligned to multiples of the
  // stride so they do not shimmer as the window slides), each drawn as its envelope.
  const plotPx = Math.max(100, Math.round(charts.trace.bbox.width / (window.devicePixelRatio || 1)) || 600);
  const stride = Math.max(1, Math.ceil((w.kHi - w.kLo + 1) / plotPx));
  const rows = windowRows(ring, w, stride);
  const { xs, outs, theory, finalBase } = rows;
  const final = store.fuseWithin;
  const traceData = [xs, outs[0], outs[1], theory.confLower, theory.confUpper, theory.obsLower, theory.obsUpper];
  if (final) traceData.push(outs[finalBase], theory.finLower, theory.finUpper);
  charts.trace.setData(traceData);
  charts.states.forEach((chart, c) => {
    const base = 2 + 4 * c;
    const data = [xs, outs[base], outs[base + 1], outs[base + 2], outs[base + 3]];
    if (final) data.push(outs[finalBase + 1 + c]);
    chart.setData(data);
  });
  dash.pointsPlotted = charts.states.length ? rows.estimatePoints : 0;
  dash.finalPointsPlotted = rows.finalPoints;
  Object.assign(dash.plotLengths, {
    trace: charts.trace.data[0].length,
    states: charts.states.map((chart) => chart.data[0].length),
    stride,
  });
  renderTraceNotes();
}

// The charts' columns over window w, a bucket of `stride` periods at a time: series Tr P pred,
// Tr P, then per component truth, x̂, x̂+2σ, x̂−2σ; with fuse_within then the final estimates'
// Tr P pred and per component final x̂ (a period never revised: its in-time one).
function windowRows(ring, w, stride) {
  const finalBase = 2 + 4 * ring.n;
  const seriesCount = finalBase + (store.fuseWithin ? 1 + ring.n : 0);
  const envelopes = Array.from({ length: seriesCount }, () => new Envelope());
  const rows = { xs: [], outs: Array.from({ length: seriesCount }, () => []), theory: new TheoryColumns(store.theory),
    finalBase, estimatePoints: 0, finalPoints: 0 };
  traceRows.theory = [];
  traceRows.diverging = [];
  for (let b = w.kLo - (w.kLo % stride); b <= w.kHi; b += stride) {
    const first = Math.max(b, w.kLo);
    const last = Math.min(b + stride - 1, w.kHi);
    let diverging = false;
    for (const e of envelopes) e.reset();
    for (let k = first; k <= last; k++) {
      const i = ring.find(k);
      if (i >= 0 && addPeriod(rows, envelopes, ring, i, k)) diverging = true;
    }
    if (last === first) {
      rows.xs.push(timeOf(ring, first));
      envelopes.forEach((e, s) => e.emitOne(rows.outs[s]));
      rows.theory.push(first);
      traceRows.diverging.push(diverging);
    } else {
      rows.xs.push(timeOf(ring, first), timeOf(ring, last));
      envelopes.forEach((e, s) => e.emitTwo(rows.outs[s]));
      rows.theory.push(first);
      rows.theory.push(last);
      traceRows.diverging.push(diverging, diverging);
    }
  }
  return rows;
}

// Adds period k (slot i) to its bucket's envelopes; true when the filter said "diverging".
function addPeriod(rows, envelopes, ring, i, k) {
  const n = ring.n;
  const hasEst = ring.hasEstimate[i] === 1;
  if (hasEst) {
    rows.estimatePoints++;
    // A log axis cannot show 0 or negative traces.
    const tp = num(ring.tracePred[i]);
    const tf = num(ring.trace[i]);
    envelopes[0].add(tp !== null && tp > 0 ? tp : null, k);
    envelopes[1].add(tf !== null && tf > 0 ? tf : null, k);
    if (store.fuseWithin) {
      const revised = ring.hasFinal[i] === 1;
      if (revised) rows.finalPoints++;
      const tpf = revised ? num(ring.tracePredFinal[i]) : tp;
      envelopes[rows.finalBase].add(tpf !== null && tpf > 0 ? tpf : null, k);
      for (let c = 0; c < n; c++) envelopes[rows.finalBase + 1 + c].add(num((revised ? ring.xHatFinal : ring.xHat)[c][i]), k);
    }
  }
  for (let c = 0; c < n; c++) {
    const base = 2 + 4 * c;
    if (ring.hasTruth[i]) envelopes[base].add(num(ring.truth[c][i]), k);
    if (!hasEst) continue;
    const x = num(ring.xHat[c][i]);
    const sd = num(ring.sigma[c][i]);
    envelopes[base + 1].add(x, k);
    if (x !== null && sd !== null) {
      envelopes[base + 2].add(x + 2 * sd, k);
      envelopes[base + 3].add(x - 2 * sd, k);
    }
  }
  return hasEst && ring.diverging[i] === 1;
}

function renderTraceNotes() {
  const th = store.latestTheory;
  const box = $('trace-notes');
  const chip = (cls, text) => el('span', { class: 'chip ' + cls, text });
  if (!th) { box.replaceChildren(chip('muted', 'no theory yet')); return; }
  const describe = (a, label, cls) => {
    if (!a) return chip(cls, label + ': not known yet');
    if (!isNum(a.lower_trace)) return chip(cls + ' alarm', label + ': Tr S̄ = ∞ (E[P] unbounded)');
    const upper = isNum(a.upper_trace) ? fmt(a.upper_trace, 3) : (a.stable === 'yes' ? '∞' : '∞ (unbounded or undecided)');
    return chip(cls, label + ': ' + fmt(a.lower_trace, 3) + ' … ' + upper);
  };
  const estimate = store.latestEstimate;
  const items = [describe(th.configured, 'configured', 'configured'),
    describe(th.observed, 'observed (since change)', 'observed')];
  if (store.fuseWithin) items.push(describe(th.final_estimate, 'final estimates (D = ' + store.maxDelayPeriods + ')', 'final'));
  if (estimate && isNum(estimate.trace_P_pred)) items.unshift(chip('pred', 'Tr P k|k−1 = ' + fmt(estimate.trace_P_pred, 3)));
  box.replaceChildren(...items);
}
