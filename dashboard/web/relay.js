// netkf relay's page (docs/relay.md, "The page"): a card per relayed topic from the relay's
// netkf/link/status channel (foxglove.websocket.v1 on this page's own host), a plot of its loss
// over time (uPlot, loaded before this module as the global uPlot), and a form that changes the
// topic's link with a setParameters of link.ID.KEY (ID the topic's negative link id). Every
// string from the network goes into the page as text (textContent), never as HTML.
import { linkModelsOf } from './link_models.js';

const SUBPROTOCOL = 'foxglove.websocket.v1';
const STATUS_TOPIC = 'netkf/link/status';
const PENDING_TIMEOUT_MS = 5000;  // a setParameters without answer is given up after this
const PLOT_POINTS = 600;  // the statuses a plot keeps (one a second, and one after each change)

const $ = (id) => document.getElementById(id);
const cards = new Map();  // link id (sensor_id) -> Card
const conn = { ws: null, attempt: 0, subscriptions: new Map(), nextSubscription: 1, nextRequest: 1 };
const pending = new Map();  // request id -> { card, errors: [] }

function el(tag, attrs = {}, text = '') {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  if (text) node.textContent = text;
  return node;
}

function number(v, digits = 4) {
  return typeof v === 'number' && Number.isFinite(v) ? String(+v.toFixed(digits)) : '—';
}

function addEvent(text) {
  const list = $('events');
  const item = el('li', {}, new Date().toLocaleTimeString() + '  ' + text);
  list.prepend(item);
  while (list.children.length > 100) list.lastChild.remove();
}

// The link models as the relay's channel catalogue describes them (the link status schema's
// `model` property, x-netkf-models; docs/dashboard.md): name -> its parameter keys in order.
const modelKeys = new Map();

// A schema without models: each card names its model alone.
function takeLinkModels(schemaText) {
  modelKeys.clear();
  for (const { name, keys } of linkModelsOf(schemaText) || []) modelKeys.set(name, keys);
}

// The model and its parameters in words, from the status's link keys: the name and each key of
// the model ("bernoulli loss=0.3", "gilbert_elliott p=0.05 r=0.25 loss_good=0 loss_bad=1"); a
// model the catalogue does not describe (trace) by its name alone.
function modelText(s) {
  const model = typeof s.model === 'string' ? s.model : '?';
  return [model, ...(modelKeys.get(model) || []).map((key) => key + '=' + number(s[key]))].join(' ');
}

// The delay a delivered sample is held for: fixed, or with jitter and its distribution.
function delayText(s) {
  if (!(s.delay_ms > 0) && !(s.jitter_ms > 0)) return 'none';
  const jitter = s.jitter_ms > 0 ? ' ± ' + number(s.jitter_ms, 3) + ' ms' +
    (typeof s.delay_distribution === 'string' ? ' (' + s.delay_distribution + ')' : '') : '';
  return number(s.delay_ms, 3) + ' ms' + jitter;
}

const FIELDS = [
  ['topic', 'topic'], ['type', 'type'], ['link id', 'sensor_id'], ['model', 'model'], ['delay', 'delay'],
  // Since the link's last change (the relay's counts restart then); "since start" goes on.
  ['samples in', 'samples_in'], ['delivered', 'delivered'], ['dropped', 'dropped'],
  ['observed loss', 'observed_loss'], ['stationary loss', 'stationary_loss'],
  ['mean burst', 'mean_burst_length'], ['since start', 'lifetime'], ['held now', 'held'],
  ['last request', 'last_request'],
];

// The loss of a topic's link over time: per interval between two statuses (the samples in
// that interval), since the link's last change, and the model's stationary loss.
class LossPlot {
  constructor(parent) {
    this.data = [[], [], [], []];  // seconds, interval loss, observed loss, stationary loss
    this.last = null;  // the previous status's lifetime counts
    this.root = el('div', { class: 'relay-plot', 'data-points': '0' });
    parent.append(this.root);
    if (typeof uPlot !== 'function') {
      this.root.textContent = 'plot unavailable (uPlot did not load)';
      return;
    }
    const line = (label, stroke, dash) => ({ label, stroke, width: 1.5, dash, spanGaps: false, value: (u, v) => number(v) });
    this.plot = new uPlot({
      width: 360, height: 150,
      scales: { x: { time: true }, y: { range: [0, 1] } },
      series: [{}, line('loss per interval', '#d9534f'), line('observed since change', '#337ab7'),
        line('stationary (model)', '#555', [4, 4])],
      axes: [{}, { size: 40 }],
      legend: { live: false },
    }, this.data, this.root);
  }

