// Browser tests for Relief Studio: the real page in Debian's Chromium (headless, SwiftShader
// WebGL 2) through playwright-core, driven with the mouse, keyboard and file inputs like a person.
// Run by CTest (labels studio, browser, slow); RELIEF_BINARY names the binary.
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { startStudio, launchBrowser, waitIdle, greyPng } from './harness.mjs';

let server, browser;
before(async () => {
  server = await startStudio();
  browser = await launchBrowser();
});
after(async () => {
  if (browser) await browser.close();
  if (server) assert.equal(await server.stop(), 0);
});

// A fresh page at `query`, with its console errors and page errors collected.
async function open(query = '?size=257') {
  const page = await browser.context.newPage();
  const errors = [];
  page.on('console', (m) => m.type() === 'error' && errors.push(m.text()));
  page.on('pageerror', (e) => errors.push(String(e)));
  await page.goto(server.url + '/' + query);
  await waitIdle(page);
  return { page, errors };
}

const pixels = (page) => page.evaluate(() => window.studio.readPixels(6));

function meanAbsDiff(a, b) {
  assert.equal(a.pixels.length, b.pixels.length);
  let s = 0;
  for (let k = 0; k < a.pixels.length; k++) s += Math.abs(a.pixels[k] - b.pixels[k]);
  return s / a.pixels.length;
}

// Drags a lil-gui slider (found by its parameter path) to `fraction` of its width in small
// steps, pausing between them so that updates arrive while the mouse is still down.
async function dragSlider(page, param, fraction, { steps = 8, pauseMs = 250 } = {}) {
  const slider = page.locator(`[data-param="${param}"] .lil-slider`);
  await slider.scrollIntoViewIfNeeded();
  const box = await slider.boundingBox();
  assert.ok(box, `slider ${param} is on screen`);
  const value = await page.evaluate((p) => window.studio.state.recipe.stages[0].octaves, param);
  const y = box.y + box.height / 2;
  const startX = box.x + box.width * ((value - 1) / 15);
  await page.mouse.move(startX, y);
  await page.mouse.down();
  const during = [];
  for (let k = 1; k <= steps; k++) {
    await page.mouse.move(startX + (box.x + box.width * fraction - startX) * (k / steps), y);
    await page.waitForTimeout(pauseMs);
    during.push(await page.evaluate(() => window.studio.state.generations));
  }
  await page.mouse.up();
  return during;
}

test('the page loads with no console error and builds its panel from the parameter table', async () => {
  const { page, errors } = await open();
  assert.deepEqual(errors, []);
  const recipe = await page.evaluate(() => window.studio.state.recipe);
  assert.equal(recipe.name, 'island');
  // One folder per recipe stage, titled by its label.
  const titles = await page.locator('#panel-box .lil-gui .lil-title').allTextContents();
  recipe.stages.forEach((s, i) => assert.ok(titles.includes(`${i + 1} · ${s.label}`), `folder for stage ${i}: ${titles}`));
  // Each control carries its description as help text.
  const table = await (await fetch(server.url + '/api/params')).json();
  const octaves = table.stages.find((s) => s.name === 'noise').params.find((p) => p.name === 'octaves');
  const title = await page.locator('[data-param="stages[0].octaves"]').getAttribute('title');
  assert.ok(title.includes(octaves.description), title);
  await page.hover('[data-param="stages[0].octaves"]');
  assert.ok((await page.textContent('#help')).includes(octaves.description));
  // The view tabs list the layers the terrain has; the export menu lists every writer.
  const tabs = await page.locator('#views button').evaluateAll((b) => b.map((x) => x.dataset.view));
  assert.deepEqual(tabs.slice(0, 4), ['3d', 'color', 'albedo', 'height']);
  const formats = await page.locator('#export-menu button.format').evaluateAll((b) => b.map((x) => x.dataset.format));
  assert.deepEqual(formats, table.formats.map((f) => f.name));
  await page.close();
});

test('the 3D canvas is not blank', async () => {
  const { page } = await open();
  const p = await pixels(page);
  assert.ok(p.width > 400 && p.height > 300);
  assert.ok(p.variance > 150, `luminance variance ${p.variance}`);
  // Land colours (green dominant) and sea colours (blue dominant) are both on screen.
  let green = 0, blue = 0;
  for (let k = 0; k < p.pixels.length; k += 3) {
    const [r, g, b] = [p.pixels[k], p.pixels[k + 1], p.pixels[k + 2]];
    if (g > r + 10 && g > b + 10) green++;
    if (b > r + 20 && b > g) blue++;
  }
  const n = p.pixels.length / 3;
  assert.ok(green / n > 0.05, `green share ${green / n}`);
  assert.ok(blue / n > 0.05, `blue share ${blue / n}`);
  await page.close();
});

