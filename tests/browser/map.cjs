// The browser console draws central's map under the fleet: loads the console in Debian's
// Chromium (headless) through Playwright, waits for the map to be drawn, and reads the canvas
// where the page puts a wall and a corridor of the demo building.
// Usage: node map.cjs URL SCREENSHOT. Prints one JSON line with what it saw.
'use strict';
const { launch } = require('./launch.cjs');

const [url, shot] = process.argv.slice(2);

async function main() {
  const { browser, page } = await launch();
  const seen = {};
  try {
    const errors = [];
    page.on('pageerror', (e) => errors.push(String(e)));
    await page.goto(url);
    const t0 = Date.now();
    for (;;) {
      seen.maps = await page.evaluate(() => window.mrmmConsole.mapsDrawn());
      if (seen.maps.length) break;
      if (Date.now() - t0 > 30000) throw new Error('no map drawn within 30 s');
      await page.waitForTimeout(100);
    }
    await page.waitForTimeout(300);
    // The grey level the canvas shows at world point (x, y).
    const shade = (x, y) => page.evaluate(([x, y]) => {
      const c = document.getElementById('map'), p = window.mrmmConsole.worldOnPage(x, y), b = c.getBoundingClientRect();
      const k = c.width / b.width;
      const d = c.getContext('2d').getImageData(Math.round((p.x - b.left) * k), Math.round((p.y - b.top) * k), 1, 1).data;
      return (d[0] + d[1] + d[2]) / 3;
    }, [x, y]);
    seen.wall = await shade(-4, 6);
    seen.corridor = await shade(7.3, 0.4);
    seen.options = await page.$$eval('#new-map option', (os) => os.map((o) => o.value));
    await page.screenshot({ path: shot });
    if (errors.length) throw new Error(`page errors: ${errors.join('; ')}`);
  } finally {
    await browser.close();
  }
  console.log(JSON.stringify(seen));
}

main().catch((e) => { console.error(String(e && e.stack || e)); process.exit(1); });
