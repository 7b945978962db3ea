// The link cards: each link's controls (model, loss, burst, delay: one setParameters per
// change, answered or given up), its status figures, arrival-rate chart and burst-length
// histogram. Above CARD_LINK_LIMIT links only the card selected in the link table is shown;
// every link keeps its status and arrival-rate history.
import { CARD_LINK_LIMIT, COLOR, CONTROL_LINK_ID, LINK_MODELS, linkName, MODEL_LABEL, modelKeys, OBSERVED_WINDOW_SAMPLES,
  WINDOW_KEY } from './constants.js';
import { canvasContext, timeChart } from './charts.js';
import { setParameters } from './connection.js';
import { $, el } from './dom.js';
import { fmt, isNum, rateText } from './format.js';
import { dash } from './probe.js';
import { redraw } from './redraw.js';
import { currentTime, RecordRing, store, view, windowPeriods } from './state.js';

const LINK_SAMPLES = 600;         // link status ~1/s: 10 min of arrival-rate history
const LINK_SAMPLES_TABLE = 120;   // arrival-rate history per link in table mode: 2 min at ~1/s
const DISTRIBUTIONS = ['uniform', 'normal', 'pareto', 'paretonormal'];
const WORD_KEYS = ['model', 'delay_distribution'];
const LINK_PARAMETER = /^link\.(-?\d+|control)\.(\w+)$/;
// The one model the page knows by name, for math of its own: the Gilbert-Elliott chain has a
// user's form (loss and mean burst: the simple Gilbert channel) and the statistics
// gilbertStats computes before the server answers. Everything else about a model (its label,
// its keys, which rows it shows) comes from the server's catalogue (constants.js, LINK_MODELS).
const GILBERT = 'gilbert_elliott';
const USER_FORM = ['loss', 'mean_burst'];
// Used when the user switches a link to a model it has no values for yet, over the values
// of the catalogue's example of each model (the model keys none of these name).
const DEFAULT_PARAMS = { loss: 0, mean_burst: 1, delay_ms: 0, jitter_ms: 0, delay_distribution: 'uniform' };
// The number rows of a link card, in order: a model shows the rows of its keys (and the
// Gilbert chain its user's form too), the delay rows show for every model (always). Each
// has the range the field accepts and the one the slider covers ('period': a few periods of
// the scenario). The server judges combinations (docs/dashboard.md).
const PROBABILITY = { min: 0, max: 1, slider: 1, step: 0.001 };
const DELAY = { always: true, min: 0, max: 60000, slider: 'period', step: 0.5 };   // ms, at most a minute
const MODEL_ROWS = [
  Object.assign({ key: 'p', label: 'p (good→bad)' }, PROBABILITY),
  Object.assign({ key: 'r', label: 'r (bad→good)' }, PROBABILITY),
  Object.assign({ key: 'loss_good', label: 'loss good' }, PROBABILITY),
  Object.assign({ key: 'loss_bad', label: 'loss bad' }, PROBABILITY),
  Object.assign({ key: 'loss', label: 'loss' }, PROBABILITY),
  { key: 'mean_burst', label: 'mean burst', min: 1, max: Infinity, slider: 20, step: 0.1 },
];
// A key of a model the rows above do not know: named as the server names it, any number ≥ 0.
const OTHER_KEY = { min: 0, max: Infinity, slider: 1, step: 0.001 };
const DELAY_ROWS = [
  Object.assign({ key: 'delay_ms', label: 'delay (ms)' }, DELAY),
  Object.assign({ key: 'jitter_ms', label: 'jitter (ms)' }, DELAY),
];

// The number rows: those above, then the keys of the catalogue's models they do not name,
// then the delay.
function numberRows() {
  const rows = MODEL_ROWS.slice();
  for (const m of LINK_MODELS.values()) {
    for (const key of m.keys) {
      if (!rows.some((row) => row.key === key)) rows.push(Object.assign({ key, label: key.replace(/_/g, ' ') }, OTHER_KEY));
    }
  }
  return rows.concat(DELAY_ROWS);
}

