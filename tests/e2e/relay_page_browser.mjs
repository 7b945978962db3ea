// Drives `netkf relay --dashboard`'s page (dashboard/web/relay.html) in Debian's headless
// Chromium as a user does and prints one JSON object with what it saw; the Python test
// (test_relay_page.py) does the assertions.
//
//   node tests/e2e/relay_page_browser.mjs --url http://127.0.0.1:PORT/ --topic rt/chatter
//        --samples N [--loss 0] [--p P --r R] [--delay-ms D] [--jitter-ms J] [--then-samples M]
//        [--screenshot out.png] [--timeout 60]
//        [--chromium /usr/bin/chromium]
//
// Waits for the topic's card to show N samples in, reads the card (and its plot's point count
// and last interval's loss), then (with --loss, --p/--r, --delay-ms, --jitter-ms) fills the
// card's form as a user would, submits it and waits for the answer shown
// on the card ("applied" or "refused: ..."), and reads the card again (with --then-samples,
// once the card shows M samples in since the change: the page kept open meanwhile).
// Exit status: 0 when it ran (whatever it observed); 2 usage error; 1 harness error (no
// browser, page not reachable, overall timeout), with "error" set in the JSON.
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
  process.stderr.write(`${message}\nusage: node relay_page_browser.mjs --url URL --topic TOPIC --samples N ` +
    '[--loss V] [--p P] [--r R] [--delay-ms D] [--jitter-ms J] [--then-samples M] [--screenshot PNG] [--timeout S] ' +
    '[--chromium PATH]\n');
  process.exit(2);
}

let options;
try {
  ({ values: options } = parseArgs({
    options: {
      url: { type: 'string' },
      topic: { type: 'string' },
      samples: { type: 'string' },
      loss: { type: 'string' },
      p: { type: 'string' },
      r: { type: 'string' },
      'delay-ms': { type: 'string' },
      'jitter-ms': { type: 'string' },
      'then-samples': { type: 'string' },
      screenshot: { type: 'string' },
      timeout: { type: 'string', default: '60' },
      chromium: { type: 'string', default: '/usr/bin/chromium' },
    },
  }));
} catch (err) {
  usage(err.message);
}
const samples = Number(options.samples);
const timeoutSeconds = Number(options.timeout);
if (!options.url || !options.topic || !Number.isInteger(samples) || !(timeoutSeconds > 0)) {
  usage('--url, --topic and an integer --samples are required; --timeout > 0');
}
const form = {};
for (const key of ['loss', 'p', 'r', 'delay-ms', 'jitter-ms']) {
  if (options[key] !== undefined) form[key.replace('-', '_')] = options[key];  // the input's name
}

const result = {
  url: options.url, topic: options.topic, card_before: null, cards: [], set: form, set_requests_sent: [],
  answer: null, answer_state: null, card_after: null, console_errors: [], page_errors: [], request_failures: [],
  error: null,
};
const deadline = Date.now() + timeoutSeconds * 1000;
const remaining = (cap) => Math.max(1, Math.min(cap, deadline - Date.now()));
let context = null;
let userDataDir = null;

async function cleanup() {
  if (context) {
    const closing = context.close().catch(() => {});
    await Promise.race([closing, new Promise((resolve) => setTimeout(resolve, 5000))]);
    context = null;
  }
  if (userDataDir) fs.rmSync(userDataDir, { recursive: true, force: true });
}

const watchdog = setTimeout(async () => {
  result.error = result.error || `overall timeout of ${timeoutSeconds} s`;
  process.stdout.write(JSON.stringify(result) + '\n');
  await cleanup();
  process.exit(1);
}, timeoutSeconds * 1000 + 2000);