test('dragging the octaves slider reshapes the island while dragging', async () => {
  const { page, errors } = await open();
  const before = await pixels(page);
  const gens0 = await page.evaluate(() => window.studio.state.generations);
  const during = await dragSlider(page, 'stages[0].octaves', 0.02);
  await waitIdle(page, gens0 + 1);
  const octaves = await page.evaluate(() => window.studio.state.recipe.stages[0].octaves);
  assert.equal(octaves, 1);
  // Whatever resolution the drag previewed at, the picture after release is the full preview.
  assert.equal(await page.evaluate(() => window.studio.state.result.header.frame.nx), 257);
  assert.equal(await page.evaluate(() => window.studio.state.result.header.recipe.stages[0].octaves), 1);
  assert.ok(during.at(-1) - gens0 >= 2, `updates while the mouse was down: ${during.map((g) => g - gens0)}`);
  const after = await pixels(page);
  assert.ok(meanAbsDiff(before, after) > 3, `picture changed by ${meanAbsDiff(before, after)}`);
  const lat = await page.evaluate(() => window.studio.state.latencies);
  assert.ok(lat.length >= 2);
  assert.deepEqual(errors, []);
  await page.close();
});

test('a colour-only slider re-runs only the colour stages', async () => {
  const { page } = await open();
  const recipe = await page.evaluate(() => window.studio.state.recipe);
  const idx = recipe.stages.findIndex((s) => s.stage === 'color');
  await page.click(`#panel-box .lil-title:text-is("${idx + 1} · ${recipe.stages[idx].label}")`);
  const gens = await page.evaluate(() => window.studio.state.generations);
  const slider = page.locator(`[data-param="stages[${idx}].rock_slope_deg"] .lil-slider`);
  await slider.scrollIntoViewIfNeeded();
  const box = await slider.boundingBox();
  await page.mouse.click(box.x + box.width * 0.1, box.y + box.height / 2);
  await waitIdle(page, gens + 1);
  const runs = await page.evaluate((g) => window.studio.state.runs.slice(g - window.studio.state.generations), gens);
  assert.ok(runs.length >= 1);
  for (const r of runs) assert.equal(r.first_stage, idx, `every update re-ran from the colour stage: ${JSON.stringify(runs)}`);
  assert.deepEqual(runs[0].cached, recipe.stages.map((_, i) => i < idx));
  await page.close();
});

test('the 2D views show every layer the terrain has', async () => {
  const { page } = await open('?size=129');
  const tabs = await page.locator('#views button').evaluateAll((b) => b.map((x) => x.dataset.view).filter((v) => v !== '3d'));
  const available = await page.evaluate(() => Object.keys(window.studio.state.result.header.available));
  assert.deepEqual([...tabs].sort(), [...available].sort());
  for (const v of tabs) {
    await page.click(`#views button[data-view="${v}"]`);
    await page.waitForFunction((name) => window.studio.state.result.layers[name], v);
    const img = await page.evaluate(() => {
      const c = document.getElementById('view2d');
      const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      let s = 0, s2 = 0;
      for (let k = 0; k < d.length; k += 4) (s += d[k + 1]), (s2 += d[k + 1] * d[k + 1]);
      const n = d.length / 4;
      return { w: c.width, h: c.height, variance: s2 / n - (s / n) ** 2, visible: c.offsetWidth > 100 };
    });
    assert.deepEqual([img.w, img.h, img.visible], [129, 129, true], v);
    assert.ok(img.variance > 10, `${v}: variance ${img.variance}`);
  }
  await page.click('#views button[data-view="3d"]');
  assert.equal(await page.isVisible('#view3d'), true);
  await page.close();
});