  // One status: an interval's loss needs the counts of the status before it (null before that
  // and when no sample came in the interval).
  add(s) {
    const total = s.samples_total, dropped = s.dropped_total;
    let interval = null;
    if (this.last && Number.isInteger(total) && total > this.last.total) {
      interval = (dropped - this.last.dropped) / (total - this.last.total);
    }
    if (Number.isInteger(total) && Number.isInteger(dropped)) this.last = { total, dropped };
    const finite = (v) => (typeof v === 'number' && Number.isFinite(v) ? v : null);
    const row = [Date.now() / 1000, interval, finite(s.observed_loss), finite(s.stationary_loss)];
    row.forEach((v, i) => this.data[i].push(v));
    if (this.data[0].length > PLOT_POINTS) this.data.forEach((series) => series.shift());
    this.root.dataset.points = String(this.data[0].length);
    if (interval !== null) this.root.dataset.lastIntervalLoss = String(interval);  // the latest with samples
    if (this.plot) this.plot.setData(this.data);
  }
}

class Card {
  constructor(id) {
    this.id = id;
    this.root = el('section', { class: 'panel relay-card', 'data-link-id': String(id) });
    this.title = el('h2');
    this.root.append(this.title);
    const dl = el('dl');
    this.values = {};
    for (const [label, key] of FIELDS) {
      const dd = el('dd', { 'data-field': key });
      dl.append(el('dt', {}, label), dd);
      this.values[key] = dd;
    }
    this.root.append(el('div', { class: 'subhead' }, 'counts since the link\'s last change'), dl);
    this.plot = new LossPlot(this.root);
    this.root.append(this.makeForm());
    $('topics').append(this.root);
  }

  makeForm() {
    // novalidate: the relay judges the values and the card shows its reason for a refusal.
    const form = el('form', { class: 'relay-form', novalidate: '' });
    const input = (name, title, max = '1') => {
      const i = el('input', { name, type: 'number', min: '0', max, step: 'any', title });
      form.append(el('label', {}, name + ' '), i);
      return i;
    };
    this.loss = input('loss', 'Bernoulli loss (each sample dropped with this probability)');
    this.p = input('p', 'Gilbert-Elliott: P(good -> bad), optional');
    this.r = input('r', 'Gilbert-Elliott: P(bad -> good), optional');
    this.delay = input('delay_ms', 'hold each delivered sample this long (ms), optional', '');
    this.jitter = input('jitter_ms', 'plus a random delay of up to this (ms, the link\'s distribution), optional', '');
    form.append(el('button', { type: 'submit' }, 'set link'));
    this.answer = el('span', { class: 'relay-answer', role: 'status', 'data-state': 'none' });
    form.append(this.answer);
    form.addEventListener('submit', (event) => {
      event.preventDefault();
      this.submit();
    });
    return form;
  }

  // p and r given: a Gilbert-Elliott link (with the loss, if given, as its bad state's loss);
  // otherwise a Bernoulli link of the given loss; a delay or jitter alone keeps the loss model.
  // The relay judges the values. This short form is the page's own and names its two models
  // (another model is set by `netkf ctl set-link` or the relay's events file).
  submit() {
    const read = (i) => (i.value.trim() === '' ? null : Number(i.value));
    const loss = read(this.loss), p = read(this.p), r = read(this.r);
    const delay = read(this.delay), jitter = read(this.jitter);
    const values = {};
    if (p !== null || r !== null) {
      Object.assign(values, { model: 'gilbert_elliott' });
      if (p !== null) values.p = p;
      if (r !== null) values.r = r;
      if (loss !== null) values.loss_bad = loss;
    } else if (loss !== null) {
      Object.assign(values, { model: 'bernoulli', loss });
    }
    if (delay !== null) values.delay_ms = delay;
    if (jitter !== null) values.jitter_ms = jitter;
    if (!Object.keys(values).length) return this.show('refused', 'give a loss (or p and r), a delay or a jitter');
    const id = 'netkf-relay-page-' + (conn.nextRequest++);
    const parameters = Object.entries(values).map(([key, value]) => (typeof value === 'number'
      ? { name: 'link.' + this.id + '.' + key, value, type: 'float64' }
      : { name: 'link.' + this.id + '.' + key, value }));
    if (!send({ op: 'setParameters', parameters, id })) return this.show('refused', 'not connected');
    const timer = setTimeout(() => {
      if (pending.delete(id)) this.show('refused', 'no answer');
    }, PENDING_TIMEOUT_MS);
    pending.set(id, { card: this, errors: [], timer });
    this.show('pending', 'applying…');
  }

  show(state, text) {
    this.answer.dataset.state = state;
    this.answer.textContent = text;
  }

  update(s) {
    const topic = typeof s.topic === 'string' ? s.topic : 'link ' + this.id;
    this.title.textContent = topic;
    this.root.dataset.topic = topic;
    const v = this.values;
    v.topic.textContent = topic;
    v.type.textContent = typeof s.type === 'string' ? s.type : 'not reported';
    v.sensor_id.textContent = String(this.id);
    v.model.textContent = modelText(s);
    v.delay.textContent = delayText(s);
    v.held.textContent = String(s.held ?? '—');
    v.samples_in.textContent = String(s.samples_in ?? '—');
    v.delivered.textContent = String(s.delivered ?? '—');
    v.dropped.textContent = String(s.dropped ?? '—');
    v.observed_loss.textContent = number(s.observed_loss);
    v.stationary_loss.textContent = number(s.stationary_loss);
    v.mean_burst_length.textContent = number(s.mean_burst_length);
    v.lifetime.textContent = String(s.samples_total ?? '—') + ' in, ' + String(s.delivered_total ?? '—') +
      ' delivered, ' + String(s.dropped_total ?? '—') + ' dropped';
    v.last_request.textContent = !s.last_request_id ? 'none'
      : String(s.last_request_id) + (s.last_request_rejected ? ' refused: ' + String(s.reject_reason ?? '') : '');
    this.plot.add(s);
  }
}