// The card's fields as the user reads them {field: text}.
function readCard(page, topic) {
  return page.evaluate((t) => {
    const card = Array.from(document.querySelectorAll('.relay-card')).find((c) => c.dataset.topic === t);
    if (!card) return null;
    const fields = { link_id: card.dataset.linkId, title: card.querySelector('h2')?.textContent ?? null };
    for (const dd of card.querySelectorAll('dd[data-field]')) fields[dd.dataset.field] = dd.textContent;
    const plot = card.querySelector('.relay-plot');
    fields.plot_points = plot?.dataset.points ?? null;
    fields.plot_last_interval_loss = plot?.dataset.lastIntervalLoss ?? null;
    fields.plot_canvas = Boolean(plot?.querySelector('canvas'));
    return fields;
  }, topic);
}

async function main() {
  userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'netkf-chromium-'));
  try {
    context = await chromium.launchPersistentContext(userDataDir, {
      executablePath: options.chromium, headless: true, args: CHROMIUM_ARGS,
      viewport: { width: 1200, height: 900 }, timeout: remaining(30000),
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
  page.on('websocket', (ws) => ws.on('framesent', (frame) => {
    if (typeof frame.payload === 'string' && frame.payload.includes('"setParameters"')) {
      try { result.set_requests_sent.push(JSON.parse(frame.payload)); } catch { result.set_requests_sent.push(frame.payload); }
    }
  }));
  try {
    await page.goto(options.url, { waitUntil: 'load', timeout: remaining(20000) });
  } catch (err) {
    result.error = `page did not load: ${err.message.split('\n')[0]}`;
    return 1;
  }
  const sel = (field) => `.relay-card[data-topic="${options.topic}"] dd[data-field="${field}"]`;
  try {
    // The relay reports each second: wait for a report with every sample in it.
    await page.waitForFunction(({ s, n }) => document.querySelector(s)?.textContent === String(n),
      { s: sel('samples_in'), n: samples }, { timeout: remaining(30000), polling: 100 });
  } catch {
    result.error = `no card of ${options.topic} with ${samples} samples in`;
  }
  result.card_before = await readCard(page, options.topic);
  result.cards = await page.evaluate(() => Array.from(document.querySelectorAll('.relay-card'), (c) => c.dataset.topic));
  if (result.error || Object.keys(form).length === 0) return 0;
  const card = page.locator(`.relay-card[data-topic="${options.topic}"]`);
  try {
    for (const [key, value] of Object.entries(form)) await card.locator(`input[name="${key}"]`).fill(value, { timeout: remaining(5000) });
    await card.locator('button[type="submit"]').click({ timeout: remaining(5000) });
    const answer = card.locator('.relay-answer');
    await page.waitForFunction((s) => ['applied', 'refused'].includes(document.querySelector(s)?.dataset.state),
      `.relay-card[data-topic="${options.topic}"] .relay-answer`, { timeout: remaining(15000), polling: 50 });
    result.answer = await answer.textContent();
    result.answer_state = await answer.getAttribute('data-state');
  } catch (err) {
    result.error = `could not use the card's form: ${err.message.split('\n')[0]}`;
  }
  // The next report shows the new model (with --then-samples: the report with M samples since).
  if (options['then-samples'] !== undefined) {
    await page.waitForFunction(({ s, n }) => document.querySelector(s)?.textContent === String(n),
      { s: sel('samples_in'), n: Number(options['then-samples']) }, { timeout: remaining(60000), polling: 100 })
      .catch(() => { result.error = result.error || `the card never showed ${options['then-samples']} samples in`; });
  } else {
    await page.waitForTimeout(Math.min(1500, remaining(1500)));
  }
  result.card_after = await readCard(page, options.topic);
  if (options.screenshot) await page.screenshot({ path: options.screenshot, fullPage: true }).catch(() => {});
  return 0;
}

let code = 1;
try {
  code = await main();
} catch (err) {
  result.error = `harness error: ${err.message.split('\n')[0]}`;
}
clearTimeout(watchdog);
process.stdout.write(JSON.stringify(result) + '\n');
await cleanup();
process.exit(code);
