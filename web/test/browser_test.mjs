// Headless browser test of `tensegrity serve` (registered with ctest as web_browser).
//
//   node web/test/browser_test.mjs TENSEGRITY_BINARY SCREENSHOT.png
//   node web/test/browser_test.mjs TENSEGRITY_BINARY --measure CHARACTER [SECONDS] [realtime]
//
// The first form serves the duck on a free port and checks the API's answers to
// bad input, then serves an empty character and drives Debian's chromium through playwright-core: two blocks
// built and linked, form finding, a stiffness design, a simulation in which
// the mouse drags a node; it checks that the node moved and the residual is
// shown, and saves a screenshot. The second form opens CHARACTER, designs it,
// drags a node for SECONDS and prints the simulation steps per second.
import { spawn } from 'node:child_process';
import { mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { chromium } from 'playwright-core';

const CHROMIUM = process.env.TENSEGRITY_CHROMIUM || '/usr/bin/chromium';
const CHROMIUM_ARGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader'];
const STEP_TIMEOUT_MS = 120000;

function fail(message) {
  throw new Error(message);
}

function check(condition, message) {
  if (!condition) fail(message);
  console.log(`ok: ${message}`);
}

// Starts `tensegrity serve ARGS --port 0` and resolves with its URL.
function startServer(binary, args) {
  const child = spawn(binary, ['serve', ...args, '--port', '0'], { stdio: ['ignore', 'pipe', 'pipe'] });
  let log = '';
  child.stderr.on('data', (d) => { log += d; });
  const url = new Promise((resolve, reject) => {
    let out = '';
    child.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/serving (http:\/\/127\.0\.0\.1:\d+\/)/);
      if (m) resolve(m[1]);
    });
    child.on('exit', (code) => reject(new Error(`tensegrity serve exited with ${code}: ${log}`)));
  });
  return { child, url, log: () => log };
}

async function checkApi(url) {
  const page = await fetch(url);
  const html = await page.text();
  check(page.status === 200 && html.includes('importmap') && !/https?:\/\/(?!127\.0\.0\.1)/.test(html),
    'GET / returns the app with no outside URL');
  const three = await fetch(`${url}vendor/three/build/three.module.js`);
  check(three.status === 200 && (await three.text()).includes('REVISION'), 'three.js is served locally');
  const controls = await fetch(`${url}vendor/three/examples/jsm/controls/OrbitControls.js`);
  check(controls.status === 200, 'OrbitControls are served locally');
  const bad = await fetch(`${url}api/solve`, { method: 'POST', body: '{"format": "tensegrity-scene", ' });
  const message = await bad.text();
  check(bad.status === 400 && /^tensegrity: request: line 1, column \d+: malformed JSON/.test(message) &&
    message.trim().split('\n').length === 1, `malformed JSON gives 400 and one line: ${message.trim()}`);
  const wrong = await fetch(`${url}api/solve`, { method: 'POST', body: '{"format": "tensegrity-scene", "version": 1, "nodes": [], "elements": []}' });
  check(wrong.status === 400 && (await wrong.text()).startsWith('tensegrity: request: '), 'an invalid scene gives 400');
  const put = await fetch(`${url}api/character`, { method: 'PUT', body: '{}' });
  check(put.status === 403, 'without --write the character file is not written');
  const info = await fetch(`${url}api/info`);
  check(info.status === 200 && (await info.json()).solvers.length > 0, 'the server keeps answering after bad input');
}

async function launch() {
  const profile = mkdtempSync(path.join(tmpdir(), 'tensegrity-chromium-'));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM, headless: true, args: CHROMIUM_ARGS, viewport: { width: 1280, height: 800 },
  });
  return { context, close: async () => { await context.close(); rmSync(profile, { recursive: true, force: true }); } };
}

async function openApp(context, url) {
  const page = context.pages()[0] || (await context.newPage());
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await page.goto(url);
  await page.waitForSelector('body[data-ready="true"]', { timeout: STEP_TIMEOUT_MS });
  return { page, errors };
}