// Every link key a card shows or sets, each a parameter link.ID.KEY (docs/dashboard.md).
function linkKeys() { return ['model', ...numberRows().map((row) => row.key), 'delay_distribution']; }

// Whether a card of a link of `model` shows the row of `key`.
function modelShows(model, spec) {
  return spec.always || modelKeys(model).includes(spec.key) || (model === GILBERT && USER_FORM.includes(spec.key));
}

// The values a link starts from: the catalogue's example of each model, then DEFAULT_PARAMS.
function defaultParams() {
  const params = {};
  for (const m of LINK_MODELS.values()) {
    for (const key of m.keys) if (!(key in params) && isNum(m.example[key])) params[key] = m.example[key];
  }
  return Object.assign(params, DEFAULT_PARAMS);
}

// Burst lengths in power-of-two bins: short bursts one by one, long ones grouped.
const BURST_BINS = [
  { lo: 1, hi: 1, label: '1' }, { lo: 2, hi: 2, label: '2' }, { lo: 3, hi: 4, label: '3–4' },
  { lo: 5, hi: 8, label: '5–8' }, { lo: 9, hi: 16, label: '9–16' }, { lo: 17, hi: 32, label: '17–32' },
  { lo: 33, hi: 64, label: '33–64' }, { lo: 65, hi: Infinity, label: '≥65' },
];

// Stationary loss and mean burst of a Gilbert-Elliott chain (as netkf/links/link.hpp computes
// them): what a model switch shows at once, before the server answers.
function gilbertStats(g) {
  const bad = g.p + g.r > 0 ? g.p / (g.p + g.r) : 0;
  const good = 1 - bad;
  const loss = good * g.loss_good + bad * g.loss_bad;
  if (loss <= 0) return { loss, meanBurst: 1 };
  const dropAfterGood = (1 - g.p) * g.loss_good + g.p * g.loss_bad;
  const dropAfterBad = g.r * g.loss_good + (1 - g.r) * g.loss_bad;
  const starts = good * (1 - g.loss_good) * dropAfterGood + bad * (1 - g.loss_bad) * dropAfterBad;
  return { loss, meanBurst: starts > 0 ? loss / starts : null };
}

// The link status's recent_fit in a few words (docs/cli.md, "Link status keys").
export function recentFitText(fit) {
  if (!fit) return 'not yet';
  const model = fit.family === 'simple_gilbert' && fit.link
    ? 'simple Gilbert p ' + fmt(fit.link.p, 3) + ' r ' + fmt(fit.link.r, 3) : 'Bernoulli';
  return model + ': loss ' + fmt(fit.loss, 3) + ', burst ' + (isNum(fit.mean_burst) ? fmt(fit.mean_burst, 2) : '∞') +
    ' (last ' + fit.samples + ')';
}

// A value as a field shows it: short, and empty for an unknown (infinite) mean burst.
function fieldText(v) { return isNum(v) ? String(+v.toPrecision(6)) : ''; }

// "6 ± 4 ms uniform", "3 ms" without jitter, "none" without delay.
function describeDelay(st) {
  if (!isNum(st.delay_ms)) return '—';
  const jitter = isNum(st.jitter_ms) ? st.jitter_ms : 0;
  const ms = (v) => String(+v.toPrecision(4));
  if (st.delay_ms === 0 && jitter === 0) return 'none';
  if (jitter === 0) return ms(st.delay_ms) + ' ms';
  return ms(st.delay_ms) + ' ± ' + ms(jitter) + ' ms ' + (st.delay_distribution || '');
}

function sameValue(a, b) {
  if (typeof a === 'number' && typeof b === 'number') return Math.abs(a - b) <= 1e-9 * Math.max(1, Math.abs(b));
  return a === b;
}

