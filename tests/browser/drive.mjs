// Drives mdas's index.html pages in headless Chromium (.ci/browser-test.sh):
// real keyboard, mouse and wheel events through playwright-core, a
// screenshot after each step, and a record of what each screenshot should
// show (steps.json), which verify.py checks against the EXR and PNG files
// with its own readers. This script fails by itself on a console error or
// warning, a page error, a request that is not file: or data:, a page that
// is not ready in time, or a page state other than the step asked for.
//
//   node drive.mjs --chromium /usr/bin/chromium --out DIR \
//       --compare DIR --sweep DIR --tune DIR --big DIR [--runs 3]
import { chromium } from 'playwright-core';
import fs from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
const out = path.resolve(args.out);
fs.mkdirSync(path.join(out, 'shots'), { recursive: true });
const VIEWPORT = { width: 1280, height: 900 };
const READY_TIMEOUT_MS = 60000;

let failures = 0;
function fail(message) {
  failures++;
  console.error(`FAIL: ${message}`);
}
function check(cond, message) {
  if (!cond) fail(message);
  return cond;
}

const browser = await chromium.launch({
  executablePath: args.chromium || '/usr/bin/chromium',
  headless: true,
  args: ['--force-color-profile=srgb', '--disable-lcd-text'],
});

// A page with every console message, page error and request watched.
async function open(dir, label) {
  const context = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
  const page = await context.newPage();
  const problems = [];
  page.on('console', (m) => {
    if (m.type() === 'error' || m.type() === 'warning') problems.push(`console ${m.type()}: ${m.text()}`);
  });
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('request', (r) => {
    if (!/^(file|data):/.test(r.url())) problems.push(`network request: ${r.url()}`);
  });
  page.on('requestfailed', (r) => problems.push(`request failed: ${r.url().slice(0, 80)}`));
  const url = pathToFileURL(path.join(path.resolve(dir), 'index.html')).href;
  const t0 = Date.now();
  await page.goto(url, { waitUntil: 'load', timeout: READY_TIMEOUT_MS });
  await page.waitForFunction(() => window.mdasView && (window.mdasView.ready || window.mdasView.error), null, { timeout: READY_TIMEOUT_MS });
  const wallMs = Date.now() - t0;
  const hook = await page.evaluate(() => ({ ready: window.mdasView.ready, error: window.mdasView.error, loadMs: window.mdasView.loadMs }));
  check(hook.ready && !hook.error, `${label}: page not ready: ${hook.error}`);
  return { context, page, problems, loadMs: hook.loadMs, wallMs, label };
}
async function close(p) {
  // Let late messages arrive before judging the console.
  await p.page.waitForTimeout(100);
  // Text the page built from its record: no value rendered as a JS
  // artefact (an element or array stringified, a missing field).
  const text = await p.page.locator('body').innerText();
  for (const bad of ['[object ', 'undefined', 'NaN']) {
    check(!text.includes(bad), `${p.label}: the page shows '${bad}': ...${text.slice(Math.max(0, text.indexOf(bad) - 60), text.indexOf(bad) + 40)}...`);
  }
  for (const m of p.problems) fail(`${p.label}: ${m}`);
  await p.context.close();
}

const steps = [];
async function shot(p, name, expect) {
  // Two animation frames: the canvas has been drawn and composited.
  await p.page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  const state = await p.page.evaluate(() => window.mdasView.state());
  const badge = await p.page.locator('#badge').boundingBox();
  const file = path.join('shots', `${String(steps.length).padStart(2, '0')}-${name}.png`);
  await p.page.screenshot({ path: path.join(out, file) });
  if (expect.label !== undefined) check(state.label === expect.label, `${name}: shows ${state.label}, not ${expect.label}`);
  if (expect.layer !== undefined) check(state.layer === expect.layer && state.layerShown === !!expect.layer, `${name}: layer ${state.layer} (shown ${state.layerShown}), not ${expect.layer}`);
  if (expect.stops !== undefined) check(Math.abs(state.stops - expect.stops) < 1e-9, `${name}: exposure ${state.stops}, not ${expect.stops}`);
  if (expect.minZoom !== undefined) check(state.zoom >= expect.minZoom, `${name}: zoom ${state.zoom} below ${expect.minZoom}`);
  steps.push({ page: p.dir, name, shot: file, state, exclude: badge ? [badge] : [], pixel: expect.pixel || null });
  return state;
}
const client = (p, x, y) => p.page.evaluate(([a, b]) => window.mdasView.filmToClient(a, b), [x, y]);
const state = (p) => p.page.evaluate(() => window.mdasView.state());