test('points render as instanced props and pins', async () => {
  // No stage in this build places props yet: feed the viewer a frame's point block directly.
  const { page } = await open('?size=129');
  const meshes = await page.evaluate(() => {
    const v = window.studio.view3d;
    const data = new Float32Array([
      100, 20, 100, 0, 1, 0, 0,   // prop tree
      120, 21, 100, 90, 1.5, 0, 0, // prop tree
      300, 5, 300, 0, 1, 0, 1,    // prop rock
      2000, 80, 2000, 0, 1, 1, 2, // volcano (a pin)
    ]);
    v.setPoints({ count: 4, stride: 7, kinds: ['prop', 'volcano'], types: ['pine tree', 'rock', 'crater'], data });
    return [...v.props.children, ...v.pins.children].map((m) => [m.name, m.count]);
  });
  assert.deepEqual(meshes, [['props:pine tree', 2], ['props:rock', 1], ['points', 1]]);
  await page.close();
});

test('switching presets works', async () => {
  const { page } = await open();
  const before = await pixels(page);
  const gens = await page.evaluate(() => window.studio.state.generations);
  await page.selectOption('#preset', 'mountains');
  await waitIdle(page, gens + 1);
  await page.waitForFunction(() => window.studio.state.result.header.recipe.name === 'mountains');
  const recipe = await page.evaluate(() => window.studio.state.recipe);
  const preset = await (await fetch(server.url + '/api/presets/mountains')).json();
  assert.deepEqual(recipe.stages.map((s) => s.label), preset.stages.map((s) => s.label));
  const titles = await page.locator('#panel-box .lil-title').allTextContents();
  assert.ok(titles.includes(`1 · ${preset.stages[0].label}`));
  assert.ok(meanAbsDiff(before, await pixels(page)) > 5);
  await page.close();
});

test('step playback shows every stage with its caption', async () => {
  const { page } = await open('?size=129');
  await page.evaluate(() => (window.studio.playback.delayMs = 400));
  await page.click('#play');
  await page.waitForSelector('#caption:not([hidden])');
  await page.waitForFunction(() => !window.studio.playback.running, null, { timeout: 60000 });
  const log = await page.evaluate(() => window.studio.playback.log);
  const recipe = await page.evaluate(() => window.studio.state.recipe);
  assert.equal(log.length, recipe.stages.length);
  log.forEach((entry, k) => {
    assert.equal(entry.index, k);
    assert.equal(entry.label, recipe.stages[k].label);
    assert.ok(entry.caption.startsWith(`Step ${k + 1} of ${recipe.stages.length} · ${recipe.stages[k].label}`), entry.caption);
  });
  assert.equal(await page.isHidden('#caption'), true, 'the caption goes away at the end');
  await page.close();
});