class LinkView {
  // The card's elements and chart exist only while it is shown (mount): a table of thousands
  // of links shows one card, and keeps the others' status and arrival-rate history only.
  constructor(sensor, historySamples) {
    this.id = sensor.id;
    this.name = linkName(sensor.id);   // in parameter names and element ids
    this.actuation = sensor.actuation || null;
    const link = sensor.link || {};
    // A model the catalogue does not describe (a trace) shows as the catalogue's first model.
    this.model = MODEL_LABEL[link.model] || !LINK_MODELS.size ? link.model : LINK_MODELS.keys().next().value;
    this.params = defaultParams();   // every key but model
    this.takeValues(link);
    this.fromParameters = false;   // true once parameterValues told the current values
    this.status = null;
    this.rates = new RecordRing(historySamples);   // {t, configured, sinceChange, window}
    this.pending = null;
    this.dragging = new Set();      // parameter names whose slider is held
    this.root = null;               // the card, while shown
    this.chart = null;
    this.actuationTheory = null;    // [configured, observed] of the latest theory (actuation link)
  }

  parameterNames() { return linkKeys().map((key) => 'link.' + this.name + '.' + key); }

  mount(box) {
    if (this.root) return;
    this.build();
    box.appendChild(this.root);
    this.chart = timeChart(this.chartBox, 84, [
      { label: 'configured', stroke: COLOR.configured, width: 2, paths: uPlot.paths.stepped({ align: 1 }), points: { show: false } },
      { label: 'observed since change', stroke: COLOR.observed, width: 1.5, points: { show: true, size: 4 } },
      { label: 'observed, last ≥' + OBSERVED_WINDOW_SAMPLES + ' samples', stroke: COLOR.observedWindow, width: 1.25, dash: [3, 3], points: { show: false } },
    ], { y: { range: [0, 1.05] } }, null, { legend: false, yValues: (u, splits) => splits.map((v) => v.toFixed(1)) });
    this.syncControls();
    if (this.actuationTheory) this.showActuationTheory(...this.actuationTheory);
    this.renderStats();
  }

  unmount() {
    this.clearPending();
    if (!this.root) return;
    if (this.chart) this.chart.destroy();
    this.root.remove();
    this.root = null;
    this.chart = null;
  }

  // Keys of a scenario link, a link status or a parameterValues answer; a Gilbert-Elliott
  // link's `loss` and `mean_burst` are its user's form.
  takeValues(values) {
    if (MODEL_LABEL[values.model]) this.model = values.model;
    if (DISTRIBUTIONS.includes(values.delay_distribution)) this.params.delay_distribution = values.delay_distribution;
    for (const row of numberRows()) {
      if (isNum(values[row.key])) this.params[row.key] = values[row.key];
      else if (row.key === 'mean_burst' && values.mean_burst === null) this.params.mean_burst = null;   // infinite
    }
  }

