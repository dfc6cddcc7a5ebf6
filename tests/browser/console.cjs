// The browser console driven as an operator would, in Debian's Chromium (headless) through
// Playwright: robots box-selected on the map, a patrol drawn and created with them, a robot
// clicked on the map and assigned to it, one released, the advising agent's suggestion applied,
// an idle robot sent to a point clicked on the map.
// Usage: node console.cjs URL SCREENSHOT.
// Prints one JSON line with what it saw; exits non-zero (with the reason) on any failure.
'use strict';
const { launch } = require('./launch.cjs');

const [url, shot] = process.argv.slice(2);
const LIMIT = 30000;

async function main() {
  const { browser, page } = await launch();
  const seen = {};
  try {
    const errors = [];
    page.on('pageerror', (e) => errors.push(String(e)));
    // A command central refuses is an HTTP 409 (the deliberate mistake below: a name taken): Chromium logs
    // it; anything else logged as an error is one.
    page.on('console', (m) => { if (m.type() === 'error' && !m.text().includes('status of 409')) errors.push(m.text()); });
    await page.goto(url);
    // The token left the address bar once read.
    seen.address_without_token = !page.url().includes('token');
    const snap = () => page.evaluate(() => window.mrmmConsole.snapshot());
    const until = async (what, pred) => {
      const t0 = Date.now();
      for (;;) {
        const s = await snap();
        if (pred(s)) return s;
        if (Date.now() - t0 > LIMIT) {
          const msg = await page.textContent('#message');
          throw new Error(`timed out waiting for ${what} (the page says ${JSON.stringify(msg)}): ${JSON.stringify(s).slice(0, 600)}`);
        }
        await page.waitForTimeout(100);
      }
    };
    await until('4 robots with poses', (s) => s.robots.length === 4 && s.robots.every((r) => r.pose));
    const at = (id) => page.evaluate((i) => window.mrmmConsole.robotOnPage(i), id);
    // Each robot is drawn where the page says it is: the canvas is painted at its centre.
    const painted = (id) => page.evaluate((i) => {
      const c = document.getElementById('map'), p = window.mrmmConsole.robotOnPage(i), b = c.getBoundingClientRect();
      const k = c.width / b.width;
      return c.getContext('2d').getImageData(Math.round((p.x - b.left) * k), Math.round((p.y - b.top) * k), 1, 1).data[3] > 0;
    }, id);
    // Until every robot is painted where the page says it is (a robot that moved since the last
    // frame is painted at the next: on a loaded machine a fixed wait missed one).
    const t1 = Date.now();
    for (;;) {
      seen.drawn = [];
      for (const id of ['r1', 'r2', 'r3', 'r4']) if (await painted(id)) seen.drawn.push(id);
      if (seen.drawn.length === 4) break;
      if (Date.now() - t1 > LIMIT) throw new Error(`robots drawn on the map: ${seen.drawn}`);
      await page.waitForTimeout(100);
    }

    // Box-select r1 and r2 on the map (they stand apart from r3 and r4).
    const [a, b] = [await at('r1'), await at('r2')];
    await page.mouse.move(Math.min(a.x, b.x) - 18, Math.min(a.y, b.y) - 18);
    await page.mouse.down();
    await page.mouse.move((a.x + b.x) / 2, (a.y + b.y) / 2 + 5, { steps: 4 });
    await page.mouse.move(Math.max(a.x, b.x) + 18, Math.max(a.y, b.y) + 18, { steps: 4 });
    await page.mouse.up();
    seen.boxed = await page.evaluate(() => window.mrmmConsole.selected());
    if (seen.boxed.join() !== 'r1,r2') throw new Error(`box selection: ${seen.boxed}`);

    // A patrol drawn on the map, created with the selection.
    await page.fill('#new-name', 'p');
    await page.selectOption('#new-recipe', 'patrol');
    await page.click('#draw');
    // The view stays still while drawing; zoomed out (the wheel) to reach the square's far side.
    const box = await page.locator('#map').boundingBox();
    for (let i = 0; i < 5; i++) { await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2); await page.mouse.wheel(0, 200); await page.waitForTimeout(50); }
    for (const [x, y] of [[0, 0], [10, 10]]) {
      const p = await page.evaluate(([x, y]) => window.mrmmConsole.worldOnPage(x, y), [x, y]);
      if (p.x < box.x || p.y < box.y || p.x > box.x + box.width || p.y > box.y + box.height) throw new Error(`(${x}, ${y}) is off the map after zooming out`);
    }
    for (const [x, y] of [[0, 0], [10, 0], [10, 10], [0, 10]]) {
      const p = await page.evaluate(([x, y]) => window.mrmmConsole.worldOnPage(x, y), [x, y]);
      await page.mouse.click(p.x, p.y);
    }
    seen.points = await page.textContent('#points');
    await page.click('#create');
    await until('mission p running with r1, r2', (s) => s.missions.some((m) => m.name === 'p' && m.status === 'running' && m.robots.join() === 'r1,r2'));
    // The page's own answer to the create ends the drawing (the fleet's tables may show p
    // running before it comes: until then a click on the map is still a point).
    await page.waitForFunction(() => document.querySelector('#message').textContent.startsWith('p '), null, { timeout: 20000 });
    seen.created = await page.textContent('#message');

    // r3 clicked on the map (a plain click selects it alone) and assigned to p from its row.
    const c = await at('r3');
    await page.mouse.click(c.x, c.y);
    seen.clicked = await page.evaluate(() => window.mrmmConsole.selected());
    if (seen.clicked.join() !== 'r3') throw new Error(`click selection: ${seen.clicked}`);
    await page.click('button[data-assign="p"]');
    await until('r3 in p', (s) => s.missions.some((m) => m.name === 'p' && m.robots.includes('r3')));

    // r1 picked from the robot table and released: p goes on with r2 and r3.
    await page.click('#robots tr[data-robot="r1"]');
    await page.click('#release');
    await until('r1 out of p', (s) => s.missions.some((m) => m.name === 'p' && m.robots.join() === 'r2,r3') && s.robots.some((r) => r.id === 'r1' && r.status === 'idle'));

    // The advising agent suggests adding an idle robot to p: applied with one click.
    const advice = await until('advice to add an idle robot to p', (s) => s.advice.some((a) => a.id === 'idle' && a.action && a.action.to === 'p'));
    seen.advice = advice.advice.find((a) => a.id === 'idle').action;
    await page.click('button[data-apply="idle"]');
    const s = await until(`${seen.advice.robot} in p`, (s) => s.missions.some((m) => m.name === 'p' && m.robots.includes(seen.advice.robot) && m.robots.length === 3));
    seen.final = s.missions.map((m) => ({ name: m.name, robots: m.robots, status: m.status }));
    seen.tour_drawn = s.missions.some((m) => m.summary && m.summary.planner === 'patrol' && m.summary.tour.length === 4);
    // p edited: a triangle drawn on the map becomes its waypoints, the same members go on. Its
    // first corner is clicked where r2 stands: while drawing, a click is a point, not a selection.
    await page.click('#draw');
    const r2 = (await snap()).robots.find((r) => r.id === 'r2').pose;
    for (const [x, y] of [[r2.x, r2.y], [5, 5], [12, 5]]) {
      const p = await page.evaluate(([x, y]) => window.mrmmConsole.worldOnPage(x, y), [x, y]);
      await page.mouse.click(p.x, p.y);
    }
    seen.edit_points = await page.textContent('#points');
    await page.click('button[data-edit="p"]');
    const e = await until('p replanned on the triangle', (s) => s.missions.some((m) => m.name === 'p' && m.summary && m.summary.tour && m.summary.tour.length === 3));
    seen.edited = e.missions.filter((m) => m.name === 'p').map((m) => ({ tour: m.summary.tour.length, robots: m.robots.length }))[0];

    // The idle r4, picked in the table, sent to a point clicked on the map.
    await page.click('#robots tr[data-robot="r4"]');
    await page.click('#goto');
    const target = await page.evaluate(() => window.mrmmConsole.worldOnPage(-4, -6));
    await page.mouse.click(target.x, target.y);
    const near = (b) => {
      const m = /^goto\((-?[\d.]+),(-?[\d.]+)\)$/.exec(b || '');
      return !!m && Math.abs(Number(m[1]) + 4) < 0.3 && Math.abs(Number(m[2]) + 6) < 0.3;
    };
    const g = await until('r4 going to the clicked point', (s) => s.robots.some((r) => r.id === 'r4' && near(r.behaviour)));
    seen.goto = g.robots.find((r) => r.id === 'r4').behaviour;
    // r4 is fitted with cameras: said in the Capabilities… dialog (its list, empty, to edit).
    page.once('dialog', (d) => { seen.caps_offered = d.defaultValue(); d.accept('camera, thermal'); });
    await page.click('#caps');
    await until('r4 with a thermal camera', (s) => s.robots.some((r) => r.id === 'r4' && (r.capabilities || []).join() === 'camera,thermal'));
    seen.caps_cell = await page.textContent('#robots tr[data-robot="r4"] td.caps');
    seen.caps_message = await page.textContent('#message');
    // A mistake gets a clear message, not a broken page.
    await page.fill('#new-name', 'p');
    await page.click('#create');
    await page.waitForFunction(() => document.querySelector('#message').classList.contains('error'), null, { timeout: LIMIT });
    seen.refused = await page.textContent('#message');
    await page.screenshot({ path: shot });
    seen.errors = errors;
    if (errors.length) throw new Error(`page errors: ${errors.join(' | ')}`);
    console.log(JSON.stringify(seen));
  } catch (e) {
    await page.screenshot({ path: shot }).catch(() => {});
    throw e;
  } finally {
    await browser.close();
  }
}

main().catch((e) => {
  console.error(`console e2e: ${e && e.stack ? e.stack : e}`);
  process.exit(1);
});