test('walk mode: the walker reaches a clicked point on land along a dry, climbable path', async () => {
  const { page } = await open('?size=257');
  await page.click('#walk');
  await page.waitForFunction(() => window.studio.walk.state === 'idle');
  await page.fill('#walk-speed', '2000');
  // A reachable land sample 25..60 samples from the walker that is on screen.
  const target = await page.evaluate(() => {
    const s = window.studio, w = s.walk;
    const [wi, wj] = w.pos.map(Math.round);
    for (let r = 25; r <= 60; r += 5)
      for (let a = 0; a < 16; a++) {
        const i = Math.round(wi + r * Math.cos((a * Math.PI) / 8)), j = Math.round(wj + r * Math.sin((a * Math.PI) / 8));
        if (i < 1 || j < 1 || i >= w.grid.nx - 1 || j >= w.grid.nz - 1) continue;
        if (w.grid.h[j * w.grid.nx + i] < w.grid.sea + 0.01) continue;
        const p = s.sampleToScreen(i, j);
        if (!p.visible || document.elementFromPoint(p.x, p.y) !== s.view3d.renderer.domElement) continue;
        const hit = s.view3d.pick(p.x, p.y);  // not hidden behind a hill
        if (!hit || Math.hypot(hit.fi - i, hit.fj - j) > 0.7 || !s.canReach(i, j)) continue;
        return { i, j, x: p.x, y: p.y };
      }
    return null;
  });
  assert.ok(target, 'found a reachable target on screen');
  await page.mouse.click(target.x, target.y);
  await page.waitForFunction(() => window.studio.walk.state === 'walking', null, { timeout: 10000 });
  await page.waitForFunction(() => window.studio.walk.state === 'arrived', null, { timeout: 60000 });
  const w = await page.evaluate(() => {
    const s = window.studio, walk = s.walk, g = walk.grid;
    const path = walk.walker.path;
    const dry = path.every(([i, j]) => g.h[Math.round(j) * g.nx + Math.round(i)] >= g.sea);
    const cam = s.view3d.camera.position, me = s.view3d.walker.position;
    return { pos: walk.pos, target: walk.target, dry, eye: cam.y - me.y, dist: Math.hypot(cam.x - me.x, cam.z - me.z), path: path.length };
  });
  assert.ok(Math.abs(w.target[0] - target.i) <= 1 && Math.abs(w.target[1] - target.j) <= 1, `clicked ${[target.i, target.j]}, target ${w.target}`);
  assert.ok(Math.hypot(w.pos[0] - w.target[0], w.pos[1] - w.target[1]) < 1e-6, `walker at ${w.pos}, target ${w.target}`);
  assert.ok(w.dry, 'every path point is on land');
  assert.ok(w.eye > 1 && w.eye < 6, `camera ${w.eye} m above the walker's feet`);
  assert.ok(w.dist < 8, `camera ${w.dist} m behind the walker`);
  // Clicking the sea is refused with a message. The overview camera eases into place (orbit
  // damping), so wait until two consecutive frames show the same view before aiming.
  await page.click('#walk-view');
  await page.waitForFunction(
    () => {
      const v = window.studio.view3d, m = v.camera.matrixWorld.elements.join();
      const settled = !v.dirty && m === window.__lastView;
      window.__lastView = m;
      return settled;
    },
    null,
    { polling: 'raf', timeout: 30000 },
  );
  const sea = await page.evaluate(() => {
    const s = window.studio, g = s.walk.grid, canvas = s.view3d.renderer.domElement;
    for (let j = 2; j < g.nz - 2; j += 5)
      for (let i = 2; i < g.nx - 2; i += 5) {
        if (g.h[j * g.nx + i] >= g.sea - 0.02) continue;
        const p = s.sampleToScreen(i, j);
        if (!p.visible || document.elementFromPoint(p.x, p.y) !== canvas) continue;
        const hit = s.view3d.pick(p.x, p.y);  // the click lands on this sea sample, not on land in front
        if (!hit || Math.hypot(hit.fi - i, hit.fj - j) > 1) continue;
        return { i, j, x: p.x, y: p.y };
      }
    return null;
  });
  assert.ok(sea, 'some sea is in sight');
  const before = await page.evaluate(() => window.studio.walk.pos.slice());
  await page.mouse.click(sea.x, sea.y);
  await page.waitForFunction(() => window.studio.walk.state === 'blocked', null, { timeout: 15000 });
  assert.match(await page.textContent('#walk-text'), /water/);
  assert.deepEqual(await page.evaluate(() => window.studio.walk.pos), before, 'the walker stays where it was');
  await page.keyboard.press('Escape');
  assert.equal(await page.evaluate(() => window.studio.walk.active), false);
  await page.close();
});

test('exports download through the menu (GLB validated when the writer exists)', async () => {
  const { page } = await open('?size=129');
  const table = await (await fetch(server.url + '/api/params')).json();
  const glb = table.formats.find((f) => f.files.some((x) => x.endsWith('.glb')));
  await page.click('#export');
  if (glb) {
    const [dl] = await Promise.all([page.waitForEvent('download'), page.click(`#export-menu button[data-format="${glb.name}"]`)]);
    let bytes = fs.readFileSync(await dl.path());
    if (bytes.subarray(0, 4).toString() !== 'glTF') {
      // A zip (the format wrote several files): take the .glb out of it (python's zipfile is the
      // independent reader).
      const { execFileSync } = await import('node:child_process');
      bytes = execFileSync('/usr/bin/python3', ['-c', 'import sys,zipfile; z=zipfile.ZipFile(sys.argv[1]); n=[x for x in z.namelist() if x.endswith(".glb")][0]; sys.stdout.buffer.write(z.read(n))', await dl.path()]);
    }
    const validator = await import('gltf-validator');
    const report = await validator.default.validateBytes(new Uint8Array(bytes));
    assert.equal(report.issues.numErrors, 0, JSON.stringify(report.issues.messages.slice(0, 5)));
  } else {
    // No GLB writer in this build yet: the heightmap's PNG through the same menu.
    const [dl] = await Promise.all([page.waitForEvent('download'), page.click('#export-menu a[data-file="height.png"]')]);
    assert.match(dl.suggestedFilename(), /height\.png$/);
    const bytes = fs.readFileSync(await dl.path());
    assert.equal(bytes.subarray(1, 4).toString(), 'PNG');
    assert.equal(bytes.readUInt32BE(16), 129);
    assert.equal(bytes[24], 16);
  }
  // The OBJ comes as a zip with its texture.
  await page.click('#export');
  const [zip] = await Promise.all([page.waitForEvent('download'), page.click('#export-menu button[data-format="obj"]')]);
  assert.match(zip.suggestedFilename(), /obj\.zip$/);
  const head = fs.readFileSync(await zip.path()).subarray(0, 4);
  assert.deepEqual([...head], [0x50, 0x4b, 0x03, 0x04]);
  await page.close();
});