  build() {
    const id = this.name;
    const selectRow = (key, label, options) => {
      const select = el('select', { 'data-link': String(id), 'data-param': key, id: 'link-' + id + '-' + key },
        options.map(([value, text]) => el('option', { value, text })));
      return { select, row: el('div', { class: 'param-row select-row' }, [el('label', { for: select.id, text: label }), select]) };
    };
    const model = selectRow('model', 'model', Object.entries(MODEL_LABEL));
    this.select = model.select;
    this.select.addEventListener('change', () => this.switchModel(this.select.value));
    const distribution = selectRow('delay_distribution', 'distribution', DISTRIBUTIONS.map((d) => [d, d]));
    this.distSelect = distribution.select;
    this.distSelect.addEventListener('change', () => this.commit({ delay_distribution: this.distSelect.value }));
    const periodMs = store.periodS * 1000;
    this.inputs = {};   // key -> {row, range, number, spec}
    const rows = [model.row];
    for (const spec of numberRows()) {
      if (spec.key === 'loss') {
        rows.push(this.userFormNote = el('div', { class: 'subhead' ,
          text: 'or as loss and mean burst (simple Gilbert channel: loss good 0, loss bad 1)' }));
      }
      if (spec.key === 'delay_ms') rows.push(el('div', { class: 'subhead', text: 'delay of the delivered samples' }));
      const slider = spec.slider === 'period' ? Math.max(10, 5 * periodMs) : spec.slider;
      const attrs = { 'data-link': String(id), 'data-param': spec.key };
      const range = el('input', Object.assign({ type: 'range', min: String(spec.min), max: String(slider), step: String(spec.step),
        id: 'link-' + id + '-' + spec.key + '-range', 'aria-label': 'link ' + id + ' ' + spec.label }, attrs));
      const number = el('input', Object.assign({ type: 'number', min: String(spec.min), step: 'any',
        id: 'link-' + id + '-' + spec.key + '-number', 'aria-label': 'link ' + id + ' ' + spec.label + ' value' }, attrs));
      if (isFinite(spec.max)) number.max = String(spec.max);
      const row = el('div', { class: 'param-row' }, [el('label', { for: number.id, text: spec.label }), range, number]);
      this.wireParam(spec.key, range, number);
      this.inputs[spec.key] = { row, range, number, spec, shownText: null, committedText: null };
      rows.push(row);
    }
    rows.push(distribution.row);
    this.modelLabel = el('span', { class: 'link-model' });
    this.pendingLabel = el('span', { class: 'link-pending', role: 'status' });
    this.statsLine = el('div', { class: 'link-stats' });
    this.chartBox = el('div', { class: 'chart arrival-chart' });
    this.histCanvas = el('canvas', { class: 'burst-hist', 'aria-label': 'burst-length histogram of link ' + id });
    this.histNote = el('div', { class: 'hist-note muted small' });
    const a = this.actuation;
    const title = a ? 'link control (actuation: estimator → plant; on loss ' + a.on_loss + ', ' +
      (a.acknowledged ? 'acknowledged' : 'unacknowledged') + ')' : 'link ' + id;
    this.theoryLine = el('div', { class: 'link-theory', role: 'status' });
    this.root = el('article', { class: 'panel link-card' + (a ? ' actuation-card' : ''), 'data-link': String(id), id: 'link-' + id }, [
      el('div', { class: 'panel-head' }, [el('h2', { text: title }), this.modelLabel, this.pendingLabel]),
      el('div', { class: 'link-controls' }, rows),
      this.theoryLine,
      this.statsLine,
      el('div', { class: 'subhead' }, [document.createTextNode('arrival rate λ: '),
        el('span', { class: 'key-configured', text: '━ configured' }), document.createTextNode(' '),
        el('span', { class: 'key-observed', text: '●━ observed since change' }), document.createTextNode(' '),
        el('span', { class: 'key-observed-window', text: '┅ observed, last ≥' + OBSERVED_WINDOW_SAMPLES + ' samples' })]),
      this.chartBox,
      ...(a ? [] : [el('div', { class: 'subhead', text: 'burst length (periods not fused in a row, window)' }),
        this.histCanvas, this.histNote]),
    ]);
  }

  // The actuation link: the loop's verdict on its side and the critical rate ν_c beside the
  // configured and observed arrival rates (netkf analyze's `actuation`).
  showActuationTheory(configured, observed) {
    this.actuationTheory = [configured, observed];
    if (!this.root) return;
    if (!configured) { this.theoryLine.textContent = ''; return; }
    const f = (v) => (isNum(v) ? v.toFixed(3) : '–');
    const parts = ['ν̄ configured ' + f(configured.arrival_rate)];
    if (observed) parts.push('observed ' + f(observed.arrival_rate));
    parts.push('critical ν_c ' + (isNum(configured.critical_rate) ? f(configured.critical_rate) : 'unknown'));
    parts.push('loop on this side: ' + configured.stable + (observed ? ' (observed: ' + observed.stable + ')' : ''));
    this.theoryLine.textContent = parts.join(' · ');
    this.theoryLine.title = configured.reason || '';
    this.theoryLine.dataset.stable = observed ? observed.stable : configured.stable;
  }

