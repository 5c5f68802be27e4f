// Opens a report.html in headless Chromium (playwright-core, pinned in
// package.json; the browser is the system's, $CHROMIUM or /usr/bin/chromium)
// with every network request blocked, takes a screenshot of the first
// screen, and prints one JSON line: console errors, page errors, blocked
// and failed requests, broken images, the text and box of the first table.
// Exits 1 when anything went wrong on the page, 2 on bad usage.
// Used by crates/cli/tests/views.rs; runnable by hand:
//   node tests/js/check_report.cjs report/report.html shot.png
'use strict';
const path = require('path');
const { chromium } = require('playwright-core');

async function main([html, shot]) {
  if (!html || !shot) {
    console.error('usage: node check_report.cjs REPORT.html SCREENSHOT.png');
    return 2;
  }
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    // Root in a container has no user namespaces for Chromium's sandbox.
    args: ['--no-sandbox'],
  });
  const out = { console_errors: [], page_errors: [], blocked_requests: [], failed_requests: [] };
  try {
    const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
    page.on('console', (m) => { if (m.type() === 'error') out.console_errors.push(m.text()); });
    page.on('pageerror', (e) => out.page_errors.push(String(e)));
    page.on('requestfailed', (r) => out.failed_requests.push(r.url()));
    // Self-contained: the report itself is the only file it may load.
    const self = 'file://' + path.resolve(html);
    await page.route('**/*', (route) => {
      const url = route.request().url();
      if (url === self || url.startsWith('data:')) return route.continue();
      out.blocked_requests.push(url);
      return route.abort();
    });
    await page.goto(self, { waitUntil: 'load' });
    out.title = await page.title();
    const table = page.locator('table').first();
    out.table_text = (await table.count()) > 0 ? await table.innerText() : '';
    out.table_box = (await table.count()) > 0 ? await table.boundingBox() : null;
    out.images = await page.evaluate(() => {
      const imgs = Array.from(document.images);
      return { total: imgs.length, broken: imgs.filter((i) => !i.complete || i.naturalWidth === 0).length };
    });
    out.svgs = await page.locator('svg').count();
    out.viewport = page.viewportSize();
    await page.screenshot({ path: shot });
  } finally {
    await browser.close();
  }
  console.log(JSON.stringify(out));
  const bad = out.console_errors.length + out.page_errors.length + out.blocked_requests.length
    + out.failed_requests.length + out.images.broken;
  return bad > 0 ? 1 : 0;
}

main(process.argv.slice(2)).then(
  (code) => process.exit(code),
  (e) => { console.error(e && e.stack ? e.stack : String(e)); process.exit(1); },
);
