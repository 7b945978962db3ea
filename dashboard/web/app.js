// netkf live dashboard: one foxglove.websocket.v1 client of `netkf launch`
// (docs/dashboard.md is the contract: channels, fields, parameters, status messages).
// Plain ES2020, no build step; uPlot is loaded before this file as the global `uPlot`.
'use strict';

(function () {
  const SUBPROTOCOL = 'foxglove.websocket.v1';
  const WINDOW_CHOICES_S = [10, 30, 120];
  const MAX_WINDOW_S = Math.max(...WINDOW_CHOICES_S);
  const MAX_PERIODS = 30000;        // ring bound even for very short periods
  const LINK_SAMPLES = 600;         // link status ~1/s: 10 min of arrival-rate history
  const THEORY_SAMPLES = 600;       // theory ~1/s
  const EVENT_LOG_CAP = 500;
  const REGION_TRAIL = 60;          // last observed operating points drawn as a trail
  const MIN_REDRAW_MS = 100;        // time charts redraw at most 10 times a second
  const MAX_REDRAW_MS = 500;        // and at least twice a second, however slow
  const LINK_REDRAW_MS = 500;       // link panels (fed ~1/s) at most twice a second
  // Above this many links the page shows a table of them and the card of the one selected:
  // thousands of cards, each a chart and a dozen controls, would not draw.
  const CARD_LINK_LIMIT = 16;
  const TABLE_ROWS = 100;           // rows the link table shows ("show more" adds as many)
  const LINK_SAMPLES_TABLE = 120;   // arrival-rate history per link in table mode: 2 min at ~1/s
  const TEXT_REDRAW_MS = 100;       // header and stability texts at most 10 times a second
  const PENDING_TIMEOUT_MS = 5000;  // a setParameters without answer is given up after this
  const OBSERVED_WINDOW_SAMPLES = 1000;  // the observed rate window's least span (kWindowSamples, cli/live/observed_rate.hpp)
  const WINDOW_KEY = 'λ last ≥' + OBSERVED_WINDOW_SAMPLES + ' samples';
  const RESTART_GAP = 50;           // k going back by more than this: the run restarted
  const MODEL_LABEL = { bernoulli: 'Bernoulli', gilbert_elliott: 'Gilbert-Elliott' };
  const DISTRIBUTIONS = ['uniform', 'normal', 'pareto', 'paretonormal'];
  // Every link key of docs/scenario-format.md ("Links") is a parameter link.ID.KEY.
  const LINK_KEYS = ['model', 'loss', 'p', 'r', 'loss_good', 'loss_bad', 'mean_burst', 'delay_ms', 'jitter_ms',
    'delay_distribution'];
  const WORD_KEYS = ['model', 'delay_distribution'];
  const LINK_PARAMETER = new RegExp('^link\\.(-?\\d+|control)\\.(' + LINK_KEYS.join('|') + ')$');
  // The actuation link (plant.control.link) is link "control": id -1 where links are numbered.
  const CONTROL_LINK_ID = -1;
  const linkName = (id) => (id === CONTROL_LINK_ID ? 'control' : String(id));
  const GILBERT_CHAIN = ['p', 'r', 'loss_good', 'loss_bad'];
  // Used when the user switches a link to a model it has no values for yet.
  const DEFAULT_PARAMS = { loss: 0, p: 0.1, r: 0.5, loss_good: 0, loss_bad: 1, mean_burst: 1,
    delay_ms: 0, jitter_ms: 0, delay_distribution: 'uniform' };
  // The number rows of a link card, in order: the models that show them (null: every
  // model), the range the field accepts and the one the slider covers ('period': a few
  // periods of the scenario). The server judges combinations (docs/dashboard.md).
  const PROBABILITY = { min: 0, max: 1, slider: 1, step: 0.001 };
  const DELAY = { models: null, min: 0, max: 60000, slider: 'period', step: 0.5 };   // ms, at most a minute
  const NUMBER_ROWS = [
    Object.assign({ key: 'p', label: 'p (good→bad)', models: ['gilbert_elliott'] }, PROBABILITY),
    Object.assign({ key: 'r', label: 'r (bad→good)', models: ['gilbert_elliott'] }, PROBABILITY),
    Object.assign({ key: 'loss_good', label: 'loss good', models: ['gilbert_elliott'] }, PROBABILITY),
    Object.assign({ key: 'loss_bad', label: 'loss bad', models: ['gilbert_elliott'] }, PROBABILITY),
    Object.assign({ key: 'loss', label: 'loss', models: ['bernoulli', 'gilbert_elliott'] }, PROBABILITY),
    { key: 'mean_burst', label: 'mean burst', models: ['gilbert_elliott'], min: 1, max: Infinity, slider: 20, step: 0.1 },
    Object.assign({ key: 'delay_ms', label: 'delay (ms)' }, DELAY),
    Object.assign({ key: 'jitter_ms', label: 'jitter (ms)' }, DELAY),
  ];
  // Burst lengths in power-of-two bins: short bursts one by one, long ones grouped.
  const BURST_BINS = [
    { lo: 1, hi: 1, label: '1' }, { lo: 2, hi: 2, label: '2' }, { lo: 3, hi: 4, label: '3–4' },
    { lo: 5, hi: 8, label: '5–8' }, { lo: 9, hi: 16, label: '9–16' }, { lo: 17, hi: 32, label: '17–32' },
    { lo: 33, hi: 64, label: '33–64' }, { lo: 65, hi: Infinity, label: '≥65' },
  ];
  const COLOR = {
    truth: '#1d232b',
    estimate: '#1f6fd1',
    sigmaBand: 'rgba(31, 111, 209, 0.16)',
    sigmaEdge: 'rgba(31, 111, 209, 0.35)',
    tracePred: '#6b3fb8',
    traceFiltered: 'rgba(107, 63, 184, 0.35)',
    configured: '#1e8a4c',
    configuredBand: 'rgba(30, 138, 76, 0.12)',
    observed: '#d9731a',
    observedWindow: '#8a4b12',
    observedBand: 'rgba(217, 115, 26, 0.08)',
    diverging: 'rgba(214, 48, 49, 0.10)',
    axis: '#4a5563',
    grid: 'rgba(0, 0, 0, 0.07)',
    stable: 'rgba(30, 138, 76, 0.20)',
    undecided: 'rgba(230, 170, 40, 0.22)',
    unstable: 'rgba(214, 48, 49, 0.20)',
    lowerCurve: '#b8322f',
    upperCurve: '#1e8a4c',
    final: '#c2185b',                      // late_policy fuse_within: the final (revised) estimates
    finalBand: 'rgba(194, 24, 91, 0.08)',
  };

  // What a test (tests/e2e/dashboard_browser.mjs) reads; updated as messages arrive.
  const dash = {
    estimatesReceived: 0,
    truthReceived: 0,
    lastK: null,
    messagesReceived: 0,
    decodeErrors: 0,
    eventCount: 0,
    pointsPlotted: 0,          // estimate points in the first state chart
    revisionsReceived: 0,      // revised estimates (revision > 0, late_policy fuse_within)
    finalPointsPlotted: 0,     // periods in the plotted window whose final estimate is a revision
    finalSeries: false,        // the charts carry the final-estimate series and band
    finalVerdict: null,        // the final estimates' "stable" ("yes"/"no"/"unknown"), null without one
    recentRevisions: [],       // the last revised estimates taken: {k, revision, x_hat}
    theoryBands: null,         // the latest theory's bands: {configured, final: {stable, lower, upper} or null}
    plotLengths: {},           // uPlot data lengths per chart, after the last redraw
    setParametersSent: 0,
    linkTableMs: null,         // the last link table redraw (filter, sort, rows), ms
    connected: false,
  };
  window.netkfDashboard = dash;

  // ---------------------------------------------------------------- helpers
  const $ = (id) => document.getElementById(id);
  function el(tag, attrs, children) {
    const node = document.createElement(tag);
    for (const [key, value] of Object.entries(attrs || {})) {
      if (key === 'text') node.textContent = value;
      else if (key === 'class') node.className = value;
      else node.setAttribute(key, value);
    }
    for (const child of children || []) node.appendChild(child);
    return node;
  }
  function isNum(v) { return typeof v === 'number' && Number.isFinite(v); }
  function fmt(v, digits) {
    if (v === null || v === undefined) return '—';
    if (!isNum(v)) return String(v);
    const a = Math.abs(v);
    if (a !== 0 && (a >= 1e5 || a < 1e-3)) return v.toExponential(2);
    return v.toFixed(digits === undefined ? 3 : digits);
  }
  // An arrival rate: always three decimals (a rate near 0 is no exponent); 'not yet' when unknown.
  function rateText(v) { return isNum(v) ? v.toFixed(3) : 'not yet'; }
  function fmtTrace(v, unboundedText) { return v === null || v === undefined ? unboundedText : fmt(v, 3); }
  function clockTime(date) {
    return date.toTimeString().slice(0, 8);
  }

  // ------------------------------------------------------------ data store
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
  class RecordRing {
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

  const store = {
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
    links: new Map(),                         // sensor id -> link view (below)
    tableMode: false,                         // more than CARD_LINK_LIMIT links: a table and one card
    selectedLink: null,                       // table mode: the id whose card is shown
    regionTrail: new RecordRing(REGION_TRAIL),
  };

  const view = {
    windowS: 30,
    paused: false,
    tLo: 0,
    tHi: 30,
    dirty: { data: true, slowData: false, header: true, theory: true, region: true, links: true, network: true },
  };

  // ------------------------------------------------------------- connection
  const conn = {
    ws: null,
    attempt: 0,
    reconnectTimer: null,
    nextSubscriptionId: 1,
    channels: new Map(),        // channel id -> channel
    subscriptions: new Map(),   // subscription id -> topic
    subscribedChannels: new Set(),
    capabilities: [],
    paramUpdates: new Set(),    // parameter names whose updates this connection subscribed
    serverName: '',
    nextRequest: 1,
  };

  function wsUrl() {
    const token = new URLSearchParams(window.location.search).get('token');
    const scheme = window.location.protocol === 'https:' ? 'wss:' : 'ws:';
    return scheme + '//' + window.location.host + '/' + (token ? '?token=' + encodeURIComponent(token) : '');
  }

  function setConnState(state, text) {
    const node = $('conn-state');
    node.dataset.state = state;
    node.textContent = text;
    dash.connected = state === 'connected';
  }

  function connect() {
    conn.reconnectTimer = null;
    setConnState('connecting', conn.attempt ? 'reconnecting…' : 'connecting…');
    let ws;
    try {
      ws = new WebSocket(wsUrl(), [SUBPROTOCOL]);
    } catch (err) {
      scheduleReconnect();
      return;
    }
    ws.binaryType = 'arraybuffer';
    conn.ws = ws;
    conn.subscriptions.clear();
    conn.subscribedChannels.clear();
    conn.channels.clear();
    conn.paramUpdates = new Set();
    ws.onopen = () => {
      conn.attempt = 0;
      setConnState('connected', 'connected');
      addEvent({ level: 'page', message: 'connected to ' + window.location.host });
    };
    ws.onmessage = (event) => {
      dash.messagesReceived++;
      if (typeof event.data === 'string') handleText(event.data);
      else handleBinary(event.data);
    };
    ws.onerror = () => { /* a close event follows; it schedules the reconnect */ };
    ws.onclose = (event) => {
      if (conn.ws !== ws) return;
      const wasOpen = dash.connected;
      conn.ws = null;
      if (wasOpen) addEvent({ level: 'page', message: 'connection closed' + (event.code ? ' (code ' + event.code + ')' : '') });
      for (const link of store.links.values()) link.clearPending();
      scheduleReconnect();
    };
  }

  function scheduleReconnect() {
    // Exponential backoff with jitter, 0.5 s .. 10 s, so a restarting server is not hammered.
    const delay = Math.min(10000, 500 * Math.pow(2, conn.attempt)) * (0.75 + 0.5 * Math.random());
    conn.attempt++;
    setConnState('disconnected', 'disconnected — retry in ' + (delay / 1000).toFixed(1) + ' s');
    conn.reconnectTimer = setTimeout(connect, delay);
  }

  function send(message) {
    if (!conn.ws || conn.ws.readyState !== WebSocket.OPEN) return false;
    conn.ws.send(JSON.stringify(message));
    return true;
  }

  function handleText(text) {
    let msg;
    try {
      msg = JSON.parse(text);
    } catch (err) {
      dash.decodeErrors++;
      return;
    }
    switch (msg.op) {
      case 'serverInfo': onServerInfo(msg); break;
      case 'advertise': onAdvertise(msg.channels || []); break;
      case 'unadvertise': onUnadvertise(msg.channelIds || []); break;
      case 'status': onStatus(msg); break;
      case 'parameterValues': onParameterValues(msg); break;
      default: break;   // removeStatus, services, ...: nothing to show
    }
  }

  const textDecoder = new TextDecoder('utf-8');

  // messageData: opcode 0x01, uint32 LE subscription id, uint64 LE timestamp, payload.
  function handleBinary(buffer) {
    if (buffer.byteLength < 13) { dash.decodeErrors++; return; }
    const dv = new DataView(buffer);
    if (dv.getUint8(0) !== 0x01) return;   // 0x02 time etc.: not used
    const topic = conn.subscriptions.get(dv.getUint32(1, true));
    if (!topic) return;
    let payload;
    try {
      payload = JSON.parse(textDecoder.decode(new Uint8Array(buffer, 13)));
    } catch (err) {
      dash.decodeErrors++;
      return;
    }
    switch (topic) {
      case 'netkf/scenario': onScenario(payload); break;
      case 'netkf/estimate': onEstimate(payload); break;
      case 'netkf/truth': onTruth(payload); break;
      case 'netkf/link/status': onLinkStatus(payload); break;
      case 'netkf/theory': onTheory(payload); break;
      case 'netkf/network': onNetwork(payload); break;
      default: break;
    }
  }

  function onServerInfo(msg) {
    conn.capabilities = msg.capabilities || [];
    conn.serverName = msg.name || '';
    if (conn.capabilities.includes('parameters')) {
      // An empty name list asks for every parameter the server has.
      send({ op: 'getParameters', parameterNames: [], id: 'netkf-dashboard-initial' });
    }
    subscribeParameterUpdates();
  }

  function onAdvertise(channels) {
    const subscriptions = [];
    for (const channel of channels) {
      conn.channels.set(channel.id, channel);
      if (!String(channel.topic).startsWith('netkf/')) continue;
      if (channel.encoding !== 'json' || conn.subscribedChannels.has(channel.id)) continue;
      const id = conn.nextSubscriptionId++;
      conn.subscriptions.set(id, channel.topic);
      conn.subscribedChannels.add(channel.id);
      subscriptions.push({ id, channelId: channel.id });
    }
    if (subscriptions.length) send({ op: 'subscribe', subscriptions });
  }

  function onUnadvertise(channelIds) {
    const gone = new Set(channelIds);
    for (const [subId, topic] of conn.subscriptions) {
      for (const id of gone) {
        const channel = conn.channels.get(id);
        if (channel && channel.topic === topic) conn.subscriptions.delete(subId);
      }
    }
    for (const id of gone) { conn.channels.delete(id); conn.subscribedChannels.delete(id); }
  }

  // Every parameter a shown card's link can have, whatever its current model, so a model
  // switch made elsewhere still reaches it. Only the cards shown: the names of thousands of
  // links would exceed what the server takes in one message (docs/dashboard.md).
  function subscribeParameterUpdates() {
    if (!conn.capabilities.includes('parametersSubscribe') || !store.scenario) return;
    const wanted = new Set();
    for (const link of store.links.values()) {
      if (link.root) for (const name of link.parameterNames()) wanted.add(name);
    }
    const add = [...wanted].filter((name) => !conn.paramUpdates.has(name));
    const drop = [...conn.paramUpdates].filter((name) => !wanted.has(name));
    if (drop.length && send({ op: 'unsubscribeParameterUpdates', parameterNames: drop })) {
      for (const name of drop) conn.paramUpdates.delete(name);
    }
    if (add.length && send({ op: 'subscribeParameterUpdates', parameterNames: add })) {
      for (const name of add) conn.paramUpdates.add(name);
    }
  }

  // --------------------------------------------------------------- messages
  function onScenario(s) {
    const sensors = Array.isArray(s.sensors) ? s.sensors : [];
    const key = JSON.stringify([s.name, s.period_ms, s.state_dim, s.seed, s.late_policy, s.max_delay_periods,
      sensors.map((x) => [x.id, x.measurement_dim])]);
    store.scenario = s;
    if (key === store.scenarioKey) return;
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
    $('scenario-name').textContent = s.name || '(unnamed scenario)';
    $('scenario-name').title = 'scenario ' + (s.name || '') + ', period ' + s.period_ms + ' ms, seed ' + s.seed +
      ', ' + s.state_dim + ' states, ' + sensors.length + ' sensors';
    buildTraceChart();
    buildStateCharts(store.ring.n);
    // The actuation link's card after the sensors': the same controls, for the inputs.
    buildLinks(s.actuation && s.actuation.link
      ? sensors.concat([{ id: CONTROL_LINK_ID, link: s.actuation.link, actuation: s.actuation }]) : sensors);
    $('assessment').classList.toggle('no-final', !store.fuseWithin);
    const twoSensors = sensors.length === 2;
    $('region-box').hidden = !twoSensors;
    $('region-none').hidden = twoSensors;
    document.querySelector('main.grid').classList.toggle('no-region', !twoSensors);
    // New link cards: read their parameters (an earlier answer may have come before them).
    // A table reads them for the card selected.
    if (conn.capabilities.includes('parameters') && !store.tableMode) {
      send({ op: 'getParameters', parameterNames: [], id: 'netkf-dashboard-scenario' });
    }
    subscribeParameterUpdates();
    markAllDirty();
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
    view.dirty.data = true;
    requestRender();
  }

  function onEstimate(e) {
    if (isNum(e.revision) && e.revision > 0) { onRevisedEstimate(e); return; }
    dash.estimatesReceived++;
    dash.lastK = e.k;
    store.latestEstimate = e;
    view.dirty.header = true;
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
    view.dirty.data = true;
    requestRender();
  }

  function onTruth(m) {
    dash.truthReceived++;
    const ring = store.ring;
    if (!ring || !isNum(m.k)) return;
    const i = ring.slot(m.k);
    if (i < 0) return;
    ring.hasTruth[i] = 1;
    if (!ring.hasEstimate[i]) ring.t[i] = isNum(m.t) ? m.t : m.k * store.periodS;
    const x = m.x || [];
    for (let c = 0; c < ring.n; c++) ring.truth[c][i] = isNum(x[c]) ? x[c] : NaN;
    view.dirty.data = true;
    requestRender();
  }

  function onTheory(th) {
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
    view.dirty.theory = true;
    view.dirty.region = true;
    view.dirty.data = true;
    requestRender();
  }

  function onNetwork(nw) {
    store.latestNetwork = nw;
    view.dirty.network = true;
    view.dirty.header = true;
    requestRender();
  }

  function onLinkStatus(st) {
    const link = store.links.get(st.sensor_id);
    if (!link) return;
    link.onStatus(st);
    view.dirty.links = true;
    view.dirty.region = true;
    requestRender();
  }

  function onParameterValues(msg) {
    // Group name link.ID.param by link; a reply to our own request carries its id.
    const perLink = new Map();
    for (const p of msg.parameters || []) {
      const match = LINK_PARAMETER.exec(String(p.name));
      if (!match) continue;
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

  const LEVEL_NAME = { 0: 'info', 1: 'warning', 2: 'error', page: 'page' };

  function onStatus(msg) {
    addEvent({ level: msg.level, message: String(msg.message || '') });
  }

  function addEvent(entry) {
    const list = $('event-log');
    const level = LEVEL_NAME[entry.level] || 'info';
    const k = dash.lastK;
    const item = el('li', { class: 'event level-' + level, 'data-level': String(entry.level) }, [
      el('time', { text: clockTime(new Date()), class: 'event-time' }),
      el('span', { class: 'event-k', text: k === null ? '' : 'k ' + k }),
      el('span', { class: 'event-level', text: level }),
      el('span', { class: 'event-message', text: entry.message }),
    ]);
    list.insertBefore(item, list.firstChild);   // newest on top
    while (list.childElementCount > EVENT_LOG_CAP) list.removeChild(list.lastElementChild);
    dash.eventCount++;
    $('event-count').textContent = list.childElementCount + (dash.eventCount > list.childElementCount ? ' shown of ' + dash.eventCount : '') + ' entries';
  }

  // ------------------------------------------------------------ link cards
  // Stationary loss and mean burst of a Gilbert-Elliott chain (as netkf/link.hpp computes
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
  function recentFitText(fit) {
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
      this.model = MODEL_LABEL[link.model] ? link.model : 'bernoulli';
      this.params = Object.assign({}, DEFAULT_PARAMS);   // every key but model
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

    parameterNames() { return LINK_KEYS.map((key) => 'link.' + this.name + '.' + key); }

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
      for (const row of NUMBER_ROWS) {
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
      for (const spec of NUMBER_ROWS) {
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

    // A model switch sends the model and the parameters the new model needs: Bernoulli
    // keeps the chain's stationary loss, Gilbert-Elliott takes the chain fields.
    switchModel(model) {
      const values = { model };
      if (model === 'bernoulli') {
        // A Gilbert-Elliott link's `loss` is its stationary loss.
        values.loss = this.model === 'gilbert_elliott' ? +this.params.loss.toFixed(4) : this.params.loss;
        this.inputs.loss.number.value = fieldText(values.loss);
        this.inputs.loss.range.value = String(values.loss);
      } else {
        for (const key of GILBERT_CHAIN) {
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
      const requestId = 'netkf-dashboard-' + Date.now().toString(36) + '-' + (conn.nextRequest++);
      const parameters = Object.entries(values).map(([key, value]) => (typeof value === 'number'
        ? { name: 'link.' + this.name + '.' + key, value, type: 'float64' }
        : { name: 'link.' + this.name + '.' + key, value }));
      if (!send({ op: 'setParameters', parameters, id: requestId })) {
        this.pendingLabel.textContent = 'not connected';
        this.pendingLabel.dataset.state = 'invalid';
        this.syncControls();
        return;
      }
      dash.setParametersSent++;
      if (this.pending) clearTimeout(this.pending.timer);
      this.pending = { id: requestId, values, timer: setTimeout(() => this.giveUp(requestId), PENDING_TIMEOUT_MS) };
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
      view.dirty.links = true;
      requestRender();
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
      for (const key of Object.keys(this.inputs)) {
        const models = this.inputs[key].spec.models;
        this.inputs[key].row.hidden = models !== null && !models.includes(model);
      }
      this.userFormNote.hidden = model !== 'gilbert_elliott';
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
      this.modelLabel.textContent = MODEL_LABEL[this.model];
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
  function buildLinks(sensors) {
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
    linkTable.shown = TABLE_ROWS;
    $('link-table-panel').hidden = !store.tableMode;
    $('link-table-hint').hidden = false;
  }

  // ------------------------------------------------------------ link table
  // The columns of the table mode: what each shows of a link's status and how it sorts
  // (null sorts first: a link that has not reported is the one to look at).
  const LINK_COLUMNS = [
    { key: 'link', label: 'link', value: (l) => l.id, text: (l) => l.name },
    { key: 'model', label: 'model', value: (l) => modelText(l), text: (l) => modelText(l) },
    { key: 'configured', label: 'λ configured', title: '(1 − loss) · P(in time)', rate: 'configured_arrival_rate' },
    { key: 'since', label: 'λ since change', title: 'observed arrival rate since the link\'s model was set: in time / samples',
      rate: 'observed_arrival_rate_since_change' },
    { key: 'window', label: WINDOW_KEY, title: 'observed arrival rate over the latest reports holding at least ' +
      OBSERVED_WINDOW_SAMPLES + ' samples', rate: 'observed_arrival_rate_window' },
    { key: 'shortfall', label: 'λ configured − since change', title: 'how far the link runs below its model',
      value: (l) => shortfall(l), text: (l) => fmt(shortfall(l), 3) },
    { key: 'late', label: 'late share', title: 'late samples / samples the estimator received from the link',
      rate: 'late_fraction' },
    { key: 'samples', label: 'samples', title: 'samples that entered the link since its model was set',
      value: (l) => statusNumber(l, 'samples_in'), text: (l) => fmt(statusNumber(l, 'samples_in'), 0) },
    { key: 'fit', label: 'fitted', title: 'the loss model the link\'s last samples show (bernoulli or simple Gilbert, by AIC)',
      value: (l) => (l.status && l.status.recent_fit ? l.status.recent_fit.loss : null),
      text: (l) => (l.status ? recentFitText(l.status.recent_fit) : '—') },
  ];
  for (const column of LINK_COLUMNS) {
    if (!column.rate) continue;
    column.value = (l) => statusNumber(l, column.rate);
    column.text = (l) => (l.status ? rateText(statusNumber(l, column.rate)) : '—');
  }
  const linkTable = { sort: 'since', descending: false, query: '', shown: TABLE_ROWS, rowsShown: [] };

  function statusNumber(link, field) { return link.status && isNum(link.status[field]) ? link.status[field] : null; }
  function shortfall(link) {
    const configured = statusNumber(link, 'configured_arrival_rate');
    const observed = statusNumber(link, 'observed_arrival_rate_since_change');
    return configured !== null && observed !== null ? configured - observed : null;
  }
  function modelText(link) {
    const st = link.status || {};
    const model = MODEL_LABEL[st.model] ? st.model : link.model;
    const loss = isNum(st.stationary_loss) ? st.stationary_loss : (model === 'bernoulli' ? link.params.loss : null);
    return MODEL_LABEL[model] + (isNum(loss) ? ' ' + fmt(loss, 3) : '');
  }

  // The search: terms separated by spaces or commas, a link shown when any term matches: an
  // id's beginning ("30": 30, 300-309, 3000-3099), a range of ids ("100-163"), or a word in its
  // model or fitted model ("gilbert", "control").
  function linkMatcher(query) {
    const terms = query.toLowerCase().split(/[\s,]+/).filter(Boolean);
    if (!terms.length) return () => true;
    const tests = terms.map((term) => {
      const range = /^(-?\d+)-(-?\d+)$/.exec(term);
      if (range) {
        const lo = Math.min(Number(range[1]), Number(range[2]));
        const hi = Math.max(Number(range[1]), Number(range[2]));
        return (l) => l.id >= lo && l.id <= hi;
      }
      if (/^-?\d+$/.test(term)) return (l) => l.name.startsWith(term);
      return (l) => (l.name + ' ' + modelText(l) + ' ' + (l.status ? recentFitText(l.status.recent_fit) : ''))
        .toLowerCase().includes(term);
    });
    return (l) => tests.some((test) => test(l));
  }

  function compareLinks(column, descending) {
    return (a, b) => {
      const x = column.value(a);
      const y = column.value(b);
      if (x === null || y === null) return x === null && y === null ? a.id - b.id : (x === null ? -1 : 1);
      const order = typeof x === 'string' ? x.localeCompare(y) : x - y;
      return (descending ? -order : order) || a.id - b.id;
    };
  }

  function setupLinkTable() {
    const head = $('link-table').tHead.rows[0];
    head.replaceChildren(...LINK_COLUMNS.map((column) => {
      const button = el('button', { type: 'button', 'data-sort': column.key, text: column.label });
      if (column.title) button.title = column.title + ' — sort by it';
      button.addEventListener('click', () => {
        linkTable.descending = linkTable.sort === column.key ? !linkTable.descending : false;
        linkTable.sort = column.key;
        view.dirty.links = true;
        requestRender();
      });
      return el('th', { scope: 'col', 'data-sort': column.key }, [button]);
    }));
    $('link-search').addEventListener('input', (event) => {
      linkTable.query = event.target.value;
      linkTable.shown = TABLE_ROWS;
      view.dirty.links = true;
      requestRender();
    });
    $('link-table-more').addEventListener('click', () => {
      linkTable.shown += TABLE_ROWS;
      view.dirty.links = true;
      requestRender();
    });
    const body = $('link-table').tBodies[0];
    const pick = (event) => {
      const row = event.target.closest('tr[data-link]');
      if (row) selectLink(row.dataset.link === 'control' ? CONTROL_LINK_ID : Number(row.dataset.link));
    };
    body.addEventListener('click', pick);
    body.addEventListener('keydown', (event) => { if (event.key === 'Enter' || event.key === ' ') { event.preventDefault(); pick(event); } });
  }

  // Table mode: show the card of one link (its parameters read and followed while shown).
  function selectLink(id) {
    const link = store.links.get(id);
    if (!link || store.selectedLink === id) return;
    const previous = store.links.get(store.selectedLink);
    if (previous) previous.unmount();
    store.selectedLink = id;
    $('link-table-hint').hidden = true;
    link.mount($('links'));
    if (conn.capabilities.includes('parameters')) {
      send({ op: 'getParameters', parameterNames: link.parameterNames(), id: 'netkf-dashboard-select-' + link.name });
    }
    subscribeParameterUpdates();
    view.dirty.links = true;
    requestRender();
  }

  function renderLinkTable() {
    const started = performance.now();
    const column = LINK_COLUMNS.find((c) => c.key === linkTable.sort) || LINK_COLUMNS[0];
    const matches = linkMatcher(linkTable.query);
    const rows = [...store.links.values()].filter(matches).sort(compareLinks(column, linkTable.descending));
    const shown = rows.slice(0, linkTable.shown);
    linkTable.rowsShown = shown.map((l) => l.name);
    $('link-table').tBodies[0].replaceChildren(...shown.map((l) => {
      const selected = l.id === store.selectedLink;
      return el('tr', { 'data-link': l.name, tabindex: '0', class: selected ? 'selected' : '', 'aria-selected': String(selected) },
        LINK_COLUMNS.map((c) => el('td', { 'data-col': c.key, text: c.text(l) })));
    }));
    for (const th of $('link-table').tHead.rows[0].cells) {
      const sorted = th.dataset.sort === column.key;
      th.setAttribute('aria-sort', sorted ? (linkTable.descending ? 'descending' : 'ascending') : 'none');
    }
    $('link-table-count').textContent = store.links.size + ' links' +
      (linkTable.query.trim() ? ', ' + rows.length + ' match' : '') + ', showing ' + shown.length +
      ', by ' + column.label + (linkTable.descending ? ' (highest first)' : ' (lowest first)');
    $('link-table-more').hidden = rows.length <= shown.length;
    dash.linkTableMs = Math.round((performance.now() - started) * 10) / 10;
  }

  // --------------------------------------------------------------- charts
  const charts = { trace: null, states: [] };
  const syncKey = 'netkf-time';
  const emptyData = (seriesCount) => Array.from({ length: seriesCount + 1 }, () => []);

  function timeChart(box, height, series, scales, hooks, options) {
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
      view.dirty.links = true;
      view.dirty.region = true;
      requestRender();
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

  function buildStateCharts(n) {
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
  function buildTraceChart() {
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

  // ------------------------------------------------------------ rendering
  let renderQueued = false;
  let lastChartDraw = -Infinity;
  let lastLinkDraw = -Infinity;
  let lastTextDraw = -Infinity;
  let redrawCost = 0;                 // smoothed milliseconds of one chart redraw
  let redrawInterval = MIN_REDRAW_MS;

  // Called on every message; at most one render is pending. A render that is not due yet
  // waits on a timer (not on back-to-back animation frames, which would repaint for nothing).
  function requestRender(delayMs) {
    if (renderQueued) return;
    renderQueued = true;
    if (delayMs > 0) setTimeout(() => requestAnimationFrame(render), delayMs);
    else requestAnimationFrame(render);
  }

  function markAllDirty() {
    for (const key of Object.keys(view.dirty)) view.dirty[key] = true;
    lastTextDraw = -Infinity;
    lastChartDraw = -Infinity;
    lastLinkDraw = -Infinity;
    requestRender();
  }

  function render(now) {
    renderQueued = false;
    const d = view.dirty;
    let wait = Infinity;
    // Header and stability texts: a period number changing 50 times a second is unreadable anyway.
    if (d.header || d.theory || d.network) {
      if (now - lastTextDraw >= TEXT_REDRAW_MS) {
        lastTextDraw = now;
        if (d.header) { d.header = false; renderHeader(); }
        if (d.theory) { d.theory = false; renderVerdict(); }
        if (d.network) { d.network = false; renderNetwork(); }
      } else {
        wait = Math.min(wait, TEXT_REDRAW_MS - (now - lastTextDraw));
      }
    }
    if (!view.paused) wait = Math.min(wait, renderCharts(now));
    if (wait < Infinity) requestRender(Math.max(1, wait));
  }

  // Draws what is due; returns the milliseconds until the next chart work is due (or Infinity).
  function renderCharts(now) {
    const d = view.dirty;
    let wait = Infinity;
    const started = performance.now();
    let drew = false;
    if (d.data) {
      if (now - lastChartDraw >= redrawInterval) {
        lastChartDraw = now;
        d.data = false;
        d.slowData = true;
        renderTimeCharts();
        drew = true;
      } else {
        wait = Math.min(wait, redrawInterval - (now - lastChartDraw));
      }
    }
    // Link panels change about once a second: fewer canvases to redraw and hand over.
    if (d.links || d.slowData) {
      if (now - lastLinkDraw >= LINK_REDRAW_MS) {
        lastLinkDraw = now;
        d.links = false;
        d.slowData = false;
        renderLinks();
        drew = true;
      } else {
        wait = Math.min(wait, LINK_REDRAW_MS - (now - lastLinkDraw));
      }
    }
    if (d.region) {
      d.region = false;
      renderRegion();
    }
    if (drew) {
      // A slow machine redraws less often instead of spending every frame on charts: at
      // most about a fifth of the time goes to drawing. uPlot draws in a microtask queued
      // by setData, so the cost is read in a microtask queued after it.
      queueMicrotask(() => {
        const spent = performance.now() - started;
        redrawCost = 0.8 * redrawCost + 0.2 * spent;
        redrawInterval = Math.min(MAX_REDRAW_MS, Math.max(MIN_REDRAW_MS, 5 * redrawCost));
        dash.redrawMs = Math.round(redrawCost * 10) / 10;
      });
    }
    return wait;
  }

  function currentTime() {
    const ring = store.ring;
    if (!ring || ring.maxK < 0) return null;
    const i = ring.find(ring.maxK);
    return i >= 0 ? ring.t[i] : ring.maxK * store.periodS;
  }

  // Periods [kLo, kHi] of the selected window that the ring holds.
  function windowPeriods() {
    const ring = store.ring;
    if (!ring || ring.maxK < 0) return null;
    const span = Math.max(1, Math.round(view.windowS / store.periodS));
    const kHi = ring.maxK;
    const kLo = Math.max(kHi - span + 1, ring.firstK, kHi - ring.cap + 1, 0);
    return { kLo, kHi, span };
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

  function renderTimeCharts() {
    if (!charts.trace) return;
    const ring = store.ring;
    const w = windowPeriods();
    if (!w) {
      view.tLo = 0;
      view.tHi = view.windowS;
      charts.trace.setData(emptyData(charts.trace.series.length - 1));
      for (const chart of charts.states) chart.setData(emptyData(chart.series.length - 1));
      dash.pointsPlotted = 0;
      dash.finalPointsPlotted = 0;
      dash.plotLengths = { trace: 0, states: charts.states.map(() => 0) };
      return;
    }
    const timeOf = (k) => {
      const i = ring.find(k);
      return i >= 0 ? ring.t[i] : k * store.periodS;
    };
    // The window ends now; until it has filled it starts at the oldest period held.
    const tNow = currentTime();
    view.tHi = tNow;
    view.tLo = Math.max(tNow - view.windowS, Math.min(timeOf(w.kLo), tNow - 1));

    // More periods than pixels: buckets of `stride` periods (aligned to multiples of the
    // stride so they do not shimmer as the window slides), each drawn as its envelope.
    const plotPx = Math.max(100, Math.round(charts.trace.bbox.width / (window.devicePixelRatio || 1)) || 600);
    const stride = Math.max(1, Math.ceil((w.kHi - w.kLo + 1) / plotPx));
    const n = ring.n;
    // Tr P pred, Tr P, then per component truth, x̂, x̂+2σ, x̂−2σ; with fuse_within then the final
    // estimates' Tr P pred and per component final x̂ (a period never revised: its in-time one).
    const final = store.fuseWithin;
    const finalBase = 2 + 4 * n;
    const seriesCount = finalBase + (final ? 1 + n : 0);
    const envelopes = Array.from({ length: seriesCount }, () => new Envelope());
    const outs = Array.from({ length: seriesCount }, () => []);
    const xs = [];
    const confLower = [];
    const confUpper = [];
    const obsLower = [];
    const obsUpper = [];
    const finLower = [];
    const finUpper = [];
    traceRows.theory = [];
    traceRows.diverging = [];
    // The theory entry in force for period k is the last one computed at or before k.
    const theory = store.theory;
    let theoryIndex = -1;
    const pushTheory = (k) => {
      while (theoryIndex + 1 < theory.length && theory.at(theoryIndex + 1).k <= k) theoryIndex++;
      const entry = theoryIndex >= 0 ? theory.at(theoryIndex) : null;
      traceRows.theory.push(entry);
      confLower.push(entry && isNum(entry.confLower) ? entry.confLower : null);
      confUpper.push(entry && isNum(entry.confUpper) ? entry.confUpper : null);
      obsLower.push(entry && isNum(entry.obsLower) ? entry.obsLower : null);
      obsUpper.push(entry && isNum(entry.obsUpper) ? entry.obsUpper : null);
      finLower.push(entry && isNum(entry.finLower) ? entry.finLower : null);
      finUpper.push(entry && isNum(entry.finUpper) ? entry.finUpper : null);
    };
    const num = (v) => (Number.isNaN(v) ? null : v);
    let estimatePoints = 0;
    let finalPoints = 0;
    for (let b = w.kLo - (w.kLo % stride); b <= w.kHi; b += stride) {
      const first = Math.max(b, w.kLo);
      const last = Math.min(b + stride - 1, w.kHi);
      let diverging = false;
      for (const e of envelopes) e.reset();
      for (let k = first; k <= last; k++) {
        const i = ring.find(k);
        if (i < 0) continue;
        const hasEst = ring.hasEstimate[i] === 1;
        if (hasEst) {
          estimatePoints++;
          if (ring.diverging[i]) diverging = true;
          // A log axis cannot show 0 or negative traces.
          const tp = num(ring.tracePred[i]);
          const tf = num(ring.trace[i]);
          envelopes[0].add(tp !== null && tp > 0 ? tp : null, k);
          envelopes[1].add(tf !== null && tf > 0 ? tf : null, k);
          if (final) {
            const revised = ring.hasFinal[i] === 1;
            if (revised) finalPoints++;
            const tpf = revised ? num(ring.tracePredFinal[i]) : tp;
            envelopes[finalBase].add(tpf !== null && tpf > 0 ? tpf : null, k);
            for (let c = 0; c < n; c++) envelopes[finalBase + 1 + c].add(num((revised ? ring.xHatFinal : ring.xHat)[c][i]), k);
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
      }
      if (last === first) {
        xs.push(timeOf(first));
        for (let sIdx = 0; sIdx < seriesCount; sIdx++) envelopes[sIdx].emitOne(outs[sIdx]);
        pushTheory(first);
        traceRows.diverging.push(diverging);
      } else {
        xs.push(timeOf(first), timeOf(last));
        for (let sIdx = 0; sIdx < seriesCount; sIdx++) envelopes[sIdx].emitTwo(outs[sIdx]);
        pushTheory(first);
        pushTheory(last);
        traceRows.diverging.push(diverging, diverging);
      }
    }
    const traceData = [xs, outs[0], outs[1], confLower, confUpper, obsLower, obsUpper];
    if (final) traceData.push(outs[finalBase], finLower, finUpper);
    charts.trace.setData(traceData);
    charts.states.forEach((chart, c) => {
      const base = 2 + 4 * c;
      const data = [xs, outs[base], outs[base + 1], outs[base + 2], outs[base + 3]];
      if (final) data.push(outs[finalBase + 1 + c]);
      chart.setData(data);
    });
    dash.pointsPlotted = charts.states.length ? estimatePoints : 0;
    dash.finalPointsPlotted = finalPoints;
    Object.assign(dash.plotLengths, {
      trace: charts.trace.data[0].length,
      states: charts.states.map((chart) => chart.data[0].length),
      stride,
    });
    renderTraceNotes();
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

  function renderLinks() {
    const w = windowPeriods();
    const ring = store.ring;
    const tLo = view.tLo;
    if (store.tableMode) renderLinkTable();
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

  function canvasContext(canvas, cssHeight) {
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

  // The (λ1, λ2) plane: above lambda2_upper stable, below lambda2_lower unstable, between
  // undecided by the bounds; the operating point is where the links are now.
  function renderRegion() {
    const box = $('region-box');
    if (box.hidden) return;
    const canvas = $('region-canvas');
    const { ctx, width, height } = canvasContext(canvas, 250);
    const pad = { left: 40, right: 120, top: 10, bottom: 34 };
    const pw = width - pad.left - pad.right;
    const ph = height - pad.top - pad.bottom;
    const X = (v) => pad.left + v * pw;
    const Y = (v) => pad.top + (1 - v) * ph;
    const clamp = (v) => Math.min(1, Math.max(0, v));
    const th = store.latestTheory;
    const region = th && Array.isArray(th.region) ? th.region.filter((p) => isNum(p.lambda1)).sort((a, b) => a.lambda1 - b.lambda1) : [];
    ctx.font = '11px system-ui, sans-serif';
    if (region.length >= 2) {
      // A missing upper curve means no λ2 is proven stable; a missing lower, none proven unstable.
      const lower = region.map((p) => [p.lambda1, isNum(p.lambda2_lower) ? clamp(p.lambda2_lower) : 0]);
      const upper = region.map((p) => [p.lambda1, isNum(p.lambda2_upper) ? clamp(p.lambda2_upper) : 1]);
      const fillBetween = (a, b, color) => {
        ctx.beginPath();
        a.forEach(([x, y], i) => (i ? ctx.lineTo(X(x), Y(y)) : ctx.moveTo(X(x), Y(y))));
        for (let i = b.length - 1; i >= 0; i--) ctx.lineTo(X(b[i][0]), Y(b[i][1]));
        ctx.closePath();
        ctx.fillStyle = color;
        ctx.fill();
      };
      const x0 = region[0].lambda1;
      const x1 = region[region.length - 1].lambda1;
      fillBetween([[x0, 0], [x1, 0]], lower, COLOR.unstable);
      fillBetween(lower, upper, COLOR.undecided);
      fillBetween(upper, [[x0, 1], [x1, 1]], COLOR.stable);
      const curve = (pts, color) => {
        ctx.beginPath();
        pts.forEach(([x, y], i) => (i ? ctx.lineTo(X(x), Y(y)) : ctx.moveTo(X(x), Y(y))));
        ctx.strokeStyle = color;
        ctx.lineWidth = 1.5;
        ctx.stroke();
      };
      curve(lower, COLOR.lowerCurve);
      curve(upper, COLOR.upperCurve);
    } else {
      ctx.fillStyle = COLOR.axis;
      ctx.fillText('waiting for netkf/theory.region', X(0.2), Y(0.5));
    }
    // Axes and ticks.
    ctx.strokeStyle = COLOR.axis;
    ctx.lineWidth = 1;
    ctx.strokeRect(X(0) + 0.5, Y(1) + 0.5, pw, ph);
    ctx.fillStyle = COLOR.axis;
    for (let v = 0; v <= 1.0001; v += 0.25) {
      ctx.textAlign = 'center';
      ctx.fillText(v.toFixed(2), X(v), Y(0) + 13);
      ctx.textAlign = 'right';
      ctx.fillText(v.toFixed(2), X(0) - 4, Y(v) + 4);
    }
    const ids = store.sensorIds;
    ctx.textAlign = 'center';
    ctx.fillText('λ1 (arrival rate of link ' + (ids[0] !== undefined ? ids[0] : 1) + ')', X(0.5), height - 4);
    ctx.save();
    ctx.translate(10, Y(0.5));
    ctx.rotate(-Math.PI / 2);
    ctx.fillText('λ2 (link ' + (ids[1] !== undefined ? ids[1] : 2) + ')', 0, 0);
    ctx.restore();
    // Operating points: configured (filled) and observed (ring, with its recent trail).
    const point = operatingPoints();
    if (point.observed) {
      const last = store.regionTrail.last();
      if (!last || last[0] !== point.observed[0] || last[1] !== point.observed[1]) store.regionTrail.push(point.observed);
    }
    ctx.fillStyle = COLOR.observed;
    store.regionTrail.forEach((p, i) => {
      ctx.globalAlpha = 0.1 + 0.4 * (i / REGION_TRAIL);
      ctx.beginPath();
      ctx.arc(X(clamp(p[0])), Y(clamp(p[1])), 2.5, 0, 2 * Math.PI);
      ctx.fill();
    });
    ctx.globalAlpha = 1;
    if (point.observed) {
      ctx.beginPath();
      ctx.arc(X(clamp(point.observed[0])), Y(clamp(point.observed[1])), 6, 0, 2 * Math.PI);
      ctx.strokeStyle = COLOR.observed;
      ctx.lineWidth = 2.5;
      ctx.stroke();
    }
    if (point.configured) {
      ctx.beginPath();
      ctx.arc(X(clamp(point.configured[0])), Y(clamp(point.configured[1])), 5, 0, 2 * Math.PI);
      ctx.fillStyle = COLOR.truth;
      ctx.fill();
    }
    // Legend on the right.
    const lx = pad.left + pw + 12;
    let ly = pad.top + 12;
    const legend = (draw, text) => { draw(lx, ly); ctx.fillStyle = COLOR.axis; ctx.textAlign = 'left'; ctx.fillText(text, lx + 18, ly + 4); ly += 18; };
    const swatch = (color) => (x, y) => { ctx.fillStyle = color; ctx.fillRect(x, y - 5, 12, 10); };
    legend(swatch(COLOR.stable), 'stable');
    legend(swatch(COLOR.undecided), 'undecided');
    legend(swatch(COLOR.unstable), 'unstable');
    legend((x, y) => { ctx.beginPath(); ctx.arc(x + 6, y, 5, 0, 2 * Math.PI); ctx.fillStyle = COLOR.truth; ctx.fill(); }, 'configured');
    legend((x, y) => { ctx.beginPath(); ctx.arc(x + 6, y, 5, 0, 2 * Math.PI); ctx.strokeStyle = COLOR.observed; ctx.lineWidth = 2.5; ctx.stroke(); }, 'observed (since change)');
    ly += 6;
    const fmtPoint = (p) => (p ? '(' + p[0].toFixed(2) + ', ' + p[1].toFixed(2) + ')' : '—');
    ctx.fillStyle = COLOR.axis;
    ctx.fillText('conf ' + fmtPoint(point.configured), lx, ly); ly += 15;
    ctx.fillText('obs  ' + fmtPoint(point.observed), lx, ly);
  }

  // Arrival rates of the two links: from the link status (updated right after a change),
  // else from the last theory assessment. Observed: since change, the rate the theory assesses.
  function operatingPoints() {
    const ids = store.sensorIds;
    const pick = (field, assessment) => {
      const values = ids.map((id) => {
        const link = store.links.get(id);
        return link && link.status && isNum(link.status[field]) ? link.status[field] : null;
      });
      if (values.every(isNum)) return values;
      const rates = assessment && assessment.arrival_rates;
      return Array.isArray(rates) && rates.length === ids.length && rates.every(isNum) ? rates : null;
    };
    const th = store.latestTheory || {};
    return {
      configured: pick('configured_arrival_rate', th.configured),
      observed: pick('observed_arrival_rate_since_change', th.observed),
    };
  }

  function renderHeader() {
    const e = store.latestEstimate;
    $('period').textContent = e && isNum(e.k) ? String(e.k) : '—';
    $('time').textContent = e && isNum(e.t) ? e.t.toFixed(2) + ' s' : '—';
    const state = $('filter-state');
    state.textContent = e ? String(e.state) : '—';
    state.dataset.state = e ? String(e.state) : '';
    const nw = store.latestNetwork;
    $('rms-error').textContent = nw ? fmt(nw.rms_error, 3) : '—';
    // Closed loop: the running mean cost, beside the theory's bounds on J when it has them
    // (acknowledged inputs, LQR weights); the summary's `cost` at the end of the run.
    const cost = nw && isNum(nw.mean_cost) ? nw.mean_cost : null;
    $('running-cost-stat').hidden = cost === null;
    const costCell = $('running-cost');
    if (cost !== null) {
      const act = store.latestTheory && store.latestTheory.configured && store.latestTheory.configured.actuation;
      const bounds = act && isNum(act.cost_lower) && isNum(act.cost_upper)
        ? ' (J ∈ [' + fmt(act.cost_lower, 3) + ', ' + fmt(act.cost_upper, 3) + '])' : '';
      costCell.textContent = fmt(cost, 4) + bounds;
      costCell.dataset.value = String(cost);
      costCell.dataset.periods = String(nw.periods_costed);
    }
    if (nw && Array.isArray(nw.processes)) {
      const running = nw.processes.filter((p) => p.running).length;
      const restarts = nw.processes.reduce((sum, p) => sum + (p.restarts | 0), 0);
      const summary = $('processes-summary');
      summary.textContent = running + '/' + nw.processes.length + ' running' + (restarts ? ', ' + restarts + ' restarts' : '');
      summary.dataset.state = running === nw.processes.length ? 'ok' : 'down';
    }
  }

  const STABLE_TEXT = { yes: 'stable', no: 'unstable', unknown: 'undecided' };

  function renderVerdict() {
    const th = store.latestTheory;
    const verdict = $('verdict');
    if (!th) return;
    const conf = th.configured || null;
    const obs = th.observed || null;
    const confStable = conf ? String(conf.stable) : 'unknown';
    const obsStable = obs ? String(obs.stable) : 'none';
    const fin = store.fuseWithin ? (th.final_estimate || null) : null;
    const finStable = fin ? String(fin.stable) : 'none';
    verdict.dataset.configured = confStable;
    verdict.dataset.observed = obsStable;
    verdict.dataset.final = finStable;
    dash.finalVerdict = fin ? finStable : null;
    verdict.replaceChildren(
      el('span', { class: 'verdict-main', 'data-stable': confStable, text: STABLE_TEXT[confStable] || confStable }),
      document.createTextNode(' '),
      el('span', { class: 'verdict-detail', text: 'configured: ' + (STABLE_TEXT[confStable] || confStable) +
        ' · observed (since change): ' + (obs ? (STABLE_TEXT[obsStable] || obsStable) : 'not yet known') +
        (store.fuseWithin ? ' · final estimates: ' + (fin ? (STABLE_TEXT[finStable] || finStable) : 'not yet known') : '') }),
      document.createTextNode(' '),
      el('span', { class: 'verdict-k muted small', text: '(at k ' + th.k + ')' }));
    const set = (field, text, cls) => {
      const cell = document.querySelector('#assessment [data-field="' + field + '"]');
      cell.textContent = text;
      cell.className = (field.startsWith('fin-') ? 'final-col ' : '') + (cls || '');
    };
    const fill = (prefix, a) => {
      if (!a) {
        for (const f of ['stable', 'markov', 'lower', 'upper', 'rates']) set(prefix + '-' + f, '—');
        return;
      }
      set(prefix + '-stable', STABLE_TEXT[a.stable] || String(a.stable), 'stable-' + a.stable);
      const markov = a.markov_criterion;
      set(prefix + '-markov', isNum(markov) ? fmt(markov, 3) + (markov < 1 ? ' < 1' : ' ≥ 1') : 'n/a',
        isNum(markov) ? (markov < 1 ? 'stable-yes' : 'stable-no') : 'muted');
      set(prefix + '-lower', fmtTrace(a.lower_trace, '∞ (unbounded)'), isNum(a.lower_trace) ? '' : 'stable-no');
      set(prefix + '-upper', fmtTrace(a.upper_trace, a.stable === 'no' ? '∞ (unbounded)' : '∞ / undecided'), isNum(a.upper_trace) ? '' : 'muted');
      // Three decimals, as the link cards show the same rates; many links: their range.
      set(prefix + '-rates', Array.isArray(a.arrival_rates) ? ratesText(a.arrival_rates) : '—');
    };
    fill('conf', conf);
    fill('obs', obs);
    fill('fin', fin);
    const reasons = [];
    if (conf && conf.reason) reasons.push('configured: ' + conf.reason);
    if (obs && obs.reason) reasons.push('observed (since change): ' + obs.reason);
    if (fin && fin.reason) reasons.push('final estimates: ' + fin.reason);
    $('assessment-reason').textContent = reasons.join(' · ');
  }

  // The assessment's arrival rates (scenario order): each, or, for more links than cards, the
  // lowest with its link, the mean and the highest (the link table has each).
  function ratesText(rates) {
    if (rates.length <= CARD_LINK_LIMIT || !rates.every(isNum)) return rates.map(rateText).join(', ');
    let lowest = 0;
    let highest = 0;
    rates.forEach((r, i) => { if (r < rates[lowest]) lowest = i; if (r > rates[highest]) highest = i; });
    const mean = rates.reduce((a, b) => a + b, 0) / rates.length;
    const id = (i) => (i < store.sensorIds.length ? ' (link ' + store.sensorIds[i] + ')' : '');
    return rates.length + ' links: lowest ' + rateText(rates[lowest]) + id(lowest) + ', mean ' + rateText(mean) +
      ', highest ' + rateText(rates[highest]);
  }

  function renderNetwork() {
    const nw = store.latestNetwork;
    if (!nw) return;
    const body = document.querySelector('#process-table tbody');
    body.replaceChildren(...(nw.processes || []).map((p) => el('tr', { class: p.running ? '' : 'down' }, [
      el('td', { text: String(p.name), title: String(p.name) }), el('td', { text: String(p.host || '') }), el('td', { text: String(p.pid) }),
      el('td', { text: p.running ? 'yes' : 'no' }), el('td', { text: String(p.restarts) })])));
    $('network-counters').textContent = 'estimates ' + nw.estimates + ' · mean Tr P ' + fmt(nw.mean_trace_P, 3) +
      ' · mean Tr P k|k−1 ' + fmt(nw.mean_trace_P_pred, 3) + ' · late ' + nw.late_total + ' · rejected ' + nw.rejected_total +
      ' · invalid samples ' + nw.invalid_samples;
  }

  // ------------------------------------------------------------- controls
  function clearData() {
    if (store.ring) store.ring.clear();
    store.theory.clear();
    store.regionTrail.clear();
    for (const link of store.links.values()) link.rates.clear();
    markAllDirty();
  }

  function setupViewControls() {
    const select = $('window-select');
    view.windowS = Number(select.value) || 30;
    select.addEventListener('change', () => {
      view.windowS = Number(select.value) || 30;
      markAllDirty();
    });
    const pause = $('pause-button');
    pause.addEventListener('click', () => {
      view.paused = !view.paused;
      pause.textContent = view.paused ? 'Resume' : 'Pause';
      pause.setAttribute('aria-pressed', String(view.paused));
      document.body.classList.toggle('paused', view.paused);
      markAllDirty();
    });
    $('clear-button').addEventListener('click', clearData);
  }

  function start() {
    setupViewControls();
    setupLinkTable();
    buildTraceChart();
    renderTimeCharts();
    connect();
  }

  if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', start);
  else start();
})();