  wireParam(key, range, number) {
    // The slider moves the number field while held and applies on release ("change").
    range.addEventListener('pointerdown', () => this.dragging.add(key));
    range.addEventListener('input', () => {
      this.dragging.add(key);
      number.value = range.value;
    });
    range.addEventListener('change', () => {
      this.dragging.delete(key);
      number.value = range.value;
      this.commitNumber(key, true);
    });
    // A pointer released without moving fires no "change": stop holding the control.
    range.addEventListener('pointerup', () => setTimeout(() => this.dragging.delete(key), 0));
    range.addEventListener('blur', () => this.dragging.delete(key));
    // The number field applies on Enter and on blur. Chromium also fires "change" on the
    // blur after an Enter: the text committed last is not sent twice.
    number.addEventListener('keydown', (event) => {
      if (event.key === 'Enter') { event.preventDefault(); this.commitNumber(key, false); }
    });
    number.addEventListener('change', () => {
      if (this.inputs[key].committedText !== number.value) this.commitNumber(key, false);
    });
    number.addEventListener('input', () => {
      number.classList.remove('invalid');
      this.inputs[key].committedText = null;
    });
  }

  // The value of a number field, or null (marked invalid, reason shown) when out of range.
  fieldValue(key) {
    const { number, spec } = this.inputs[key];
    const value = Number(number.value);
    if (number.value === '' || !Number.isFinite(value) || value < spec.min || value > spec.max) {
      number.classList.add('invalid');
      this.pendingLabel.textContent = spec.label + ' must be ' +
        (isFinite(spec.max) ? 'in [' + spec.min + ', ' + spec.max + ']' : '≥ ' + spec.min);
      this.pendingLabel.dataset.state = 'invalid';
      return null;
    }
    number.classList.remove('invalid');
    return value;
  }

  // Only the key the user changed is sent: a field left as shown sends nothing (the loss
  // of a Gilbert-Elliott link would rebuild its chain as the simple Gilbert channel).
  commitNumber(key, fromSlider) {
    const input = this.inputs[key];
    input.committedText = input.number.value;
    if (!fromSlider && input.number.value === input.shownText && !this.pending) return;
    const value = this.fieldValue(key);
    if (value === null) return;
    input.range.value = String(value);
    this.commit({ [key]: value });
  }

  // A model switch sends the model and the parameters the new model needs (its keys in the
  // catalogue): Gilbert-Elliott takes the chain fields; another model its keys' values, where a
  // loss keeps the chain's stationary loss.
  switchModel(model) {
    const values = { model };
    if (model !== GILBERT) {
      for (const key of modelKeys(model)) {
        const v = this.params[key];
        // A Gilbert-Elliott link's `loss` is its stationary loss.
        values[key] = key === 'loss' && this.model === GILBERT && isNum(v) ? +v.toFixed(4) : v;
        this.inputs[key].number.value = fieldText(values[key]);
        this.inputs[key].range.value = String(values[key]);
      }
    } else {
      for (const key of modelKeys(GILBERT)) {
        const v = this.fieldValue(key);
        if (v === null) return;
        values[key] = v;
      }
      const stats = gilbertStats(values);
      this.inputs.loss.number.value = fieldText(stats.loss);
      this.inputs.mean_burst.number.value = fieldText(stats.meanBurst);
    }
    this.showModelRows(model);
    this.commit(values);
  }

  // One setParameters for this link only, with the given keys.
  commit(values) {
    // Enter fires both keydown and "change": the request already under way is enough.
    const samePending = this.pending && Object.keys(values).length === Object.keys(this.pending.values).length &&
      Object.entries(values).every(([k, v]) => this.pending.values[k] === v);
    if (samePending) return;
    const parameters = Object.entries(values).map(([key, value]) => (typeof value === 'number'
      ? { name: 'link.' + this.name + '.' + key, value, type: 'float64' }
      : { name: 'link.' + this.name + '.' + key, value }));
    const request = setParameters(parameters, (requestId) => this.giveUp(requestId));
    if (!request) {
      this.pendingLabel.textContent = 'not connected';
      this.pendingLabel.dataset.state = 'invalid';
      this.syncControls();
      return;
    }
    if (this.pending) clearTimeout(this.pending.timer);
    this.pending = { id: request.id, values, timer: request.timer };
    this.pendingLabel.textContent = 'applying…';
    this.pendingLabel.dataset.state = 'pending';
  }

