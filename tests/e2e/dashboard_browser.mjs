// Drives the dashboard page in Debian's headless Chromium like a user would and prints
// one JSON object with what it saw. The Python e2e test does the assertions.
//
//   node tests/e2e/dashboard_browser.mjs --url http://127.0.0.1:8470/ --screenshot out.png
//        [--link 2] [--loss 1.0] [--no-set] [--seconds 2] [--timeout 60]
//        [--chromium /usr/bin/chromium]
//
// --link/--loss: the link whose loss is set through the page's own number field (Enter);
//   default link 2, loss 1.0. --no-set: only watch.
// --seconds: how long the page keeps running after the change before the screenshot.
// Exit status: 0 when it ran (whatever it observed); 2 usage error; 1 harness error
// (no browser, page not reachable, overall timeout), with "error" set in the JSON.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { parseArgs } from 'node:util';
import { chromium } from 'playwright-core';

const CHROMIUM_ARGS = [
  '--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
];

function usage(message) {
  process.stderr.write(`${message}\nusage: node dashboard_browser.mjs --url URL --screenshot PNG ` +
    '[--link ID] [--loss VALUE] [--no-set] [--seconds N] [--timeout S] [--chromium PATH]\n');
  process.exit(2);
}

let options;
try {
  ({ values: options } = parseArgs({
    options: {
      url: { type: 'string' },
      screenshot: { type: 'string' },
      link: { type: 'string', default: '2' },
      loss: { type: 'string', default: '1.0' },
      'no-set': { type: 'boolean', default: false },
      seconds: { type: 'string', default: '2' },
      timeout: { type: 'string', default: '60' },
      chromium: { type: 'string', default: '/usr/bin/chromium' },
    },
  }));
} catch (err) {
  usage(err.message);
}
if (!options.url || !options.screenshot) usage('--url and --screenshot are required');
const linkId = Number(options.link);
const loss = Number(options.loss);
const settleSeconds = Number(options.seconds);
const timeoutSeconds = Number(options.timeout);
if (!Number.isInteger(linkId) || !Number.isFinite(loss) || !(settleSeconds >= 0) || !(timeoutSeconds > 0)) {
  usage('--link must be an integer, --loss a number, --seconds >= 0, --timeout > 0');
}
const doSet = !options['no-set'];

const result = {
  url: options.url,
  screenshot: path.resolve(options.screenshot),
  estimates_received: 0,          // window.netkfDashboard.estimatesReceived when plots had points
  points_plotted: 0,              // estimate points in the first state chart at that moment
  plot_lengths: {},               // uPlot data lengths per chart at that moment
  conn_state: null,
  period_text: null,              // #period when the plots had points
  set: doSet ? { link: linkId, loss } : null,
  set_method: null,
  set_at_ms: null,
  set_error: null,
  set_requests_sent: [],          // setParameters frames the page sent (JSON)
  applied: false,                 // the event log showed the applied change
  applied_at_ms: null,
  applied_entry: null,
  control_value_after: null,      // the number field after the answer
  final: null,                    // counters and header at the screenshot
  verdict: null,
  event_log: [],                  // status messages as shown, oldest first
  event_log_entries: [],          // {time, k, level, message}
  console_errors: [],
  page_errors: [],
  request_failures: [],
  error: null,
};

const deadline = Date.now() + timeoutSeconds * 1000;
const remaining = (cap) => Math.max(1, Math.min(cap === undefined ? Infinity : cap, deadline - Date.now()));

let context = null;
let userDataDir = null;
let printed = false;

function print(exitCode) {
  if (printed) return;
  printed = true;
  process.stdout.write(JSON.stringify(result) + '\n');
  process.exitCode = exitCode;
}

async function cleanup() {
  if (context) {
    const closing = context.close().catch(() => {});
    await Promise.race([closing, new Promise((resolve) => setTimeout(resolve, 5000))]);
    context = null;
  }
  if (userDataDir) fs.rmSync(userDataDir, { recursive: true, force: true });
}

// The overall bound: whatever hangs, the browser is closed and the result printed.
const watchdog = setTimeout(async () => {
  result.error = result.error || `overall timeout of ${timeoutSeconds} s`;
  print(1);
  await cleanup();
  process.exit(1);
}, timeoutSeconds * 1000 + 2000);

async function readEventLog(page) {
  return page.evaluate(() => Array.from(document.querySelectorAll('#event-log > *')).reverse().map((li) => ({
    time: li.querySelector('.event-time')?.textContent ?? '',
    k: li.querySelector('.event-k')?.textContent ?? '',
    level: li.querySelector('.event-level')?.textContent ?? '',
    message: li.querySelector('.event-message')?.textContent ?? li.textContent,
  })));
}

