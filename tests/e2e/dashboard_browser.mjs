// Drives the dashboard page in Debian's headless Chromium like a user would and prints
// one JSON object with what it saw. The Python e2e test does the assertions.
//
//   node tests/e2e/dashboard_browser.mjs --url http://127.0.0.1:8470/ --screenshot out.png
//        [--link 2|control] [--loss 1.0] [--no-set] [--delay 2=3] [--gilbert 3=0.2,4]
//        [--select ID] [--seconds 2] [--timeout 60] [--chromium /usr/bin/chromium]
//
// --select ID: a scenario of more links than cards (the page's table mode): first read the link
//   table as it opened ("table_before"), then search for ID in it, click its row and wait for
//   its card ("selected"); the --link/--delay/--gilbert steps then use that card.
// --link/--loss: the link whose loss is set through the page's own number field (Enter);
//   default link 2, loss 1.0. --no-set: only watch.
// --delay ID=MS: then that link's delay (ms) is set through its delay field (Enter).
// --gilbert ID=LOSS,BURST: then that Gilbert-Elliott link is set in the user's form: its
//   loss field (Enter), then its mean burst field (Enter), each waited for.
// Each of these is a step in "steps": the setParameters frames the page sent for it, the
// event-log entry that showed it applied, the field's value after.
// --seconds: how long the page keeps running after the change before the screenshot.
// --compare-ctl NETKF: meanwhile, read every link card and the stability panel every 100 ms
//   ("readings": the distinct ones, each with its Date.now() time) and, 2 s in, run
//   `NETKF ctl status --json` once ("ctl": its output, start and end times), reading on until
//   1.5 s after it ended: the page and ctl at nearly the same time (the test compares them).
// Exit status: 0 when it ran (whatever it observed); 2 usage error; 1 harness error
// (no browser, page not reachable, overall timeout), with "error" set in the JSON.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { parseArgs } from 'node:util';
import { execFile } from 'node:child_process';
import { chromium } from 'playwright-core';

const CHROMIUM_ARGS = [
  '--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
];

function usage(message) {
  process.stderr.write(`${message}\nusage: node dashboard_browser.mjs --url URL --screenshot PNG ` +
    '[--link ID] [--loss VALUE] [--no-set] [--delay ID=MS] [--gilbert ID=LOSS,BURST] [--select ID] [--seconds N] [--timeout S] ' +
    '[--chromium PATH] [--compare-ctl NETKF]\n');
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
      delay: { type: 'string' },
      gilbert: { type: 'string' },
      seconds: { type: 'string', default: '2' },
      timeout: { type: 'string', default: '60' },
      chromium: { type: 'string', default: '/usr/bin/chromium' },
      'compare-ctl': { type: 'string' },
      select: { type: 'string' },
    },
  }));
} catch (err) {
  usage(err.message);
}
if (!options.url || !options.screenshot) usage('--url and --screenshot are required');
// A sensor id, or "control" for the actuation link (plant.control.link).
const linkId = options.link === 'control' ? 'control' : Number(options.link);
const loss = Number(options.loss);
const settleSeconds = Number(options.seconds);
const timeoutSeconds = Number(options.timeout);
if (!(Number.isInteger(linkId) || linkId === 'control') || !Number.isFinite(loss) || !(settleSeconds >= 0) || !(timeoutSeconds > 0)) {
  usage('--link must be an integer, --loss a number, --seconds >= 0, --timeout > 0');
}
const doSet = !options['no-set'];
// ID=V1[,V2...] -> {link, values} (null when not given).
function linkValues(text, count, name) {
  if (text === undefined) return null;
  const m = /^(-?\d+)=(.+)$/.exec(text);
  const values = m ? m[2].split(',').map(Number) : [];
  if (!m || values.length !== count || !values.every(Number.isFinite)) usage(`--${name} wants ID=${count === 1 ? 'MS' : 'LOSS,BURST'}`);
  return { link: Number(m[1]), values };
}
const delaySet = linkValues(options.delay, 1, 'delay');
const gilbertSet = linkValues(options.gilbert, 2, 'gilbert');

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
  steps: [],                      // --delay, --gilbert: {link, param, value, sent, applied, applied_entry, ...}
  link_stats: {},                 // per link id: the card's stats line at the screenshot {key: text}
  table_before: null,             // --select: the link table before the search (readLinkTable)
  selected: null,                 // --select: {search_rows, card, error}
  table: null,                    // the link table at the screenshot (null: the page shows cards)
  readings: [],                   // --compare-ctl: {ms, links: {id: {key: text}}, theory: {header, rates}}
  ctl: null,                      // --compare-ctl: {start_ms, end_ms, status (parsed), error}
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