  giveUp(requestId) {
    if (!this.pending || this.pending.id !== requestId) return;
    this.clearPending();
    this.pendingLabel.textContent = 'no answer';
    this.pendingLabel.dataset.state = 'invalid';
    this.syncControls();
  }

  clearPending() {
    if (this.pending) clearTimeout(this.pending.timer);
    this.pending = null;
    if (!this.root) return;
    this.pendingLabel.textContent = '';
    delete this.pendingLabel.dataset.state;
  }

  onParameterValues(values, requestId) {
    this.takeValues(values);
    this.fromParameters = true;
    let answered = [];
    if (this.pending && requestId !== undefined && requestId === this.pending.id) {
      // Applied when the answer carries what we asked for; a refusal answers the old values.
      const current = Object.assign({ model: this.model }, this.params);
      answered = Object.keys(this.pending.values);
      const applied = answered.every((k) => sameValue(current[k], this.pending.values[k]));
      this.clearPending();   // a pending request exists only on a shown card
      this.pendingLabel.textContent = applied ? 'applied' : 'refused (see events)';
      this.pendingLabel.dataset.state = applied ? 'applied' : 'invalid';
    }
    this.syncControls(answered);
    redraw('links');
  }

  onStatus(st) {
    this.status = st;
    // Until the parameters have been read, the link status tells the current link.
    if (!this.fromParameters && !this.pending && MODEL_LABEL[st.model]) {
      this.takeValues(st);
      this.syncControls();
    }
    const t = currentTime();
    if (t !== null) {
      this.rates.push({
        t,
        configured: isNum(st.configured_arrival_rate) ? st.configured_arrival_rate : null,
        sinceChange: isNum(st.observed_arrival_rate_since_change) ? st.observed_arrival_rate_since_change : null,
        window: isNum(st.observed_arrival_rate_window) ? st.observed_arrival_rate_window : null,
      });
    }
  }

  showModelRows(model) {
    for (const key of Object.keys(this.inputs)) this.inputs[key].row.hidden = !modelShows(model, this.inputs[key].spec);
    this.userFormNote.hidden = model !== GILBERT;
  }

  // Controls follow the current values, except a slider being held or a field being typed
  // in; the controls of an answered request (`answered`: its keys) show the answer anyway.
  syncControls(answered) {
    if (!this.root) return;
    const force = new Set(answered || []);
    if (!this.pending) {
      if (document.activeElement !== this.select || force.has('model')) this.select.value = this.model;
      if (document.activeElement !== this.distSelect || force.has('delay_distribution')) {
        this.distSelect.value = this.params.delay_distribution;
      }
      this.showModelRows(this.model);
    }
    for (const key of Object.keys(this.inputs)) {
      const input = this.inputs[key];
      const value = this.params[key];
      if (this.dragging.has(key) || this.pending) continue;
      if (isNum(value)) input.range.value = String(value);
      if (document.activeElement !== input.number || force.has(key)) {
        input.number.value = input.shownText = fieldText(value);
        input.number.classList.remove('invalid');
      }
    }
    this.modelLabel.textContent = MODEL_LABEL[this.model] || String(this.model);
  }

