// When the page redraws: a message marks what it changed (dirty) and asks for a render; the
// render draws what is due, each part at its own most rate, and the charts less often on a
// slow machine. What each part draws is the painters' (set once by app.js).
import { dash } from './probe.js';

const MIN_REDRAW_MS = 100;        // time charts redraw at most 10 times a second
const MAX_REDRAW_MS = 500;        // and at least twice a second, however slow
const LINK_REDRAW_MS = 500;       // link panels (fed ~1/s) at most twice a second
const TEXT_REDRAW_MS = 100;       // header and stability texts at most 10 times a second

const dirty = { data: true, slowData: false, header: true, theory: true, region: true, links: true, network: true };
let painters = { header() {}, theory() {}, network() {}, timeCharts() {}, links() {}, region() {} };
let paused = false;
let renderQueued = false;
let lastChartDraw = -Infinity;
let lastLinkDraw = -Infinity;
let lastTextDraw = -Infinity;
let redrawCost = 0;                 // smoothed milliseconds of one chart redraw
let redrawInterval = MIN_REDRAW_MS;

// The functions that draw each part: {header, theory, network, timeCharts, links, region}.
export function paintWith(parts) { painters = parts; }

// Marks parts (keys of `dirty`) to be drawn at the next render, without asking for one.
export function markDirty(...parts) {
  for (const part of parts) dirty[part] = true;
}

// Marks parts and asks for a render.
export function redraw(...parts) {
  markDirty(...parts);
  requestRender();
}

// Everything, at once (a new scenario, window or pause, a clear).
export function redrawAll() {
  for (const key of Object.keys(dirty)) dirty[key] = true;
  lastTextDraw = -Infinity;
  lastChartDraw = -Infinity;
  lastLinkDraw = -Infinity;
  requestRender();
}

// Paused: the charts stay as they are; the texts go on.
export function pauseCharts(on) {
  paused = on;
  redrawAll();
}

// Called on every message; at most one render is pending. A render that is not due yet
// waits on a timer (not on back-to-back animation frames, which would repaint for nothing).
function requestRender(delayMs) {
  if (renderQueued) return;
  renderQueued = true;
  if (delayMs > 0) setTimeout(() => requestAnimationFrame(render), delayMs);
  else requestAnimationFrame(render);
}

function render(now) {
  renderQueued = false;
  const d = dirty;
  let wait = Infinity;
  // Header and stability texts: a period number changing 50 times a second is unreadable anyway.
  if (d.header || d.theory || d.network) {
    if (now - lastTextDraw >= TEXT_REDRAW_MS) {
      lastTextDraw = now;
      if (d.header) { d.header = false; painters.header(); }
      if (d.theory) { d.theory = false; painters.theory(); }
      if (d.network) { d.network = false; painters.network(); }
    } else {
      wait = Math.min(wait, TEXT_REDRAW_MS - (now - lastTextDraw));
    }
  }
  if (!paused) wait = Math.min(wait, renderCharts(now));
  if (wait < Infinity) requestRender(Math.max(1, wait));
}

// Draws what is due; returns the milliseconds until the next chart work is due (or Infinity).
function renderCharts(now) {
  const d = dirty;
  let wait = Infinity;
  const started = performance.now();
  let drew = false;
  if (d.data) {
    if (now - lastChartDraw >= redrawInterval) {
      lastChartDraw = now;
      d.data = false;
      d.slowData = true;
      painters.timeCharts();
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
      painters.links();
      drew = true;
    } else {
      wait = Math.min(wait, LINK_REDRAW_MS - (now - lastLinkDraw));
    }
  }
  if (d.region) {
    d.region = false;
    painters.region();
  }
  if (drew) measureRedraw(started);
  return wait;
}

// A slow machine redraws less often instead of spending every frame on charts: at most about
// a fifth of the time goes to drawing. uPlot draws in a microtask queued by setData, so the
// cost is read in a microtask queued after it.
function measureRedraw(started) {
  queueMicrotask(() => {
    const spent = performance.now() - started;
    redrawCost = 0.8 * redrawCost + 0.2 * spent;
    redrawInterval = Math.min(MAX_REDRAW_MS, Math.max(MIN_REDRAW_MS, 5 * redrawCost));
    dash.redrawMs = Math.round(redrawCost * 10) / 10;
  });
}