// ---------- the comparison page ----------
async function comparison(dir, label, methods) {
  const p = await open(dir, label);
  p.dir = path.resolve(dir);
  const s0 = await state(p);
  const [W, H] = s0.film;
  check(s0.images[0] === 'reference' && s0.images.length === methods.length + 1, `${label}: images ${s0.images}`);
  await shot(p, 'fit-reference', { label: 'reference', stops: 0, layer: null });

  // Switch by key, by click on a button, by click on a table row, by arrow.
  await p.page.keyboard.press('1');
  await shot(p, 'key-1', { label: methods[0] });
  await p.page.getByRole('button', { name: new RegExp(`^${methods[1].replace(/[+]/g, '\\+')}`) }).click();
  await shot(p, 'click-button', { label: methods[1] });
  await p.page.locator('tr[data-image="1"]').click();
  await shot(p, 'click-row', { label: methods[0] });
  await p.page.keyboard.press('ArrowRight');
  await shot(p, 'arrow-right', { label: methods[1] });
  await p.page.keyboard.press('r');
  await shot(p, 'key-r', { label: 'reference' });

  // Zoom into a crop with the wheel, about a film pixel under the cursor,
  // down to single pixels; the pixel stays under the cursor.
  const target = [Math.floor(W * 0.62), Math.floor(H * 0.31)];
  let c = await client(p, ...target);
  await p.page.mouse.move(c.x, c.y);
  for (let i = 0; i < 12 && (await state(p)).zoom < 64; i++) {
    await p.page.mouse.wheel(0, -120);
    await p.page.waitForTimeout(30);
  }
  const zoomed = await shot(p, 'wheel-zoom', { label: 'reference', minZoom: 64 });
  c = await client(p, ...target);
  const under = await p.page.evaluate(([x, y]) => {
    const s = window.mdasView.state();
    return [Math.floor((x - s.canvas.left - s.ox) / s.zoom), Math.floor((y - s.canvas.top - s.oy) / s.zoom)];
  }, [c.x, c.y]);
  check(under[0] === target[0] && under[1] === target[1], `zoom lost the pixel under the cursor: ${under} not ${target}`);
  check(zoomed.zoom * 1 >= 64, `zoomed to ${zoomed.zoom}`);
  // The inspector shows every image's values at the pixel under the cursor.
  await p.page.mouse.move(c.x, c.y);
  const inspector = await p.page.evaluate(() => [...document.querySelectorAll('aside tbody tr')].map((tr) => [...tr.cells].map((td) => td.textContent)));
  steps.push({ page: p.dir, name: "inspector", inspector, pixel: target });
  check(inspector.length === methods.length + 1, `inspector rows ${inspector.length}`);

  // Keys: zoom out one step, pan with Shift+arrows, then drag with the mouse.
  await p.page.keyboard.press('-');
  await p.page.keyboard.press('Shift+ArrowLeft');
  const before = await state(p);
  await p.page.mouse.move(c.x, c.y);
  await p.page.mouse.down();
  await p.page.mouse.move(c.x - 37, c.y + 21, { steps: 4 });
  await p.page.mouse.up();
  const after = await shot(p, 'keys-pan-drag', { label: 'reference' });
  check(after.ox - before.ox === -37 && after.oy - before.oy === 21, `drag moved the view by ${after.ox - before.ox}, ${after.oy - before.oy}`);

  // Methods at this zoom; a map layer on each where it exists.
  await p.page.keyboard.press('1');
  await shot(p, 'zoomed-method-1', { label: methods[0] });
  for (const [key, layer] of [['e', 'relmse'], ['f', 'flip'], ['d', 'density']]) {
    const s = await state(p);
    if (!s.layers.includes(layer)) continue;
    await p.page.keyboard.press(key);
    await shot(p, `map-${layer}`, { label: methods[0], layer });
  }
  await p.page.getByRole('button', { name: /^RelMSE/ }).click();
  await p.page.keyboard.press('2');
  await shot(p, 'map-relmse-method-2', { label: methods[1], layer: 'relmse' });
  await p.page.keyboard.press('n');
  await shot(p, 'no-map', { label: methods[1], layer: null });

  // Exposure: keys, then the slider dragged with the mouse.
  for (let i = 0; i < 3; i++) await p.page.keyboard.press(']');
  await shot(p, 'exposure-keys', { label: methods[1], stops: 1.5 });
  const slider = p.page.getByLabel('exposure in stops');
  const box = await slider.boundingBox();
  await p.page.mouse.click(box.x + box.width * 0.3, box.y + box.height / 2);
  const s = await state(p);
  check(s.stops < -1, `the slider click set ${s.stops} stops`);
  await shot(p, 'exposure-slider', { label: methods[1], stops: s.stops });
  await p.page.keyboard.press('\\');
  await p.page.keyboard.press('0');
  await shot(p, 'fit-again', { label: methods[1], stops: 0 });
  await close(p);
}