test('saving and loading a recipe round-trips it', async () => {
  const { page } = await open('?size=129&seed=99');
  const [dl] = await Promise.all([page.waitForEvent('download'), page.click('#save')]);
  const saved = JSON.parse(fs.readFileSync(await dl.path(), 'utf8'));
  assert.equal(saved.seed, 99);
  assert.deepEqual(saved, await page.evaluate(() => {
    const r = structuredClone(window.studio.state.recipe);
    return r;
  }));
  saved.seed = 1234;
  saved.stages[0].octaves = 3;
  const gens = await page.evaluate(() => window.studio.state.generations);
  await page.setInputFiles('#load-file', { name: 'mine.json', mimeType: 'application/json', buffer: Buffer.from(JSON.stringify(saved)) });
  await waitIdle(page, gens + 1);
  const r = await page.evaluate(() => window.studio.state.recipe);
  assert.equal(r.seed, 1234);
  assert.equal(r.stages[0].octaves, 3);
  assert.equal(await page.inputValue('#seed'), '1234');
  await page.close();
});

test('uploading a broken recipe shows a clear message and the page keeps working', async () => {
  const { page, errors } = await open('?size=129');
  const before = await page.evaluate(() => window.studio.state.recipe);
  // Not JSON at all.
  await page.setInputFiles('#load-file', { name: 'garbage.json', mimeType: 'application/json', buffer: Buffer.from('{"stages": [') });
  await page.waitForSelector('#toast:not([hidden])');
  assert.match(await page.textContent('#toast-text'), /Could not load garbage\.json: not valid JSON/);
  // Valid JSON, invalid recipe: the server's message names the field.
  const broken = structuredClone(before);
  broken.stages[0].octaves = 40;
  await page.setInputFiles('#load-file', { name: 'broken.json', mimeType: 'application/json', buffer: Buffer.from(JSON.stringify(broken)) });
  await page.waitForFunction(() => document.getElementById('toast-text').textContent.includes('broken.json'));
  assert.equal(await page.textContent('#toast-text'), 'Could not load broken.json: stages[0].octaves: expected an integer in 1..16, got 40');
  assert.deepEqual(await page.evaluate(() => window.studio.state.recipe), before, 'the current recipe is kept');
  // Still working: a slider drag regenerates.
  const gens = await page.evaluate(() => window.studio.state.generations);
  await dragSlider(page, 'stages[0].octaves', 0.3, { steps: 2, pauseMs: 100 });
  await waitIdle(page, gens + 1);
  assert.notEqual(await page.evaluate(() => window.studio.state.recipe.stages[0].octaves), before.stages[0].octaves);
  // The only console errors are the browser's notes of the refused request (HTTP 400).
  assert.ok(errors.every((e) => /status of 400/.test(e)), errors.join('\n'));
  await page.close();
});

