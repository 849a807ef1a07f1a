// The browser test of `spacearm view` pages (tests/view_browser.sh makes them): each page opens
// from disk in Debian's Chromium, headless, driven by playwright-core, with every network request
// refused. Checks: no console error, the hook (window.spacearmView) ready, the end effector
// drawn where the run's CSV says at its rows and interpolated between them, time kept within
// the run, pixels that change with time, a hostile scene name shown as text, the study's map.
//   node view_test.mjs NODE_MODULES PAGES_DIR
// PAGES_DIR holds the pages and the CSVs tests/view_browser.sh wrote; screenshots go there too.
import { createRequire } from 'node:module';
import { readFileSync } from 'node:fs';
import path from 'node:path';

const [modules, dir] = process.argv.slice(2);
const { chromium } = createRequire(path.join(path.resolve(modules), 'x.js'))('playwright-core');
let failures = 0;
function check(ok, what) {
  console.log((ok ? 'ok   ' : 'FAIL ') + what);
  if (!ok) failures++;
}

function readCsv(file) {
  const [head, ...lines] = readFileSync(path.join(dir, file), 'utf8').trim().split('\n');
  const names = head.split(',');
  return lines.map((l) => Object.fromEntries(l.split(',').map((v, i) => [names[i], +v])));
}

// Opens a page with the network refused; returns it with the errors it logs.
async function open(browser, file) {
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  page.on('console', (m) => m.type() === 'error' && errors.push(m.text()));
  page.on('pageerror', (e) => errors.push(String(e)));
  await page.route('**/*', (route) =>
    route.request().url().startsWith('file:') ? route.continue() : (errors.push('network: ' + route.request().url()), route.abort()));
  await page.goto('file://' + path.resolve(dir, file));
  await page.waitForFunction(() => window.spacearmView && (window.spacearmView.ready || window.spacearmView.error), null, { timeout: 20000 });
  return { page, errors };
}

// The drawn end effector at the CSV's rows (every tenth) and between two rows.
async function endEffectorFollowsCsv(page, rows, name) {
  let worst = 0;
  for (let k = 0; k < rows.length; k += Math.max(1, Math.floor(rows.length / 10))) {
    const r = rows[k];
    const ee = await page.evaluate((t) => (window.spacearmView.setTime(t), window.spacearmView.endEffector(0)), r.t);
    const want = [r.ee_x, r.ee_y, r.ee_z ?? 0];
    worst = Math.max(worst, ...want.map((v, i) => Math.abs(v - ee[i])));
  }
  check(worst < 1e-6, name + ': end effector at the CSV rows (max error ' + worst.toExponential(2) + ' m)');
  const [a, b] = [rows[5], rows[6]];
  const mid = await page.evaluate((t) => (window.spacearmView.setTime(t), window.spacearmView.endEffector(0)), (a.t + b.t) / 2);
  const half = [(a.ee_x + b.ee_x) / 2, (a.ee_y + b.ee_y) / 2, ((a.ee_z ?? 0) + (b.ee_z ?? 0)) / 2];
  check(half.every((v, i) => Math.abs(v - mid[i]) < 1e-6), name + ': between two rows, halfway');
  const last = rows[rows.length - 1];
  const after = await page.evaluate((t) => (window.spacearmView.setTime(t), window.spacearmView.time()), last.t + 100);
  check(after === last.t, name + ': time past the end stays at the last row (' + after + ')');
}

// Canvas pixels at the start and at the end differ; a screenshot of the page at time t.
async function drawsAndShoots(page, name, shot) {
  const range = await page.evaluate(() => window.spacearmView.timeRange);
  const canvas = page.locator('.scene3d canvas');
  await page.evaluate((t) => window.spacearmView.setTime(t), range[0]);
  const first = await canvas.screenshot();
  await page.evaluate((t) => window.spacearmView.setTime(t), range[1]);
  const last = await canvas.screenshot();
  check(first.length > 1000 && !first.equals(last), name + ': the canvas draws (pixels differ between t0 and t_end)');
  await page.evaluate((t) => window.spacearmView.setTime(t), (range[0] + range[1]) * 0.6);
  await page.screenshot({ path: path.join(dir, shot) });
}

