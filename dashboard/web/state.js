// What the page holds of the run: the periods' estimates and truth (a ring over the longest
// window), the theory's history, the latest scenario, estimate and network, the links; and
// the plotted window. A period going back far means the run restarted: the plots start over.
import { CONTROL_LINK_ID } from './constants.js';
import { addEvent } from './events.js';
import { isNum } from './format.js';
import { dash } from './probe.js';
import { markDirty, redraw, redrawAll } from './redraw.js';

const WINDOW_CHOICES_S = [10, 30, 120];
const MAX_WINDOW_S = Math.max(...WINDOW_CHOICES_S);
const MAX_PERIODS = 30000;        // ring bound even for very short periods
const THEORY_SAMPLES = 600;       // theory ~1/s
const REGION_TRAIL = 60;          // last observed operating points drawn as a trail
const RESTART_GAP = 50;           // k going back by more than this: the run restarted

// One slot per period, indexed by k modulo the capacity; estimate and truth of the same
// period may arrive in either order and meet in the slot.
class PeriodRing {
  constructor(capacity, stateDim, sensorCount) {
    this.cap = capacity;
    this.n = stateDim;
    this.m = sensorCount;
    this.k = new Float64Array(capacity);
    this.t = new Float64Array(capacity);
    this.hasEstimate = new Uint8Array(capacity);
    this.hasTruth = new Uint8Array(capacity);
    this.diverging = new Uint8Array(capacity);
    this.tracePred = new Float64Array(capacity);
    this.trace = new Float64Array(capacity);
    // The final estimate of a period: its last revision (late_policy fuse_within).
    this.revision = new Uint16Array(capacity);
    this.hasFinal = new Uint8Array(capacity);
    this.tracePredFinal = new Float64Array(capacity);
    this.xHatFinal = [];
    this.xHat = [];
    this.sigma = [];
    this.truth = [];
    for (let i = 0; i < stateDim; i++) {
      this.xHat.push(new Float64Array(capacity));
      this.xHatFinal.push(new Float64Array(capacity));
      this.sigma.push(new Float64Array(capacity));
      this.truth.push(new Float64Array(capacity));
    }
    this.fused = [];   // per sensor index: 1 fused, 0 not fused in that period
    for (let s = 0; s < sensorCount; s++) this.fused.push(new Uint8Array(capacity));
    this.clear();
  }
  clear() {
    this.k.fill(-1);
    this.hasEstimate.fill(0);
    this.hasTruth.fill(0);
    this.hasFinal.fill(0);
    this.maxK = -1;
    this.firstK = Infinity;   // oldest period received since the last clear
  }
  // Slot of period k, or -1 when k is older than what the ring holds.
  slot(k) {
    if (this.maxK >= 0 && k <= this.maxK - this.cap) return -1;
    const i = k % this.cap;
    if (this.k[i] !== k) {
      if (this.k[i] > k) return -1;
      this.k[i] = k;
      this.hasEstimate[i] = 0;
      this.hasTruth[i] = 0;
      this.hasFinal[i] = 0;
    }
    if (k > this.maxK) this.maxK = k;
    if (k < this.firstK) this.firstK = k;
    return i;
  }
  // Index of period k if the ring holds it, else -1.
  find(k) {
    const i = k % this.cap;
    return this.k[i] === k ? i : -1;
  }
}

// Fixed-size ring of plain records (theory, link status samples, region trail).
export class RecordRing {
  constructor(capacity) { this.cap = capacity; this.items = []; this.start = 0; }
  push(item) {
    if (this.items.length < this.cap) this.items.push(item);
    else { this.items[this.start] = item; this.start = (this.start + 1) % this.cap; }
  }
  clear() { this.items = []; this.start = 0; }
  get length() { return this.items.length; }
  at(i) { return this.items[(this.start + i) % this.items.length]; }
  last() { return this.items.length ? this.at(this.items.length - 1) : null; }
  forEach(fn) { for (let i = 0; i < this.items.length; i++) fn(this.at(i), i); }
}