async function setField(page, id, value) {
  await page.fill(`#${id}`, String(value));
  await page.dispatchEvent(`#${id}`, 'change');
}

const view = (page) => page.evaluate(() => window.tensegrityApp.state.view);

// The free node drawn highest, which the drag pulls on.
async function topFreeNode(page) {
  return page.evaluate(() => {
    const v = window.tensegrityApp.state.view;
    let best = -1;
    v.positions.forEach((p, i) => { if (!v.nodes[i].fixed && (best < 0 || p[2] > v.positions[best][2])) best = i; });
    return best;
  });
}

async function design(page) {
  await page.click('#design');
  await page.waitForFunction(() => /cable strain|no design/.test(document.getElementById('design-result').textContent),
    null, { timeout: STEP_TIMEOUT_MS });
  const text = await page.textContent('#design-result');
  if (!text.includes('cable strain')) fail(`design failed: ${await page.textContent('#message')}`);
  return text;
}

async function simulate(page, realTime) {
  if (!realTime) await page.uncheck('#realtime');
  await page.click('#simulate');
  await page.waitForFunction(() => window.tensegrityApp.state.sim && window.tensegrityApp.state.sim.steps >= 10,
    null, { timeout: STEP_TIMEOUT_MS });
}

// Presses the mouse on `node`, moves it by (dx, dy) pixels, holds for `holdMs`.
// Longest hold of a drag that waits for the node to follow the mouse.
const MAX_DRAG_HOLD_MS = 60000;

async function dragNode(page, node, dx, dy, holdMs, startPosition = null, minMove = 0) {
  const at = await page.evaluate((i) => window.tensegrityApp.nodeScreenPosition(i), node);
  await page.mouse.move(at.x, at.y);
  await page.mouse.down();
  for (let k = 1; k <= 10; ++k) {
    await page.mouse.move(at.x + dx * k / 10, at.y + dy * k / 10);
    await page.waitForTimeout(30);
  }
  const count = () => page.evaluate(() => [window.tensegrityApp.state.sim.steps, window.tensegrityApp.state.sim.requests]);
  const [steps0, requests0] = await count();
  const t0 = Date.now();
  await page.waitForTimeout(holdMs);
  // On a busy machine the simulation runs fewer steps per second: hold on
  // (up to MAX_DRAG_HOLD_MS) until the node has followed the mouse.
  if (minMove > 0) {
    await page.waitForFunction(([i, p0, d]) => {
      const p = window.tensegrityApp.state.view.positions[i];
      return Math.hypot(p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]) > d;
    }, [node, startPosition, minMove], { timeout: MAX_DRAG_HOLD_MS }).catch(() => {});
  }
  const [steps1, requests1] = await count();
  const seconds = (Date.now() - t0) / 1000;
  const dragging = await page.evaluate(() => !!window.tensegrityApp.state.sim.drag);
  // Read while still holding: once released, the node springs back.
  const held = await page.evaluate((i) => window.tensegrityApp.state.view.positions[i], node);
  await page.mouse.up();
  return { rate: (steps1 - steps0) / seconds, answers: (requests1 - requests0) / seconds, steps: steps1 - steps0, seconds,
    dragging, held };
}

const DUCK = path.join(path.dirname(new URL(import.meta.url).pathname), '..', '..', 'data', 'characters', 'duck.character.json');