  renderStats() {
    if (!this.root) return;
    const st = this.status;
    if (!st) { this.statsLine.textContent = 'no link status yet'; return; }
    const items = [
      ['stationary loss', fmt(st.stationary_loss, 3)],
      ['delay', describeDelay(st)],
      ['P(in time)', fmt(st.in_time, 3), 'P(delay ≤ the estimator\'s deadline)'],
      ['λ configured', fmt(st.configured_arrival_rate, 3), '(1 − loss) · P(in time)'],
      // The observed arrival rate, each with its window (docs/dashboard.md, "Observed arrival rates").
      ['λ since change', rateText(st.observed_arrival_rate_since_change),
        'observed arrival rate since the link\'s model was set: in time / samples (the theory\'s observed point)'],
      ['in time / samples', st.delivered_in_time + ' / ' + st.samples_in,
        'since the link\'s model was set: samples delivered within the estimator\'s deadline / samples that entered the link'],
      [WINDOW_KEY, isNum(st.observed_arrival_rate_window)
        ? rateText(st.observed_arrival_rate_window) + ' over ' + st.observed_window_samples : 'not yet',
        'observed arrival rate, in time / samples, over the latest link reports since the change that hold at least ' +
        OBSERVED_WINDOW_SAMPLES + ' samples'],
      ['loss since change', fmt(st.observed_loss, 3), 'dropped / samples since the link\'s model was set'],
      ['mean burst', fmt(st.mean_burst_length, 2)],
      ['held', isNum(st.held) ? String(st.held) : '—', 'samples the channel holds now (delayed)'],
      ['fitted', recentFitText(st.recent_fit), 'the loss model the link\'s last samples since its model was set ' +
        'show (at most 5000; bernoulli or simple Gilbert, by AIC), to compare with the configured one'],
    ];
    if (st.last_request_rejected && st.reject_reason) items.push(['last request refused', st.reject_reason]);
    this.statsLine.replaceChildren(...items.map(([k, v, title]) => el('span', Object.assign({ class: 'stat', 'data-stat': k },
      title ? { title } : {}), [el('span', { class: 'stat-key', text: k }), el('span', { class: 'stat-value', text: v })])));
  }
}


// A card per link, or, above CARD_LINK_LIMIT links, the link table and no card until one is
// selected in it.
export function buildLinks(sensors) {
  for (const link of store.links.values()) link.unmount();
  store.links.clear();
  store.tableMode = sensors.length > CARD_LINK_LIMIT;
  store.selectedLink = null;
  const box = $('links');
  box.replaceChildren();
  for (const sensor of sensors) {
    const link = new LinkView(sensor, store.tableMode ? LINK_SAMPLES_TABLE : LINK_SAMPLES);
    store.links.set(sensor.id, link);
    if (!store.tableMode) link.mount(box);
  }
  $('link-table-panel').hidden = !store.tableMode;
  $('link-table-hint').hidden = false;
}

// The cards shown: their figures, arrival-rate charts and histograms.
export function renderLinkCards() {
  const w = windowPeriods();
  const ring = store.ring;
  const tLo = view.tLo;
  for (const link of store.links.values()) {
    if (!link.root) continue;
    link.renderStats();
    // Arrival rates over the same time window as the other charts.
    const xs = [];
    const configured = [];
    const sinceChange = [];
    const windowed = [];
    link.rates.forEach((r) => {
      if (r.t < tLo || r.t > view.tHi + 1) return;
      xs.push(r.t); configured.push(r.configured); sinceChange.push(r.sinceChange); windowed.push(r.window);
    });
    // Carry the configured rate to "now" so the step reaches the right edge.
    if (xs.length && view.tHi > xs[xs.length - 1]) {
      xs.push(view.tHi); configured.push(configured[configured.length - 1]); sinceChange.push(null); windowed.push(null);
    }
    link.chart.setData([xs, configured, sinceChange, windowed]);
    dash.plotLengths['link' + link.id] = link.chart.data[0].length;
    // The actuation link carries inputs, not samples: no fused-burst histogram.
    if (!link.actuation) drawBurstHistogram(link, w ? burstHistogram(ring, store.sensorIndex.get(link.id), w.kLo, w.kHi) : null);
  }
}