// ---------- sweep and tune pages ----------
async function tables(dir, label, kind) {
  const p = await open(dir, label);
  const record = JSON.parse(fs.readFileSync(path.join(dir, `${kind}.json`), 'utf8'));
  const s = await state(p);
  check(s.kind === kind && s.rows === record.rows.length, `${label}: state ${JSON.stringify(s)}`);
  if (kind === 'sweep') {
    const w = await p.page.locator('img.plot').evaluate((img) => img.complete && img.naturalWidth);
    check(w > 0, `${label}: the plot did not load`);
  }
  // The first table has the record's rows; a click on RelMSE sorts it.
  const table = p.page.locator('table.sortable').first();
  check((await table.locator('tbody tr').count()) === record.rows.length, `${label}: row count`);
  const header = table.locator('th', { hasText: /^RelMSE$/ });
  const column = await header.evaluate((th) => th.cellIndex);
  for (const dir of [1, -1]) {
    await header.click();
    const shown = await table.locator('tbody tr').evaluateAll((rows, i) => rows.map((r) => Number(r.cells[i].textContent)), column);
    const want = record.rows.map((r) => r.relmse).sort((a, b) => dir * (a - b));
    check(shown.every((v, i) => Math.abs(v - want[i]) <= 1e-3 * Math.abs(want[i])), `${label}: sorted ${dir > 0 ? 'up' : 'down'}: ${shown} not ${want}`);
  }
  const text = await p.page.locator('main').innerText();
  check(text.includes('command line') && text.includes(record.provenance.command_line[1]), `${label}: no provenance`);
  await p.page.screenshot({ path: path.join(out, 'shots', `${kind}.png`), fullPage: true });
  await close(p);
}

// ---------- load time of a large comparison ----------
async function loadTime(dir, runs) {
  const times = [];
  for (let i = 0; i < runs; i++) {
    const p = await open(dir, `large page, load ${i + 1}`);
    p.dir = path.resolve(dir);
    times.push({ loadMs: p.loadMs, wallMs: p.wallMs });
    if (i === runs - 1) {
      // One zoomed check on the large page as well.
      const [W, H] = (await state(p)).film;
      const c = await client(p, Math.floor(W / 2), Math.floor(H / 2));
      await p.page.mouse.move(c.x, c.y);
      for (let k = 0; k < 8 && (await state(p)).zoom < 16; k++) await p.page.mouse.wheel(0, -120);
      await p.page.keyboard.press('2');
      await shot(p, 'large-zoomed', { minZoom: 16 });
    }
    await close(p);
  }
  return times;
}

try {
  const methods = (dir) => JSON.parse(fs.readFileSync(path.join(dir, 'report.json'), 'utf8')).methods.map((m) => m.name);
  await comparison(args.compare, 'compare page', methods(args.compare));
  if (args.sweep) await tables(args.sweep, 'sweep page', 'sweep');
  if (args.tune) await tables(args.tune, 'tune page', 'tune');
  let times = [];
  if (args.big) times = await loadTime(args.big, Number(args.runs || 3));
  fs.writeFileSync(path.join(out, 'steps.json'), JSON.stringify({ steps, loads: times }, null, 1));
  for (const t of times) console.log(`large page: ready ${t.loadMs.toFixed(0)} ms after navigation start (${t.wallMs} ms from goto)`);
} catch (e) {
  fail(e.stack || String(e));
} finally {
  await browser.close();
}
if (failures) {
  console.error(`${failures} browser check(s) failed`);
  process.exit(1);
}
console.log(`browser: ${steps.length} steps driven, no console errors or warnings`);