// Sets one number field of a link card as a user does (fill, Enter) and waits for the
// server's level-0 status of the change (from dashboard) showing every expected number:
// `expect` = [[text before the number, value], ...], equal within 1e-3 relative (the
// status prints 4 significant digits).
async function setField(page, link, param, value, expect) {
  const step = { link, param, value, method: 'number field + Enter', set_at_ms: null, sent: [], applied: false,
    applied_at_ms: null, applied_entry: null, control_value_after: null, error: null };
  result.steps.push(step);
  const selector = `input[type="number"][data-link="${link}"][data-param="${param}"]`;
  const sentBefore = result.set_requests_sent.length;
  const logBefore = await page.evaluate(() => window.netkfDashboard.eventCount);
  try {
    const number = page.locator(selector);
    await number.fill(String(value), { timeout: remaining(5000) });
    step.set_at_ms = Date.now();
    await number.press('Enter', { timeout: remaining(5000) });
  } catch (err) {
    step.error = `could not use the link ${link} ${param} control: ${err.message.split('\n')[0]}`;
    return step;
  }
  try {
    // Only entries added since the change: the log is newest first, so its first (count now − count before).
    const handle = await page.waitForFunction(({ id, fresh, wanted }) => {
      const shows = (text) => wanted.every(([prefix, v]) => {
        const at = text.indexOf(prefix);
        const m = at < 0 ? null : /^[-+0-9.eE]+/.exec(text.slice(at + prefix.length));
        return m !== null && Math.abs(Number(m[0]) - v) <= 1e-3 * Math.max(1, Math.abs(v));
      });
      const nodes = Array.from(document.querySelectorAll('#event-log .event-message'))
        .slice(0, window.netkfDashboard.eventCount - fresh);
      for (const node of nodes) {
        const text = node.textContent || '';
        if (text.startsWith(`link ${id}:`) && text.includes('(from dashboard)') && shows(text)) return text;
      }
      return false;
    }, { id: link, fresh: logBefore, wanted: expect }, { timeout: remaining(15000), polling: 50 });
    step.applied = true;
    step.applied_at_ms = Date.now();
    step.applied_entry = await handle.jsonValue();
  } catch {
    step.applied = false;
  }
  // Frames arrive as events: the ones sent for this step are in by the time it was applied.
  step.sent = result.set_requests_sent.slice(sentBefore);
  step.control_value_after = await page.evaluate((sel) => document.querySelector(sel)?.value ?? null, selector);
  return step;
}

// Every link card's stats line {id: {key: text}}, and the stability panel's observed column.
function readLinkStats(page) {
  return page.evaluate(() => {
    const links = {};
    for (const card of document.querySelectorAll('article.link-card')) {
      const stats = {};
      for (const stat of card.querySelectorAll('.link-stats .stat')) {
        stats[stat.querySelector('.stat-key')?.textContent ?? ''] = stat.querySelector('.stat-value')?.textContent ?? '';
      }
      links[card.dataset.link] = stats;
    }
    const header = document.querySelectorAll('#assessment thead th')[2]?.textContent ?? '';
    const rates = document.querySelector('#assessment [data-field="obs-rates"]')?.textContent ?? '';
    return { links, theory: { header, rates } };
  });
}

function runCtlStatus(netkf) {
  return new Promise((resolve) => {
    const start = Date.now();
    execFile(netkf, ['ctl', 'status', '--json'], { timeout: 30000 }, (err, stdout) => {
      const out = { start_ms: start, end_ms: Date.now(), status: null, error: err ? err.message.split('\n')[0] : null };
      try { out.status = JSON.parse(stdout); } catch { out.error = out.error || 'ctl printed no JSON'; }
      resolve(out);
    });
  });
}

// The page and `netkf ctl status --json` at nearly the same time (--compare-ctl).
async function compareWithCtl(page, netkf) {
  const begin = Date.now();
  let ctlRun = null;
  let last = '';
  while (Date.now() < deadline - 5000) {
    const reading = await readLinkStats(page);
    const text = JSON.stringify(reading);
    if (text !== last) result.readings.push({ ms: Date.now(), ...reading });
    last = text;
    if (!ctlRun && Date.now() - begin >= 2000) ctlRun = runCtlStatus(netkf).then((r) => { result.ctl = r; });
    if (result.ctl && Date.now() - result.ctl.end_ms >= 1500) return;
    await page.waitForTimeout(100);
  }
  if (ctlRun) await ctlRun;
}

// The link table (table mode), or null when the page shows cards: its count line and the rows
// shown, each {link, selected, cells: {column: text}}, in the page's order.
async function readLinkTable(page) {
  return page.evaluate(() => {
    const panel = document.getElementById('link-table-panel');
    if (!panel || panel.hidden) return null;
    const rows = Array.from(document.querySelectorAll('#link-table tbody tr')).map((tr) => ({
      link: tr.dataset.link,
      selected: tr.classList.contains('selected'),
      cells: Object.fromEntries(Array.from(tr.cells).map((td) => [td.dataset.col, td.textContent])),
    }));
    const sorted = document.querySelector('#link-table th[aria-sort="ascending"], #link-table th[aria-sort="descending"]');
    return { count: document.getElementById('link-table-count')?.textContent ?? '', rows,
      sort: sorted ? { column: sorted.dataset.sort, order: sorted.getAttribute('aria-sort') } : null,
      cards: document.querySelectorAll('article.link-card').length,
      redraw_ms: window.netkfDashboard ? window.netkfDashboard.linkTableMs : null };
  });
}