// Suggest link (stiffest) between the two blocks: the table lists the
// server's ranking in its order with its numbers, and a row shows its ends
// in the link fields.
async function suggestLinkStep(page, url) {
  await page.selectOption('#suggest-want', 'stiff');
  await setField(page, 'suggest-range', 20);
  const body = await page.evaluate(() => ({ character: window.tensegrityApp.state.character,
    a: document.getElementById('link-a-block').value, b: document.getElementById('link-b-block').value,
    range: 20, stiff: true }));
  await page.click('#suggest-link');
  await page.waitForFunction(() => /links between .* ranked \(stiffest\)/.test(document.getElementById('status-line').textContent),
    null, { timeout: 120000 });
  const shown = await page.evaluate(() => [...document.querySelectorAll('#suggestions tbody tr')]
    .map((tr) => [...tr.querySelectorAll('td')].map((td) => td.textContent)));
  const reply = await fetch(`${url}api/suggest-link`, { method: 'POST', body: JSON.stringify(body) });
  const ranking = await reply.json();
  const measured = ranking.candidates.filter((c) => c.measured);
  check(reply.status === 200 && ranking.format === 'tensegrity-link-suggestions' && measured.length > 0,
    `the server ranks ${ranking.candidates.length} links between ${body.a} and ${body.b}`);
  check(shown.length === ranking.candidates.length &&
    shown.every((row, i) => row[1] === ranking.candidates[i].type && row[2] === ranking.candidates[i].a &&
      row[3] === ranking.candidates[i].b),
  `the table lists the ranking in its order (${shown.length} rows)`);
  const first = ranking.candidates.findIndex((c) => c.measured);
  check(shown[first][4] === ranking.candidates[first].principal_stiffness[0].toPrecision(4),
    `the best measured link shows its smallest stiffness ${shown[first][4]}`);
  await page.click(`#suggestions tbody tr:nth-child(${first + 1}) td:first-child`);
  const ends = await page.evaluate(() => [document.getElementById('link-type').value,
    document.getElementById('link-a-block').value, document.getElementById('link-b-block').value]);
  const link = ranking.candidates[first].link;
  check(ends[0] === link.type && ends[1] === link.a.block && ends[2] === link.b.block,
    `a row shows its link's ends: ${ends.join(' ')}`);
}