function onLinkStatus(s) {
  if (typeof s !== 'object' || s === null || !Number.isInteger(s.sensor_id)) return;
  let card = cards.get(s.sensor_id);
  if (!card) {
    card = new Card(s.sensor_id);
    cards.set(s.sensor_id, card);
    $('no-topics').hidden = true;
  }
  card.update(s);
}

// A status (an error is the refusal of a change) goes to the request under way, if any.
function onStatus(msg) {
  const text = typeof msg.message === 'string' ? msg.message : '';
  if (msg.level === 2) for (const p of pending.values()) p.errors.push(text);
  addEvent((msg.level === 2 ? 'refused: ' : '') + text);
}

// The answer to a setParameters: applied, or refused with the reasons sent before it.
function onParameterValues(msg) {
  const p = pending.get(msg.id);
  if (!p) return;
  pending.delete(msg.id);
  clearTimeout(p.timer);
  if (p.errors.length) p.card.show('refused', 'refused: ' + p.errors.join('; '));
  else p.card.show('applied', 'applied');
}

function send(message) {
  if (!conn.ws || conn.ws.readyState !== WebSocket.OPEN) return false;
  conn.ws.send(JSON.stringify(message));
  return true;
}

function onAdvertise(channels) {
  const subscriptions = [];
  for (const channel of channels) {
    if (channel.topic !== STATUS_TOPIC || channel.encoding !== 'json') continue;
    takeLinkModels(channel.schema);
    const id = conn.nextSubscription++;
    conn.subscriptions.set(id, channel.topic);
    subscriptions.push({ id, channelId: channel.id });
  }
  if (subscriptions.length) send({ op: 'subscribe', subscriptions });
}

function handleText(text) {
  let msg;
  try {
    msg = JSON.parse(text);
  } catch (err) {
    return;
  }
  if (msg.op === 'serverInfo' && typeof msg.name === 'string') $('server-name').textContent = msg.name;
  else if (msg.op === 'advertise') onAdvertise(Array.isArray(msg.channels) ? msg.channels : []);
  else if (msg.op === 'status') onStatus(msg);
  else if (msg.op === 'parameterValues') onParameterValues(msg);
}

const decoder = new TextDecoder('utf-8');

// messageData: opcode 0x01, uint32 LE subscription id, uint64 LE timestamp, JSON payload.
function handleBinary(buffer) {
  if (buffer.byteLength < 13) return;
  const dv = new DataView(buffer);
  if (dv.getUint8(0) !== 0x01 || conn.subscriptions.get(dv.getUint32(1, true)) !== STATUS_TOPIC) return;
  try {
    onLinkStatus(JSON.parse(decoder.decode(new Uint8Array(buffer, 13))));
  } catch (err) {
    addEvent('an undecodable status was ignored');
  }
}

function setConnState(state, text) {
  $('conn-state').dataset.state = state;
  $('conn-state').textContent = text;
}

function wsUrl() {
  const token = new URLSearchParams(window.location.search).get('token');
  const scheme = window.location.protocol === 'https:' ? 'wss:' : 'ws:';
  return scheme + '//' + window.location.host + '/' + (token ? '?token=' + encodeURIComponent(token) : '');
}

function connect() {
  setConnState('connecting', conn.attempt ? 'reconnecting…' : 'connecting…');
  let ws;
  try {
    ws = new WebSocket(wsUrl(), [SUBPROTOCOL]);
  } catch (err) {
    return scheduleReconnect();
  }
  ws.binaryType = 'arraybuffer';
  conn.ws = ws;
  conn.subscriptions.clear();
  ws.onopen = () => {
    conn.attempt = 0;
    setConnState('connected', 'connected');
  };
  ws.onmessage = (event) => (typeof event.data === 'string' ? handleText(event.data) : handleBinary(event.data));
  ws.onclose = () => {
    if (conn.ws !== ws) return;
    conn.ws = null;
    scheduleReconnect();
  };
}

function scheduleReconnect() {
  // Backoff with jitter, 0.5 s .. 10 s: a relay that has ended is not hammered.
  const delay = Math.min(10000, 500 * 2 ** conn.attempt) * (0.75 + 0.5 * Math.random());
  conn.attempt++;
  setConnState('disconnected', 'disconnected — retry in ' + (delay / 1000).toFixed(1) + ' s');
  setTimeout(connect, delay);
}

connect();