// --select: search the table for a link, click its row, wait for its card.
async function selectInTable(page, id) {
  const out = { search_rows: null, card: false, error: null, ms: null };
  try {
    await page.waitForFunction(() => document.querySelectorAll('#link-table tbody tr').length > 0, null,
      { timeout: remaining(15000), polling: 100 });
    result.table_before = await readLinkTable(page);
    const started = Date.now();
    await page.fill('#link-search', String(id), { timeout: remaining(5000) });
    // The table redraws at most twice a second: wait for the search to show.
    await page.waitForFunction((want) => {
      const rows = document.querySelectorAll('#link-table tbody tr');
      return rows.length > 0 && Array.from(rows).every((tr) => tr.dataset.link.startsWith(want));
    }, String(id), { timeout: remaining(5000), polling: 50 });
    out.search_rows = (await readLinkTable(page)).rows.map((r) => r.link);
    await page.click(`#link-table tbody tr[data-link="${id}"]`, { timeout: remaining(5000) });
    await page.waitForSelector(`article.link-card[data-link="${id}"] input[data-param="loss"]`, { timeout: remaining(5000) });
    // Its stats come from the link status the page kept for it.
    await page.waitForFunction((sel) => (document.querySelector(sel)?.textContent || '').includes('λ since change'),
      `article.link-card[data-link="${id}"] .link-stats`, { timeout: remaining(5000), polling: 50 });
    out.card = true;
    out.ms = Date.now() - started;   // search typed to the card's stats shown
  } catch (err) {
    out.error = err.message.split('\n')[0];
  }
  return out;
}

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
  // The actuation link's card (plant.control.link): its theory line, before and after.
  const actuationTheory = () => page.evaluate(() => {
    const line = document.querySelector('article.link-card[data-link="control"] .link-theory');
    return line ? { stable: line.dataset.stable ?? null, text: line.textContent } : null;
  });
  if (linkId === 'control') {
    try {  // the first theory message reached the card
      await page.waitForFunction(() => document.querySelector('article.link-card[data-link="control"] .link-theory')
        ?.dataset.stable, null, { timeout: remaining(15000), polling: 100 });
    } catch {
      // reported as null below
    }
  }
  result.actuation_theory_before = await actuationTheory();
  // The header's running cost (closed loop): the value and how many periods it averages.
  result.running_cost = await page.evaluate(() => {
    const stat = document.getElementById('running-cost-stat');
    const cell = document.getElementById('running-cost');
    if (!stat || !cell || stat.hidden) return null;
    return { value: Number(cell.dataset.value), periods: Number(cell.dataset.periods), text: cell.textContent };
  });
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

  if (options.select !== undefined) result.selected = await selectInTable(page, options.select);

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

  if (delaySet) {
    // "link 2: bernoulli loss=1, delay 3±0 ms uniform (from dashboard)"
    const [ms] = delaySet.values;
    await setField(page, delaySet.link, 'delay_ms', ms, [[', delay ', ms]]);
  }
  if (gilbertSet) {
    const [lossValue, burst] = gilbertSet.values;
    // A Bernoulli link shows no mean burst field: switch it to Gilbert-Elliott first, as a user would.
    const model = page.locator(`select[data-link="${gilbertSet.link}"][data-param="model"]`);
    try {
      if ((await model.inputValue({ timeout: remaining(5000) })) !== 'gilbert_elliott') {
        await model.selectOption('gilbert_elliott', { timeout: remaining(5000) });
        await page.waitForFunction((sel) => document.querySelector(sel)?.dataset.state !== 'pending',
          `#link-${gilbertSet.link} .link-pending`, { timeout: remaining(15000), polling: 50 });
      }
    } catch (err) {
      result.steps.push({ link: gilbertSet.link, param: 'model', error: `model switch: ${err.message.split('\n')[0]}` });
    }
    // "link 3: gilbert_elliott p=... r=... loss_good=0 loss_bad=1 (loss 0.2, mean burst 3.333) (from dashboard)"
    await setField(page, gilbertSet.link, 'loss', lossValue, [['(loss ', lossValue]]);
    await setField(page, gilbertSet.link, 'mean_burst', burst, [['(loss ', lossValue], [', mean burst ', burst]]);
  }

  if (settleSeconds > 0) await page.waitForTimeout(remaining(settleSeconds * 1000));
  if (options['compare-ctl']) await compareWithCtl(page, options['compare-ctl']);
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
  result.link_stats = (await readLinkStats(page)).links;
  result.table = await readLinkTable(page);
  result.js_heap_mb = await page.evaluate(() => (performance.memory ? performance.memory.usedJSHeapSize / 1048576 : null));
  result.verdict = after.verdict;
  result.actuation_theory_after = await actuationTheory();
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
