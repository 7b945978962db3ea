// An independent foxglove.websocket.v1 client (@foxglove/ws-protocol's FoxgloveClient
// over the `ws` package) for the e2e tests of `netkf launch`'s dashboard server. It
// subscribes to netkf/estimate, optionally changes parameters, and prints one JSON object
// with everything it received. The Python e2e test does the assertions.
//
//   node tests/e2e/foxglove_client.mjs --url ws://127.0.0.1:8470/ --seconds 5
//        [--set link.2.loss=0.5 ...] [--set-after 1] [--get] [--subscribe-params]
//        [--raw '{"op":"bogus"}' ...] [--origin http://evil.example] [--token T]
//
// --set NAME=VALUE (repeatable): one setParameters request with all of them (numbers are
//   sent as float64, anything else as a string), sent --set-after seconds after connecting.
// --raw TEXT (repeatable): text frames sent as they are at the same moment (refusal tests).
// --get: getParameters with no names (all parameters) right after serverInfo.
// --subscribe-params: subscribeParameterUpdates for the links named by --set (or link.1..8).
// --origin: sends that Origin header; a refused upgrade is reported as refused/http_status.
// Exit status: 0 when it ran (connection refused or failed included: reported in the JSON);
// 2 usage error; 1 harness error.
import { parseArgs } from 'node:util';
// The package is CommonJS whose exports Node cannot name statically: take the default.
import foxgloveWsProtocol from '@foxglove/ws-protocol';
import WebSocket from 'ws';

const { FoxgloveClient } = foxgloveWsProtocol;

function usage(message) {
  process.stderr.write(`${message}\nusage: node foxglove_client.mjs --url ws://HOST:PORT/ --seconds N ` +
    '[--set NAME=VALUE ...] [--set-after S] [--get] [--subscribe-params] [--raw TEXT ...] [--origin ORIGIN] [--token T]\n');
  process.exit(2);
}

let options;
try {
  ({ values: options } = parseArgs({
    options: {
      url: { type: 'string' },
      seconds: { type: 'string', default: '3' },
      set: { type: 'string', multiple: true, default: [] },
      'set-after': { type: 'string', default: '1' },
      raw: { type: 'string', multiple: true, default: [] },
      get: { type: 'boolean', default: false },
      'subscribe-params': { type: 'boolean', default: false },
      origin: { type: 'string' },
      token: { type: 'string' },
      topic: { type: 'string', default: 'netkf/estimate' },
    },
  }));
} catch (err) {
  usage(err.message);
}
if (!options.url) usage('--url is required');
const seconds = Number(options.seconds);
const setAfter = Number(options['set-after']);
if (!(seconds > 0) || !(setAfter >= 0)) usage('--seconds must be > 0 and --set-after >= 0');

const setParameters = options.set.map((item) => {
  const eq = item.indexOf('=');
  if (eq <= 0) usage(`--set wants NAME=VALUE, got ${item}`);
  const name = item.slice(0, eq);
  const text = item.slice(eq + 1);
  const number = Number(text);
  // "nan"/"NaN" are sent as the JSON string they are: JSON has no NaN.
  return text.trim() !== '' && Number.isFinite(number) ? { name, value: number, type: 'float64' } : { name, value: text };
});

const result = {
  url: options.url,
  origin: options.origin ?? null,
  connected: false,
  refused: false,
  http_status: null,
  protocol: null,
  server_info: null,
  channels: [],
  topic: options.topic,
  subscribed: false,
  estimates: [],          // {k, t, x_hat, trace_P, trace_P_pred, fused, state, recv_ms}
  estimate_count: 0,
  messages_per_topic: {},
  parameter_values: [],   // {id, parameters, recv_ms}
  statuses: [],           // {level, message, id, recv_ms}
  set_request: null,      // {id, parameters, sent_at_ms}
  raw_sent: [],
  errors: [],
  close: null,            // {code, reason, at_ms}
  started_at_ms: Date.now(),
  finished_at_ms: null,
  error: null,
};

let url = options.url;
if (options.token) url += (url.includes('?') ? '&' : '?') + 'token=' + encodeURIComponent(options.token);
const headers = {};
if (options.origin) headers.Origin = options.origin;

const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL], { headers, handshakeTimeout: 5000 });
// A refused upgrade (403 for a foreign Origin, 401 without the token) is an observation.
ws.on('unexpected-response', (req, res) => {
  result.refused = true;
  result.http_status = res.statusCode;
  res.resume();
  req.destroy();
  finish();
});

