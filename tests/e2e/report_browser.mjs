// Opens a sweep's report.html (file://) in headless Chromium with every network request
// refused, and prints one JSON object: the plots drawn (uPlot charts), their titles, the
// page's script errors and the requests it tried to make (a self-contained page makes none).
// usage: node report_browser.mjs --report FILE --screenshot PNG [--chromium PATH]
import path from 'node:path';
import { parseArgs } from 'node:util';
import { chromium } from 'playwright-core';

const { values: options } = parseArgs({
  options: { report: { type: 'string' }, screenshot: { type: 'string' }, chromium: { type: 'string', default: '/usr/bin/chromium' } },
});
const browser = await chromium.launch({
  executablePath: options.chromium,
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--no-first-run', '--disable-background-networking'],
});
const result = { errors: [], requests: [], plots: 0, titles: [] };
try {
  const page = await browser.newPage({ viewport: { width: 1300, height: 900 } });
  page.on('pageerror', (e) => result.errors.push(String(e)));
  await page.route('**/*', (route) => {
    const url = route.request().url();
    if (url.startsWith('file:')) return route.continue();
    result.requests.push(url);
    return route.abort();
  });
  await page.goto('file://' + path.resolve(options.report));
  await page.waitForTimeout(500);
  result.plots = await page.locator('.uplot').count();
  result.titles = await page.locator('.u-title').allTextContents();
  if (options.screenshot) await page.screenshot({ path: options.screenshot, fullPage: false });
} finally {
  await browser.close();
}
process.stdout.write(JSON.stringify(result) + '\n');