const browser = await chromium.launch({
  executablePath: process.env.SPACEARM_CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--disable-background-networking',
         '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-quic'],
});
try {
  {  // The paper's replay at p = 10 beside its plan.
    const { page, errors } = await open(browser, 'paper.html');
    const hook = await page.evaluate(() => ({ ready: window.spacearmView.ready, frames: window.spacearmView.frames }));
    check(hook.ready && hook.frames === 401, 'paper: ready with 401 frames (' + hook.frames + ')');
    await endEffectorFollowsCsv(page, readCsv('replay.csv'), 'paper');
    const ghost = await page.evaluate(() => (window.spacearmView.setTime(1), window.spacearmView.endEffector(1)));
    check(Array.isArray(ghost), 'paper: the plan drawn as a ghost');
    check((await page.locator('.uplot').count()) >= 5, 'paper: five plots (angles, torques, energy, momentum, distance)');
    await drawsAndShoots(page, 'paper', 'paper_view.png');
    check(errors.length === 0, 'paper: no console errors ' + JSON.stringify(errors));
  }
  {  // A spatial arm.
    const { page, errors } = await open(browser, 'spatial.html');
    check(await page.evaluate(() => window.spacearmView.ready), 'spatial: ready');
    await endEffectorFollowsCsv(page, readCsv('spatial.csv'), 'spatial');
    await drawsAndShoots(page, 'spatial', 'spatial_view.png');
    check(errors.length === 0, 'spatial: no console errors ' + JSON.stringify(errors));
  }
  {  // Issue 52: two arms on one satellite, each rod and both tools drawn where the CSV has them.
    const { page, errors } = await open(browser, 'dual.html');
    check(await page.evaluate(() => window.spacearmView.ready), 'dual: ready');
    const rows = readCsv('dual.csv');
    let worst = 0;
    for (let k = 0; k < rows.length; k += Math.max(1, Math.floor(rows.length / 10))) {
      const r = rows[k];
      const drawn = await page.evaluate((t) => (window.spacearmView.setTime(t), window.spacearmView.endEffectors(0)), r.t);
      check(drawn.tips.length === 2 && drawn.rods === 14 && drawn.struts === 2,
            'dual: two tools, 14 rods and two struts (' + JSON.stringify(drawn) + ')');
      ['l', 'r'].forEach((side, e) => ['x', 'y', 'z'].forEach((c, i) => {
        worst = Math.max(worst, Math.abs(r['ee_' + side + '_tool_flange_' + c] - drawn.tips[e][i]));
      }));
    }
    check(worst < 1e-6, 'dual: both tools at the CSV rows (max error ' + worst.toExponential(2) + ' m)');
    await drawsAndShoots(page, 'dual', 'dual_view.png');
    check(errors.length === 0, 'dual: no console errors ' + JSON.stringify(errors));
  }
  {  // A URDF arm: its base drawn with the URDF's own shapes, the inertia box on request.
    const { page, errors } = await open(browser, 'urdf.html');
    check(await page.evaluate(() => window.spacearmView.ready), 'urdf: ready');
    const before = await page.evaluate(() => window.spacearmView.baseShapes());
    check(before.shapes === 1 && !before.box, 'urdf: the bus box drawn, not the inertia box (' + JSON.stringify(before) + ')');
    check(JSON.stringify(before.links) === '[1,2,2]', 'urdf: each link drawn with its shapes, the STL among them (' + JSON.stringify(before.links) + ')');
    check(JSON.stringify(before.meshTriangles) === '[4]', 'urdf: the STL tetrahedron parsed (' + JSON.stringify(before.meshTriangles) + ')');
    for (const t of [0.3, 1]) {  // each link's shapes ride on its frame, whose origin is its joint
      await page.evaluate((at) => window.spacearmView.setTime(at), t);
      const now = await page.evaluate(() => window.spacearmView.baseShapes());
      const gap = Math.max(...now.linkPositions.map((p, i) =>
        Math.hypot(...p.map((v, k) => v - now.jointPositions[i][k]))));
      check(gap < 1e-6, 'urdf: link frames at their joints at t = ' + t + ' (' + gap + ' m)');
    }
    await page.evaluate(() => window.spacearmView.setTime(0));
    // Framing: all by default; "fit the arm" comes closer to the arm, whose centre it looks at.
    const dist = (v) => Math.hypot(...v.position.map((x, k) => x - v.target[k]));
    const framedAll = await page.evaluate(() => window.spacearmView.view());
    await page.locator('button[data-fit=arm]').click();
    const framedArm = await page.evaluate(() => window.spacearmView.view());
    check(framedAll.framed === 'all' && framedArm.framed === 'arm' && dist(framedArm) < 0.8 * dist(framedAll),
          'urdf: fit the arm frames the arm closer (' + dist(framedAll).toFixed(2) + ' m, then ' + dist(framedArm).toFixed(2) + ' m)');
    await page.locator('button[data-fit=all]').click();
    check((await page.evaluate(() => window.spacearmView.view())).framed === 'all', 'urdf: fit all again');
    const canvas = page.locator('.scene3d canvas');
    const shapes = await canvas.screenshot();
    await page.locator('label.note input[type=checkbox]').check();
    const after = await page.evaluate(() => window.spacearmView.baseShapes());
    const both = await canvas.screenshot();
    check(after.box && !shapes.equals(both), 'urdf: the checkbox shows the inertia box too');
    await drawsAndShoots(page, 'urdf', 'urdf_view.png');
    check(errors.length === 0, 'urdf: no console errors ' + JSON.stringify(errors));
  }
  {  // --camera arm starts framed on the arm; --camera x,y,z,tx,ty,tz looks from there.
    const arm = await open(browser, 'urdf_arm.html');
    const a = await arm.page.evaluate(() => window.spacearmView.view());
    check(a.framed === 'arm', 'camera: --camera arm starts on the arm (' + a.framed + ')');
    const eye = await open(browser, 'urdf_eye.html');
    const e = await eye.page.evaluate(() => window.spacearmView.view());
    const near = (a, b) => a.every((x, k) => Math.abs(x - b[k]) < 1e-9);
    check(near(e.position, [6, -4, 3]) && near(e.target, [1.5, 0, 0.8]),
          'camera: --camera x,y,z,tx,ty,tz looks from and at them (' + JSON.stringify(e) + ')');
    check(arm.errors.length === 0 && eye.errors.length === 0, 'camera: no console errors');
  }
  {  // Random draws: bins with no run told from failed ones; the runs' scatter, histogram and
     // ranking find the parameter the metric follows.
    const { page, errors } = await open(browser, 'random.html');
    const legend = await page.evaluate(() => window.spacearmView.legend());
    const cells = await page.evaluate(() => window.spacearmView.cells());
    check(cells.empty > 0 && /white: no run fell in the bin/.test(legend) && !/grey: every run there failed/.test(legend) === (cells.failed === 0),
          'random: empty bins are named apart from failed ones (' + legend + ')');
    const ranking = await page.evaluate(() => window.spacearmView.ranking());
    check(ranking[0].name === 'mp' && ranking[0].r > 0.99 && Math.abs(ranking[1].r) < 0.3,
          'random: mp ranked first by correlation with ee_error (' + JSON.stringify(ranking) + ')');
    const scatter = await page.evaluate(() => window.spacearmView.scatter());
    check(scatter.x === 'mp' && scatter.y === 'ee_error' && scatter.drawn === 292 && scatter.failed === 8,
          'random: the scatter shows ee_error against mp, failed runs left out (' + JSON.stringify(scatter) + ')');
    const histogram = await page.evaluate(() => window.spacearmView.histogram());
    check(histogram.reduce((a, b) => a + b, 0) === 292, 'random: the histogram counts every run that has the metric');
    await page.screenshot({ path: path.join(dir, 'random_view.png'), fullPage: true });
    check(errors.length === 0, 'random: no console errors ' + JSON.stringify(errors));
  }
  {  // Markup in the scene's description and the run's file name.
    const { page, errors } = await open(browser, 'hostile.html');
    const seen = await page.evaluate(() => ({
      cells: [...document.querySelectorAll('td')].map((td) => td.textContent),
      notes: document.querySelector('.notes').textContent,
      pwned: window.pwned, scripts: document.scripts.length, images: document.images.length }));
    check(seen.cells.includes('</script><script>window.pwned=1</script>'), 'hostile: the description shows as text');
    check(seen.notes.includes('<img src=x onerror=window.pwned=2>.csv'), 'hostile: the file name shows as text');
    check(seen.pwned === undefined && seen.scripts === 2 && seen.images === 0, 'hostile: no script of the input ran or was added');
    check(errors.length === 0, 'hostile: no console errors ' + JSON.stringify(errors));
  }
  {  // A study: the map, a cell's values, a click that opens a run's time series.
    const { page, errors } = await open(browser, 'study.html');
    const cell = await page.evaluate(() => window.spacearmView.cell(1, 1));
    check(/p = .*Im = .*ee_error = .*run \d+/.test(cell), 'study: a cell names its parameters, metric and run (' + cell + ')');
    const run = await page.evaluate(() => window.spacearmView.open(1, 1));
    check(Number.isInteger(run) && (await page.locator('.series .uplot').count()) === 1, 'study: a click opens run ' + run + "'s series");
    await page.screenshot({ path: path.join(dir, 'study_view.png') });
    check(errors.length === 0, 'study: no console errors ' + JSON.stringify(errors));
  }
} finally {
  await browser.close();
}
console.log(failures ? failures + ' checks failed' : 'all checks passed');
process.exit(failures ? 1 : 0);