const client = new FoxgloveClient({ ws });
const decoder = new TextDecoder();
const topicOfSubscription = new Map();
let finished = false;
let timer = null;

client.on('open', () => {
  result.connected = true;
  result.protocol = ws.protocol;
  timer = setTimeout(finish, seconds * 1000);
  setTimeout(sendRequests, setAfter * 1000);
});
client.on('error', (err) => { if (!result.refused) result.errors.push(String(err && err.message ? err.message : err)); });
client.on('close', (event) => {
  result.close = { code: event.code ?? null, reason: event.reason ? String(event.reason) : '', at_ms: Date.now() };
  finish();
});
client.on('serverInfo', (info) => {
  result.server_info = info;
  if (options.get) client.getParameters([], 'foxglove-client-get');
  if (options['subscribe-params']) {
    const links = new Set(setParameters.map((p) => p.name.split('.')[1]).filter(Boolean));
    if (!links.size) for (let i = 1; i <= 8; i++) links.add(String(i));
    const names = [];
    for (const id of links) for (const p of ['model', 'loss', 'p', 'r', 'loss_good', 'loss_bad', 'mean_burst', 'delay_ms', 'jitter_ms',
      'delay_distribution']) names.push(`link.${id}.${p}`);
    client.subscribeParameterUpdates(names);
  }
});
client.on('advertise', (channels) => {
  for (const channel of channels) {
    result.channels.push({ id: channel.id, topic: channel.topic, encoding: channel.encoding,
      schemaName: channel.schemaName, schemaEncoding: channel.schemaEncoding ?? null });
    if (channel.topic === options.topic) {
      topicOfSubscription.set(client.subscribe(channel.id), channel.topic);
      result.subscribed = true;
    }
  }
});
client.on('message', ({ subscriptionId, data }) => {
  const topic = topicOfSubscription.get(subscriptionId) ?? `subscription ${subscriptionId}`;
  result.messages_per_topic[topic] = (result.messages_per_topic[topic] || 0) + 1;
  let payload;
  try {
    payload = JSON.parse(decoder.decode(data));
  } catch (err) {
    result.errors.push(`undecodable payload on ${topic}: ${err.message}`);
    return;
  }
  if (topic === 'netkf/estimate') {
    result.estimate_count++;
    result.estimates.push({ k: payload.k, t: payload.t, x_hat: payload.x_hat, trace_P: payload.trace_P,
      trace_P_pred: payload.trace_P_pred, fused: payload.fused, state: payload.state, recv_ms: Date.now() });
  } else {
    // Another --topic: keep the payload itself.
    result.estimates.push({ ...payload, recv_ms: Date.now() });
  }
});
client.on('parameterValues', (msg) => {
  result.parameter_values.push({ id: msg.id ?? null, parameters: msg.parameters, recv_ms: Date.now() });
});
client.on('status', (msg) => {
  result.statuses.push({ level: msg.level, message: msg.message, id: msg.id ?? null, recv_ms: Date.now() });
});

function sendRequests() {
  if (finished || ws.readyState !== WebSocket.OPEN) return;
  if (setParameters.length) {
    const id = `foxglove-client-${process.pid}`;
    result.set_request = { id, parameters: setParameters, sent_at_ms: Date.now() };
    client.setParameters(setParameters, id);
  }
  for (const text of options.raw) {
    ws.send(text);
    result.raw_sent.push({ text, sent_at_ms: Date.now() });
  }
}

// A bug of this script: report it as a harness error (exit 1) with what was seen so far.
process.on('uncaughtException', (err) => {
  result.error = `harness error: ${err && err.message ? err.message : err}`;
  if (!finished) {
    finished = true;
    process.stdout.write(JSON.stringify(result) + '\n');
  }
  process.exit(1);
});

// Nothing answers at all (no server, a handshake that hangs): stop anyway.
const watchdog = setTimeout(() => {
  if (!result.connected && !result.refused) result.errors.push('no connection within the time allowed');
  finish();
}, seconds * 1000 + 10000);

function finish() {
  if (finished) return;
  finished = true;
  clearTimeout(timer);
  clearTimeout(watchdog);
  result.finished_at_ms = Date.now();
  process.stdout.write(JSON.stringify(result) + '\n');
  try {
    if (ws.readyState === WebSocket.OPEN || ws.readyState === WebSocket.CONNECTING) ws.terminate();
  } catch {
    // already gone
  }
  // Let stdout drain, then leave even if a socket lingers.
  setTimeout(() => process.exit(0), 200).unref();
}