test('an image stage takes a file by its picker or dropped on the panel; Save makes a zip with the image', async () => {
  const { page, errors } = await open('?size=129');
  // A recipe with an image stage that has no file yet (its run is refused until it has one).
  const doc = { name: 'sketch', seed: 3, world: { size: 129 }, stages: [{ stage: 'image', path: '' }, { stage: 'color' }] };
  await page.setInputFiles('#load-file', { name: 'sketch.json', mimeType: 'application/json', buffer: Buffer.from(JSON.stringify(doc)) });
  await page.waitForFunction(() => window.studio.state.recipe.name === 'sketch' && window.studio.idle);
  // The file picker of stages[0].path: a 16-bit ramp along x.
  const ramp = await greyPng(129, 129, 16, (x) => x * 500);
  let gens = await page.evaluate(() => window.studio.state.generations);
  await page.setInputFiles('input[data-upload="stages[0].path"]', { name: 'ramp.png', mimeType: 'image/png', buffer: ramp });
  await waitIdle(page, gens + 1);
  assert.equal(await page.evaluate(() => window.studio.state.recipe.stages[0].path), 'upload:ramp.png');
  const row = await page.evaluate(() => Array.from(window.studio.state.result.layers.height.data.slice(0, 129)));
  row.forEach((h, x) => assert.ok(Math.abs(h * 65535 - x * 500) <= 0.5, `x ${x}: ${h}`));
  // A file dropped on the panel (on the stage's folder) replaces it.
  gens = await page.evaluate(() => window.studio.state.generations);
  const flat = await greyPng(129, 129, 8, () => 51);
  await page.evaluate((bytes) => {
    const dt = new DataTransfer();
    dt.items.add(new File([new Uint8Array(bytes)], 'flat.png', { type: 'image/png' }));
    const target = document.querySelector('#panel [data-stage="0"]');
    target.dispatchEvent(new DragEvent('dragover', { dataTransfer: dt, bubbles: true, cancelable: true }));
    target.dispatchEvent(new DragEvent('drop', { dataTransfer: dt, bubbles: true, cancelable: true }));
  }, [...flat]);
  await waitIdle(page, gens + 1);
  assert.equal(await page.evaluate(() => window.studio.state.recipe.stages[0].path), 'upload:flat.png');
  assert.equal(await page.evaluate(() => window.studio.state.result.layers.height.data[1000]), Math.fround(51 / 255));
  // Save: recipe.json and flat.png, the recipe's path the file beside it.
  const [dl] = await Promise.all([page.waitForEvent('download'), page.click('#save')]);
  assert.equal(dl.suggestedFilename(), 'sketch-3.zip');
  const { execFileSync } = await import('node:child_process');
  const listing = JSON.parse(execFileSync('/usr/bin/python3', ['-c', `
import json, sys, zipfile
z = zipfile.ZipFile(sys.argv[1])
print(json.dumps({'names': sorted(z.namelist()), 'path': json.loads(z.read('recipe.json'))['stages'][0]['path'], 'png': list(z.read('flat.png')[:4])}))
`, await dl.path()], { encoding: 'utf8' }));
  assert.deepEqual(listing, { names: ['flat.png', 'recipe.json'], path: 'flat.png', png: [0x89, 0x50, 0x4e, 0x47] });
  // The only console errors are the browser's notes of the run refused before a file was chosen.
  assert.ok(errors.every((e) => /status of 400/.test(e)), errors.join('\n'));
  await page.close();
});

// The share of sampled pixels within `tol` of an sRGB colour.
function colourShare(p, rgb, tol = 4) {
  let hits = 0;
  for (let k = 0; k < p.pixels.length; k += 3)
    if (Math.abs(p.pixels[k] - rgb[0]) <= tol && Math.abs(p.pixels[k + 1] - rgb[1]) <= tol && Math.abs(p.pixels[k + 2] - rgb[2]) <= tol) hits++;
  return hits / (p.pixels.length / 3);
}

// The chunk nodes and triangles of the caves.glb the server gives for `recipe`.
async function serverVolume(recipe) {
  const res = await fetch(server.url + '/api/volume', { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify({ recipe }) });
  assert.equal(res.status, 200);
  const glb = Buffer.from(await res.arrayBuffer());
  const json = JSON.parse(glb.subarray(20, 20 + glb.readUInt32LE(12)).toString('utf8'));
  const chunkNodes = json.nodes.filter((n) => /^caves_x/.test(n.name || ''));
  const triangles = chunkNodes.reduce((s, n) => s + json.meshes[n.mesh].primitives.reduce((q, p) => q + json.accessors[p.indices].count / 3, 0), 0);
  return { triangles, chunks: chunkNodes.length };
}