export const store = {
  scenario: null,
  scenarioKey: '',
  periodS: 0.02,
  sensorIds: [],
  sensorIndex: new Map(),
  ring: null,
  theory: new RecordRing(THEORY_SAMPLES),   // {k, confLower, confUpper, obsLower, obsUpper, finLower, finUpper}
  fuseWithin: false,                        // late_policy fuse_within: revised estimates follow
  maxDelayPeriods: 0,                       // D
  latestEstimate: null,
  latestTheory: null,
  latestNetwork: null,
  links: new Map(),                         // sensor id -> its card (link_cards.js)
  tableMode: false,                         // more than CARD_LINK_LIMIT links: a table and one card
  selectedLink: null,                       // table mode: the id whose card is shown
  regionTrail: new RecordRing(REGION_TRAIL),
};

// The plotted time window [tLo, tHi] (seconds) and its chosen length.
export const view = { windowS: 30, tLo: 0, tHi: 30 };

// Takes netkf/scenario; true when it is another scenario than the one held (the rings start
// over and the page is to be built anew), false for the same one again.
export function takeScenario(s) {
  const sensors = Array.isArray(s.sensors) ? s.sensors : [];
  const key = JSON.stringify([s.name, s.period_ms, s.state_dim, s.seed, s.late_policy, s.max_delay_periods,
    sensors.map((x) => [x.id, x.measurement_dim])]);
  store.scenario = s;
  if (key === store.scenarioKey) return false;
  store.scenarioKey = key;
  store.periodS = isNum(s.period_ms) && s.period_ms > 0 ? s.period_ms / 1000 : 0.02;
  store.sensorIds = sensors.map((x) => x.id);
  store.sensorIndex = new Map(store.sensorIds.map((id, i) => [id, i]));
  const capacity = Math.min(MAX_PERIODS, Math.ceil(MAX_WINDOW_S / store.periodS) + 16);
  store.ring = new PeriodRing(capacity, Math.max(1, s.state_dim | 0), sensors.length);
  store.fuseWithin = s.late_policy === 'fuse_within';
  store.maxDelayPeriods = isNum(s.max_delay_periods) ? s.max_delay_periods : 0;
  store.theory.clear();
  store.regionTrail.clear();
  store.latestTheory = null;
  return true;
}

// A revised estimate (late_policy fuse_within) of a period the ring holds: its final estimate.
function onRevisedEstimate(e) {
  dash.revisionsReceived++;
  const ring = store.ring;
  if (!ring || !isNum(e.k)) return;
  const i = ring.find(e.k);
  if (i < 0 || !ring.hasEstimate[i] || e.revision < ring.revision[i]) return;
  ring.revision[i] = Math.min(e.revision, 65535);
  ring.hasFinal[i] = 1;
  ring.tracePredFinal[i] = isNum(e.trace_P_pred) ? e.trace_P_pred : NaN;
  const xHat = e.x_hat || [];
  for (let c = 0; c < ring.n; c++) ring.xHatFinal[c][i] = isNum(xHat[c]) ? xHat[c] : NaN;
  dash.recentRevisions.push({ k: e.k, revision: e.revision, x_hat: xHat });
  if (dash.recentRevisions.length > 20) dash.recentRevisions.shift();
  redraw('data');
}