async function runTest(binary, screenshot) {
  // The API on a served character, then the app from an empty one.
  const duck = startServer(binary, [DUCK]);
  try {
    const duckUrl = await duck.url;
    await checkApi(duckUrl);
    const initial = (await (await fetch(`${duckUrl}api/info`)).json()).initial;
    check(initial.kind === 'character' && initial.json.name === 'duck', 'serving the duck: the app opens its character');
  } finally {
    duck.child.kill('SIGTERM');
  }
  const server = startServer(binary, []);
  const url = await server.url;
  const browser = await launch();
  try {
    const { page, errors } = await openApp(browser.context, url);
    // Two prisms, one above the other, joined top face to bottom face.
    await page.selectOption('#block-type', 'prism-3');
    await page.click('#add-block');
    await page.waitForFunction(() => document.getElementById('status-line').textContent.startsWith('built'));
    // The move handle: drag along its x arrow.
    await page.selectOption('#gizmo-mode', 'translate');
    const t0 = await page.evaluate(() => window.tensegrityApp.state.character.blocks[0].translation);
    const [c, e] = await page.evaluate((t) => [window.tensegrityApp.screenPosition(t),
      window.tensegrityApp.screenPosition([t[0] + 0.01, t[1], t[2]])], t0);
    const len = Math.hypot(e.x - c.x, e.y - c.y);
    const dir = { x: (e.x - c.x) / len, y: (e.y - c.y) / len };
    await page.mouse.move(c.x + 40 * dir.x, c.y + 40 * dir.y);
    await page.mouse.down();
    for (let k = 1; k <= 5; ++k) await page.mouse.move(c.x + (40 + 8 * k) * dir.x, c.y + (40 + 8 * k) * dir.y);
    await page.mouse.up();
    await page.waitForFunction((x) => window.tensegrityApp.state.character.blocks[0].translation[0] !== x, t0[0]);
    const t1 = await page.evaluate(() => window.tensegrityApp.state.character.blocks[0].translation);
    check(t1[0] > t0[0] && t1[1] === t0[1] && t1[2] === t0[2], `the move handle moved the block along x: ${t0} -> ${t1}`);
    await page.selectOption('#gizmo-mode', 'off');
    await setField(page, 'bt-tx', 0);
    await page.click('#add-block');
    await page.waitForFunction(() => window.tensegrityApp.state.character.blocks.length === 2);
    await setField(page, 'bt-tx', 0);
    await setField(page, 'bt-tz', 0.11);
    await setField(page, 'bt-rz', 60);
    await page.selectOption('#link-type', 'face');
    // Picking in 3D: shift-click the lowest node (of the first block) picks a face through it.
    await page.waitForFunction(() => /2 blocks/.test(document.getElementById('status-line').textContent));
    const low = await page.evaluate(() => {
      const v = window.tensegrityApp.state.view;
      let best = 0;
      v.positions.forEach((p, i) => { if (p[2] < v.positions[best][2]) best = i; });
      return { node: best, block: v.nodes[best].block, blockNode: v.nodes[best].block_node };
    });
    const at = await page.evaluate((i) => window.tensegrityApp.nodeScreenPosition(i), low.node);
    await page.keyboard.down('Shift');
    await page.mouse.click(at.x, at.y);
    await page.keyboard.up('Shift');
    const picked = await page.evaluate(() => [document.getElementById('link-a-block').value,
      document.getElementById('link-a-part').value]);
    const faceNodes = await page.evaluate(([b, f]) => {
      const c = window.tensegrityApp.state.character.blocks.find((x) => x.id === b);
      return window.tensegrityApp.state.info.blocks[c.type].face_nodes[f] || [];
    }, picked);
    check(picked[0] === low.block && faceNodes.includes(low.blockNode),
      `shift-click on node ${low.node} picked ${picked[0]} face ${picked[1]} through it`);
    await page.selectOption('#link-a-block', 'prism-3-1');
    await page.selectOption('#link-a-part', 'top');
    await page.selectOption('#link-b-block', 'prism-3-2');
    await page.selectOption('#link-b-part', 'bottom');
    await page.click('#add-link');
    await page.waitForFunction(() => /2 blocks, 1 face links/.test(document.getElementById('status-line').textContent));
    const status = await page.textContent('#status-line');
    check(status.includes('2 blocks, 1 face links'), `two blocks built and linked: ${status}`);
    const file = JSON.parse(await page.inputValue('#character-json'));
    check(file.blocks.length === 2 && file.links[0].a.face === 'top', 'the character file follows the edits');
    // Undo removes the link, redo brings it back.
    await page.click('#undo');
    await page.waitForFunction(() => /2 blocks, 0 face links/.test(document.getElementById('status-line').textContent));
    const undone = await page.evaluate(() => window.tensegrityApp.state.character.links.length);
    await page.click('#redo');
    await page.waitForFunction(() => /2 blocks, 1 face links/.test(document.getElementById('status-line').textContent));
    const redone = await page.evaluate(() => window.tensegrityApp.state.character.links.length);
    check(undone === 0 && redone === 1, 'undo removes the link and redo restores it');
    await suggestLinkStep(page, url);

    const before = await view(page);
    await page.click('#solve');
    await page.waitForFunction(() => window.tensegrityApp.state.solution !== null, null, { timeout: STEP_TIMEOUT_MS });
    const solution = await page.evaluate(() => window.tensegrityApp.state.solution);
    check(solution.status === 'converged' && solution.stats.relative_residual <= 1e-8,
      `form finding converged, relative residual ${solution.stats.relative_residual}`);
    const shown = await page.textContent('#status-line');
    check(shown.includes(`relative residual ${solution.stats.relative_residual.toExponential(2)}`),
      `the residual is shown: ${shown}`);
    const after = await view(page);
    const change = Math.hypot(...after.positions.flatMap((p, i) => p.map((x, k) => x - before.positions[i][k])));
    check(Math.abs(change - solution.stats.geometry_change) <= 1e-9 * Math.max(1, change),
      `the drawn geometry is the solution's (geometry change ${change.toPrecision(4)} m)`);

    await design(page);
    await simulate(page, true);
    const node = await topFreeNode(page);
    const start = (await view(page)).positions[node];
    const size = await page.evaluate(() => {
      const p = window.tensegrityApp.state.view.positions;
      const lo = [0, 1, 2].map((k) => Math.min(...p.map((q) => q[k]))), hi = [0, 1, 2].map((k) => Math.max(...p.map((q) => q[k])));
      return Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    });
    const drag = await dragNode(page, node, 120, -60, 1500, start, 0.05 * size);
    check(drag.dragging, 'the mouse grabbed a node');
    const end = drag.held;
    const moved = Math.hypot(end[0] - start[0], end[1] - start[1], end[2] - start[2]);
    check(moved > 0.05 * size, `dragging moved node ${node} by ${(1000 * moved).toFixed(1)} mm (structure ${(1000 * size).toFixed(0)} mm)`);
    const simText = await page.textContent('#sim-result');
    check(/steps\/s/.test(simText), `simulation shown: ${simText}`);
    await page.click('#stop');
    await page.waitForTimeout(200);
    // Exports: the fabrication sheet and the picture.
    await page.click('summary:has-text("Export")');
    const [sheet] = await Promise.all([page.waitForEvent('download'), page.click('[data-export="sheet"]')]);
    const csv = readFileSync(await sheet.path(), 'utf8').split('\n');
    const struts = (await view(page)).elements.filter((e) => e.kind === 'strut').length;
    check(csv[0].startsWith('group_kind,group,element,name,kind') &&
      csv.filter((l) => /^[a-z]+,[^,]*,\d+,[^,]*,strut,/.test(l)).length === struts,
      `the fabrication sheet lists the ${struts} struts (${sheet.suggestedFilename()})`);
    const [png] = await Promise.all([page.waitForEvent('download'), page.click('[data-export="png"]')]);
    const bytes = readFileSync(await png.path());
    check(bytes.subarray(1, 4).toString() === 'PNG' && bytes.length > 10000, `PNG export (${bytes.length} bytes)`);
    const message = await page.evaluate(() => document.getElementById('message').textContent);
    check(!message.includes('nothing to export'), `an export that downloads says nothing is missing ("${message}")`);
    await page.screenshot({ path: screenshot });
    check(errors.length === 0, `no errors in the page${errors.length ? ': ' + errors.join('; ') : ''}`);
    console.log(`screenshot: ${screenshot}`);
  } finally {
    await browser.close();
    server.child.kill('SIGTERM');
  }
}