async function main() {
  userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'netkf-chromium-'));
  try {
    context = await chromium.launchPersistentContext(userDataDir, {
      executablePath: options.chromium,
      headless: true,
      args: CHROMIUM_ARGS,
      viewport: { width: 1400, height: 1000 },
      deviceScaleFactor: 1,
      timeout: remaining(30000),
    });
  } catch (err) {
    result.error = `browser launch failed: ${err.message.split('\n')[0]}`;
    return 1;
  }
  const page = context.pages()[0] || await context.newPage();
  page.on('console', (msg) => { if (msg.type() === 'error') result.console_errors.push(msg.text()); });
  page.on('pageerror', (err) => result.page_errors.push(String(err && err.message ? err.message : err)));
  page.on('requestfailed', (req) => result.request_failures.push(`${req.url()}: ${req.failure()?.errorText}`));
  page.on('response', (res) => { if (res.status() >= 400) result.request_failures.push(`${res.url()}: HTTP ${res.status()}`); });
  page.on('websocket', (ws) => {
    ws.on('framesent', (frame) => {
      if (typeof frame.payload !== 'string' || !frame.payload.includes('"setParameters"')) return;
      try { result.set_requests_sent.push(JSON.parse(frame.payload)); } catch { result.set_requests_sent.push(frame.payload); }
    });
  });

  try {
    await page.goto(options.url, { waitUntil: 'load', timeout: remaining(20000) });
  } catch (err) {
    result.error = `page did not load: ${err.message.split('\n')[0]}`;
    return 1;
  }

  // Plots have points: enough estimates arrived and a redraw (at most 10 a second) took them.
  try {
    await page.waitForFunction(() => window.netkfDashboard && window.netkfDashboard.estimatesReceived > 50 &&
      window.netkfDashboard.pointsPlotted > 50, null, { timeout: remaining(30000), polling: 100 });
  } catch {
    // Reported below as what it is (few estimates, no points); the Python test judges.
  }
  const before = await page.evaluate(() => ({
    dash: window.netkfDashboard ? JSON.parse(JSON.stringify(window.netkfDashboard)) : null,
    conn: document.getElementById('conn-state')?.dataset.state ?? null,
    period: document.getElementById('period')?.textContent ?? null,
  }));
  if (before.dash) {
    result.estimates_received = before.dash.estimatesReceived;
    result.points_plotted = before.dash.pointsPlotted;
    result.plot_lengths = before.dash.plotLengths;
  }
  result.conn_state = before.conn;
  result.period_text = before.period;

  if (doSet) {
    const number = page.locator(`input[type="number"][data-link="${linkId}"][data-param="loss"]`);
    const model = page.locator(`select[data-link="${linkId}"][data-param="model"]`);
    try {
      // A Gilbert-Elliott link has no loss field showing: switch it to Bernoulli first, as a user would.
      if (!(await number.isVisible())) {
        await model.selectOption('bernoulli', { timeout: remaining(5000) });
        result.set_method = 'model select bernoulli, then number field + Enter';
      } else {
        result.set_method = 'number field + Enter';
      }
      await number.fill(String(loss), { timeout: remaining(5000) });
      result.set_at_ms = Date.now();
      await number.press('Enter', { timeout: remaining(5000) });
    } catch (err) {
      // The page's control missing or unusable is an observation, not a harness error.
      result.set_error = `could not use the link ${linkId} loss control: ${err.message.split('\n')[0]}`;
    }
    if (result.set_at_ms !== null) {
      // The server's level-0 status: "link 2: bernoulli loss=1 (from dashboard)".
      try {
        const handle = await page.waitForFunction(({ id, value }) => {
          for (const node of document.querySelectorAll('#event-log .event-message')) {
            const text = node.textContent || '';
            if (!text.startsWith(`link ${id}:`) || !text.includes('(from dashboard)')) continue;
            const m = /\bloss=([-+0-9.eE]+)/.exec(text);
            if (m && Math.abs(Number(m[1]) - value) < 1e-9) return text;
          }
          return false;
        }, { id: linkId, value: loss }, { timeout: remaining(15000), polling: 50 });
        result.applied = true;
        result.applied_at_ms = Date.now();
        result.applied_entry = await handle.jsonValue();
      } catch {
        result.applied = false;
      }
      result.control_value_after = await page.evaluate((sel) => document.querySelector(sel)?.value ?? null,
        `input[type="number"][data-link="${linkId}"][data-param="loss"]`);
    }
  }

  if (settleSeconds > 0) await page.waitForTimeout(remaining(settleSeconds * 1000));
  await page.screenshot({ path: result.screenshot, fullPage: true, timeout: remaining(15000) });

  const after = await page.evaluate(() => {
    const verdict = document.getElementById('verdict');
    return {
      dash: window.netkfDashboard ? JSON.parse(JSON.stringify(window.netkfDashboard)) : null,
      conn_state: document.getElementById('conn-state')?.dataset.state ?? null,
      period_text: document.getElementById('period')?.textContent ?? null,
      verdict: verdict ? { text: verdict.textContent, configured: verdict.dataset.configured, observed: verdict.dataset.observed } : null,
    };
  });
  result.final = { ...(after.dash || {}), conn_state: after.conn_state, period_text: after.period_text };
  result.verdict = after.verdict;
  result.event_log_entries = await readEventLog(page);
  result.event_log = result.event_log_entries.map((e) => e.message);
  return result.error ? 1 : 0;
}

let code = 1;
try {
  code = await main();
} catch (err) {
  result.error = `harness error: ${err && err.message ? err.message.split('\n')[0] : err}`;
  code = 1;
} finally {
  clearTimeout(watchdog);
  await cleanup();
}
print(code);