export function onEstimate(e) {
  if (isNum(e.revision) && e.revision > 0) { onRevisedEstimate(e); return; }
  dash.estimatesReceived++;
  dash.lastK = e.k;
  store.latestEstimate = e;
  markDirty('header');
  const ring = store.ring;
  if (!ring || !isNum(e.k)) return;
  if (ring.maxK >= 0 && e.k + RESTART_GAP < ring.maxK) {
    const previous = ring.maxK;
    clearData();
    addEvent({ level: 'page', message: 'period went back from ' + previous + ' to ' + e.k + ': plots restarted' });
  }
  const i = ring.slot(e.k);
  if (i < 0) return;
  ring.hasEstimate[i] = 1;
  ring.hasFinal[i] = 0;
  ring.revision[i] = 0;
  ring.t[i] = isNum(e.t) ? e.t : e.k * store.periodS;
  ring.tracePred[i] = isNum(e.trace_P_pred) ? e.trace_P_pred : NaN;
  ring.trace[i] = isNum(e.trace_P) ? e.trace_P : NaN;
  ring.diverging[i] = e.state === 'diverging' ? 1 : 0;
  const n = ring.n;
  const xHat = e.x_hat || [];
  const P = e.P || [];
  for (let c = 0; c < n; c++) {
    ring.xHat[c][i] = isNum(xHat[c]) ? xHat[c] : NaN;
    const variance = P[c * n + c];
    ring.sigma[c][i] = isNum(variance) ? Math.sqrt(Math.max(0, variance)) : NaN;
  }
  for (let s = 0; s < ring.m; s++) ring.fused[s][i] = 0;
  for (const id of e.fused || []) {
    const s = store.sensorIndex.get(id);
    if (s !== undefined) ring.fused[s][i] = 1;
  }
  redraw('data');
}

export function onTruth(m) {
  dash.truthReceived++;
  const ring = store.ring;
  if (!ring || !isNum(m.k)) return;
  const i = ring.slot(m.k);
  if (i < 0) return;
  ring.hasTruth[i] = 1;
  if (!ring.hasEstimate[i]) ring.t[i] = isNum(m.t) ? m.t : m.k * store.periodS;
  const x = m.x || [];
  for (let c = 0; c < ring.n; c++) ring.truth[c][i] = isNum(x[c]) ? x[c] : NaN;
  redraw('data');
}

export function onTheory(th) {
  store.latestTheory = th;
  const conf = th.configured || null;
  const obs = th.observed || null;
  const fin = th.final_estimate || null;
  const band = (a) => (a ? { stable: a.stable, lower: a.lower_trace, upper: a.upper_trace } : null);
  dash.theoryBands = { configured: band(conf), final: band(fin) };
  const control = store.links.get(CONTROL_LINK_ID);
  if (control) control.showActuationTheory(conf && conf.actuation, obs && obs.actuation);
  store.theory.push({
    k: isNum(th.k) ? th.k : (store.ring ? store.ring.maxK : 0),
    confLower: conf ? conf.lower_trace : null,
    confUpper: conf ? conf.upper_trace : null,
    confValid: !!conf,
    obsLower: obs ? obs.lower_trace : null,
    obsUpper: obs ? obs.upper_trace : null,
    obsValid: !!obs,
    finLower: fin ? fin.lower_trace : null,
    finUpper: fin ? fin.upper_trace : null,
    finValid: !!fin,
  });
  redraw('theory', 'region', 'data');
}

export function onNetwork(nw) {
  store.latestNetwork = nw;
  redraw('network', 'header');
}

// The time of the newest period held, or null before the first.
export function currentTime() {
  const ring = store.ring;
  if (!ring || ring.maxK < 0) return null;
  const i = ring.find(ring.maxK);
  return i >= 0 ? ring.t[i] : ring.maxK * store.periodS;
}

// Periods [kLo, kHi] of the selected window that the ring holds.
export function windowPeriods() {
  const ring = store.ring;
  if (!ring || ring.maxK < 0) return null;
  const span = Math.max(1, Math.round(view.windowS / store.periodS));
  const kHi = ring.maxK;
  const kLo = Math.max(kHi - span + 1, ring.firstK, kHi - ring.cap + 1, 0);
  return { kLo, kHi, span };
}

// The Clear button and a restart: the plots and histories start over.
export function clearData() {
  if (store.ring) store.ring.clear();
  store.theory.clear();
  store.regionTrail.clear();
  for (const link of store.links.values()) link.rates.clear();
  redrawAll();
}