test('a recipe with a volume shows its caves mesh, and the cut plane opens it', async (t) => {
  const { page, errors } = await open('?preset=sea-cliff&size=129&seed=7');
  await page.waitForFunction(() => ['shown', 'empty', 'error'].includes(window.studio.volume.status), null, { timeout: 120000, polling: 100 });
  const v = await page.evaluate(() => {
    const s = window.studio, x = s.volume;
    return { status: x.status, error: x.error, triangles: x.triangles, chunks: x.chunks, shown: s.view3d.volume.visible, terrain: s.view3d.terrain.visible, recipe: s.state.result.header.recipe };
  });
  assert.equal(v.status, 'shown', v.error || v.status);
  assert.ok(v.shown && !v.terrain, 'the volume is shown instead of the height mesh');
  // The page shows every triangle and chunk of the server's caves.glb for the terrain it shows.
  const expected = await serverVolume(v.recipe);
  assert.ok(expected.triangles > 0);
  assert.deepEqual([v.triangles, v.chunks], [expected.triangles, expected.chunks]);

  // The cut plane, through the View menu's Volume folder: off at first, then on (across z, at the
  // middle): the renderer clips with one plane facing -z through the centre, and the cut rock
  // (drawn flat in the cut colour) comes into view.
  const cutRgb = [0x5b, 0x46, 0x36];
  const before = await pixels(page);
  assert.deepEqual(await page.evaluate(() => window.studio.volume.clipping().planes), []);
  await page.click('#view-gui > .lil-title');
  await page.click('[data-volume="cut plane"] input');
  const clip = await page.evaluate(() => window.studio.volume.clipping());
  assert.equal(clip.local, true, 'renderer.localClippingEnabled');
  assert.equal(clip.planes.length, 1);
  assert.deepEqual(clip.planes[0].normal, [0, 0, -1]);
  assert.ok(Math.abs(clip.planes[0].constant) < 1e-6, `constant ${clip.planes[0].constant}`);
  const cut = await pixels(page);
  assert.ok(meanAbsDiff(before, cut) > 2, `the picture changed by ${meanAbsDiff(before, cut)}`);
  const shareBefore = colourShare(before, cutRgb), shareCut = colourShare(cut, cutRgb);
  assert.ok(shareBefore < 0.002 && shareCut > 0.01, `cut-colour pixels: ${shareBefore} before, ${shareCut} after`);
  // Along x at a quarter: the plane moves with the controls.
  await page.selectOption('[data-volume="cut axis"] select', 'x');
  const slider = page.locator('[data-volume="cut at"] .lil-slider');
  const box = await slider.boundingBox();
  await page.mouse.click(box.x + box.width * 0.25, box.y + box.height / 2);
  const moved = await page.evaluate(() => ({ cut: window.studio.volume.cut, clip: window.studio.volume.clipping(), width: window.studio.state.result.header.frame.width_m }));
  assert.equal(moved.cut.axis, 'x');
  assert.deepEqual(moved.clip.planes[0].normal, [-1, 0, 0]);
  assert.ok(Math.abs(moved.clip.planes[0].constant - (moved.cut.at - 0.5) * moved.width) < 1e-6);
  assert.ok(Math.abs(moved.cut.at - 0.25) < 0.05, `cut at ${moved.cut.at}`);
  const shot = path.join(process.env.RELIEF_SHOTS_DIR || os.tmpdir(), 'studio-volume-cut.png');
  await page.screenshot({ path: shot });
  t.diagnostic(`screenshot: ${shot}`);
  // Off again: no plane.
  await page.click('[data-volume="cut plane"] input');
  assert.deepEqual(await page.evaluate(() => window.studio.volume.clipping().planes), []);
  // Another seed: a new terrain, and then its own volume.
  const loads = await page.evaluate(() => window.studio.volume.loads);
  await page.fill('#seed', '8');
  await page.press('#seed', 'Tab');
  await page.waitForFunction((n) => window.studio.volume.loads > n && window.studio.volume.status === 'shown', loads, { timeout: 120000, polling: 100 });
  const v8 = await page.evaluate(() => ({ triangles: window.studio.volume.triangles, chunks: window.studio.volume.chunks, recipe: window.studio.state.result.header.recipe }));
  assert.equal(v8.recipe.seed, 8);
  assert.deepEqual([v8.triangles, v8.chunks], Object.values(await serverVolume(v8.recipe)));
  assert.notEqual(v8.triangles, v.triangles);
  // A recipe without a volume: the height mesh again, and the Volume folder goes away.
  const gens = await page.evaluate(() => window.studio.state.generations);
  await page.selectOption('#preset', 'island');
  await waitIdle(page, gens + 1);
  await page.waitForFunction(() => window.studio.volume.status === 'none');
  assert.deepEqual(await page.evaluate(() => [window.studio.view3d.volume.visible, window.studio.view3d.terrain.visible]), [false, true]);
  assert.equal(await page.isVisible('#volume-gui'), false);
  assert.deepEqual(errors, []);
  await page.close();
});