// Runs of consecutive periods in which the sensor was not fused, within the window.
// A period missing from the ring (message dropped by the server) ends a run uncounted.
function burstHistogram(ring, s, kLo, kHi) {
  const counts = new Array(BURST_BINS.length).fill(0);
  let run = 0;
  let runs = 0;
  let total = 0;
  let periods = 0;
  const close = () => {
    if (run > 0) {
      const b = BURST_BINS.findIndex((bin) => run >= bin.lo && run <= bin.hi);
      counts[b]++;
      runs++;
      total += run;
    }
    run = 0;
  };
  for (let k = kLo; k <= kHi; k++) {
    const i = ring.find(k);
    if (i < 0 || !ring.hasEstimate[i]) { run = 0; continue; }
    periods++;
    if (ring.fused[s][i]) close(); else run++;
  }
  const ongoing = run;
  close();
  return { counts, runs, mean: runs ? total / runs : null, ongoing, periods };
}

function drawBurstHistogram(link, hist) {
  const { ctx, width, height } = canvasContext(link.histCanvas, 74);
  const left = 30;
  const bottom = height - 18;
  const top = 4;
  const plotW = width - left - 6;
  ctx.font = '10px system-ui, sans-serif';
  ctx.fillStyle = COLOR.axis;
  ctx.strokeStyle = COLOR.grid;
  ctx.beginPath();
  ctx.moveTo(left, bottom + 0.5);
  ctx.lineTo(left + plotW, bottom + 0.5);
  ctx.stroke();
  if (!hist || hist.periods === 0) {
    ctx.fillText('no periods yet', left + 8, top + 20);
    link.histNote.textContent = '';
    return;
  }
  const max = Math.max(1, ...hist.counts);
  const slot = plotW / BURST_BINS.length;
  ctx.textAlign = 'center';
  BURST_BINS.forEach((bin, b) => {
    const x = left + b * slot;
    const h = (hist.counts[b] / max) * (bottom - top - 10);
    ctx.fillStyle = COLOR.observed;
    ctx.globalAlpha = 0.8;
    ctx.fillRect(x + 2, bottom - h, slot - 4, h);
    ctx.globalAlpha = 1;
    ctx.fillStyle = COLOR.axis;
    ctx.font = (slot < 30 ? '9px' : '10px') + ' system-ui, sans-serif';
    ctx.fillText(bin.label, x + slot / 2, bottom + 12);
    if (hist.counts[b]) ctx.fillText(String(hist.counts[b]), x + slot / 2, Math.max(top + 9, bottom - h - 2));
  });
  ctx.textAlign = 'right';
  ctx.fillText('runs', left - 4, top + 8);
  const server = link.status && isNum(link.status.mean_burst_length) ? fmt(link.status.mean_burst_length, 2) : '—';
  link.histNote.textContent = hist.runs + ' bursts in ' + hist.periods + ' periods, mean ' + fmt(hist.mean, 2) +
    (hist.ongoing ? ' · ongoing ' + hist.ongoing : '') + ' · link status mean ' + server;
}

export function onLinkStatus(st) {
  const link = store.links.get(st.sensor_id);
  if (!link) return;
  link.onStatus(st);
  redraw('links', 'region');
}

export function onParameterValues(msg) {
  // Group name link.ID.param by link; a reply to our own request carries its id.
  const perLink = new Map();
  const keys = linkKeys();
  for (const p of msg.parameters || []) {
    const match = LINK_PARAMETER.exec(String(p.name));
    if (!match || !keys.includes(match[2])) continue;
    const id = match[1] === 'control' ? CONTROL_LINK_ID : Number(match[1]);
    if (!perLink.has(id)) perLink.set(id, {});
    // Words stay words; a number that is not finite (an endless mean burst) comes as null.
    perLink.get(id)[match[2]] = WORD_KEYS.includes(match[2]) ? String(p.value) : (isNum(p.value) ? p.value : null);
  }
  for (const [id, values] of perLink) {
    const link = store.links.get(id);
    if (link) link.onParameterValues(values, msg.id);
  }
  // A reply for a link that has no values in it (should not happen) still ends the wait.
  for (const link of store.links.values()) {
    if (link.pending && msg.id !== undefined && link.pending.id === msg.id && !perLink.has(link.id)) link.clearPending();
  }
}
