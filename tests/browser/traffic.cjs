// The browser console shows traffic on a graph map: loads the console in Debian's Chromium
// (headless) through Playwright, waits until it draws the lanes robots hold, then until a robot
// is listed lost in the Traffic table, takes it off the lanes with its button and waits for the
// console's answer.
// Usage: node traffic.cjs URL SCREENSHOT LOST_ROBOT. Prints one JSON line with what it saw.
'use strict';
const { launch } = require('./launch.cjs');

const [url, shot, lost] = process.argv.slice(2);

async function until(what, ms, probe) {
  const t0 = Date.now();
  for (;;) {
    const v = await probe();
    if (v) return v;
    if (Date.now() - t0 > ms) throw new Error(`${what} not within ${ms / 1000} s`);
    await new Promise((r) => setTimeout(r, 200));
  }
}

async function main() {
  const { browser, page } = await launch();
  const seen = {};
  try {
    const errors = [];
    page.on('pageerror', (e) => errors.push(String(e)));
    await page.goto(url);
    // Lanes held by two robots or more, drawn on the office graph.
    seen.drawn = await until('lanes held drawn', 60000, async () => {
      const d = await page.evaluate(() => window.mrmmConsole.trafficDrawn());
      return d.filter((x) => x.held > 0 && !x.lost).length >= 2 ? d : null;
    });
    seen.rows = await page.$$eval('#traffic tbody tr', (rs) => rs.map((r) => r.dataset.traffic));
    // The robot killed: listed lost, with its button.
    await until(`${lost} listed lost`, 60000, () => page.$(`button[data-clear="${lost}"]`));
    seen.lost_state = await page.$eval(`tr[data-traffic="${lost}"] td:nth-child(2)`, (td) => td.textContent);
    await page.screenshot({ path: shot });
    await page.click(`button[data-clear="${lost}"]`);
    seen.message = await until('an answer', 20000, async () => {
      const m = await page.$eval('#message', (e) => e.textContent);
      return m && m.startsWith(lost) ? m : null;
    });
    // Gone from the table at a later poll.
    await until(`${lost} gone from the table`, 20000, async () => !(await page.$(`tr[data-traffic="${lost}"]`)));
    seen.rows_after = await page.$$eval('#traffic tbody tr', (rs) => rs.map((r) => r.dataset.traffic));
    if (errors.length) throw new Error(`page errors: ${errors.join('; ')}`);
  } finally {
    await browser.close();
  }
  console.log(JSON.stringify(seen));
}

main().catch((e) => { console.error(String(e && e.stack || e)); process.exit(1); });
