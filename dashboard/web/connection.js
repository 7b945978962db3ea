// The foxglove.websocket.v1 client of `netkf launch`: connects (and reconnects with backoff),
// subscribes to every netkf/ channel advertised, decodes the messages and hands each topic's
// to its handler; reads, follows and sets the links' parameters.
import { takeLinkModels } from './constants.js';
import { $ } from './dom.js';
import { addEvent, onStatus } from './events.js';
import { dash } from './probe.js';
import { store } from './state.js';

const SUBPROTOCOL = 'foxglove.websocket.v1';
const PENDING_TIMEOUT_MS = 5000;  // a setParameters without answer is given up after this

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
// {topics: {topic: fn(payload)}, parameterValues: fn(msg)}, given to connect().
let handlers = { topics: {}, parameterValues() {} };
const textDecoder = new TextDecoder('utf-8');

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

// Connects, and again after every close; messages go to `messageHandlers` (see handlers).
export function connect(messageHandlers) {
  handlers = messageHandlers;
  open();
}

function open() {
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
  conn.reconnectTimer = setTimeout(open, delay);
}

// Sends a JSON message; false when not connected.
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
    case 'parameterValues': handlers.parameterValues(msg); break;
    default: break;   // removeStatus, services, ...: nothing to show
  }
}

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
  const handler = Object.prototype.hasOwnProperty.call(handlers.topics, topic) ? handlers.topics[topic] : null;
  if (handler) handler(payload);
}

function onServerInfo(msg) {
  conn.capabilities = msg.capabilities || [];
  conn.serverName = msg.name || '';
  // An empty name list asks for every parameter the server has.
  getParameters([], 'netkf-dashboard-initial');
  subscribeParameterUpdates();
}

function onAdvertise(channels) {
  const subscriptions = [];
  for (const channel of channels) {
    conn.channels.set(channel.id, channel);
    // The link models the page shows and edits come with the link status's schema.
    if (channel.topic === 'netkf/link/status' && !takeLinkModels(channel.schema)) dash.decodeErrors++;
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

// Asks for the values of the named parameters (none named: all) when the server has them;
// the answer (parameterValues) carries `id`.
export function getParameters(names, id) {
  if (conn.capabilities.includes('parameters')) send({ op: 'getParameters', parameterNames: names, id });
}

// Every parameter a shown card's link can have, whatever its current model, so a model
// switch made elsewhere still reaches it. Only the cards shown: the names of thousands of
// links would exceed what the server takes in one message (docs/dashboard.md).
export function subscribeParameterUpdates() {
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

// One setParameters request: its id and the timer that calls noAnswer(id) when no answer came
// within PENDING_TIMEOUT_MS (clear it on the answer); null when not connected.
export function setParameters(parameters, noAnswer) {
  const id = 'netkf-dashboard-' + Date.now().toString(36) + '-' + (conn.nextRequest++);
  if (!send({ op: 'setParameters', parameters, id })) return null;
  dash.setParametersSent++;
  return { id, timer: setTimeout(() => noAnswer(id), PENDING_TIMEOUT_MS) };
}