async function runMeasure(binary, character, seconds, realTime) {
  const server = startServer(binary, [character, '--time-limit', '300']);
  const url = await server.url;
  const browser = await launch();
  try {
    const { page } = await openApp(browser.context, url);
    const t0 = Date.now();
    console.log(await design(page), `(${((Date.now() - t0) / 1000).toFixed(1)} s)`);
    const counts = await page.evaluate(() => {
      const v = window.tensegrityApp.state.view;
      return `${v.nodes.length} nodes, ${v.elements.length} elements`;
    });
    await simulate(page, realTime);
    const node = await topFreeNode(page);
    const drag = await dragNode(page, node, 100, -50, 1000 * seconds);
    const perStep = await page.evaluate(() => {
      const s = window.tensegrityApp.state.sim;
      return 1000 * s.stepSeconds / s.steps;
    });
    console.log(`${path.basename(character)}: ${counts}; while dragging node ${node} ` +
      `(${realTime ? 'real time: the steps due per request' : 'one step per request'}): ${drag.steps} steps in ` +
      `${drag.seconds.toFixed(2)} s = ${drag.rate.toFixed(1)} steps/s, ${drag.answers.toFixed(1)} answers/s; ` +
      `solver time ${perStep.toFixed(2)} ms per step`);
  } finally {
    await browser.close();
    server.child.kill('SIGTERM');
  }
}

const [binary, second, third, fourth, fifth] = process.argv.slice(2);
if (!binary || !second) {
  console.error('usage: browser_test.mjs TENSEGRITY SCREENSHOT.png | TENSEGRITY --measure CHARACTER [SECONDS]');
  process.exit(2);
}
const run = second === '--measure' ? runMeasure(binary, third, Number(fourth || 10), fifth === 'realtime') : runTest(binary, second);
run.then(() => process.exit(0), (err) => { console.error(`FAILED: ${err.message}`); process.exit(1); });
