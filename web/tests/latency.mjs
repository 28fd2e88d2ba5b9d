// Benchmark (not a test): end-to-end update latency of Relief Studio, as medians of several runs.
//   node web/tests/latency.mjs [--size 513] [--runs 9] [--threads 0]
// Measures, for the island preset at the given preview size:
//   * server: POST /api/generate from node after a regenerate-class change (a new seed: every
//     stage runs) and after a recolour-class change (only the colour stages run);
//   * page: in headless Chromium, the time from a slider change (octaves; rock_slope_deg) to the
//     frame that shows the result (fetch + decode + mesh/texture update + render). Chromium here
//     renders with SwiftShader (software WebGL), so the page figures include software rendering
//     of the full mesh; a GPU browser renders the frame in a few milliseconds.
import { startStudio, launchBrowser, waitIdle } from './harness.mjs';
import { decodeFrame } from '../src/api.js';

const arg = (name, def) => {
  const i = process.argv.indexOf(`--${name}`);
  return i > 0 ? process.argv[i + 1] : def;
};
const size = Number(arg('size', 513)), runs = Number(arg('runs', 9)), threads = arg('threads', '0');
const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2;
};
const fmt = (xs) => `median ${median(xs).toFixed(1)} ms (min ${Math.min(...xs).toFixed(1)}, max ${Math.max(...xs).toFixed(1)}, n=${xs.length})`;

const server = await startStudio(['--threads', threads]);
try {
  const doc = await (await fetch(`${server.url}/api/presets/island`)).json();
  doc.world.size = size;
  const post = async (recipe) => {
    const t0 = performance.now();
    const res = await fetch(`${server.url}/api/generate`, {
      method: 'POST',
      headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify({ recipe, layers: ['height', 'albedo', 'color'] }),
    });
    const f = decodeFrame(await res.arrayBuffer());
    return { ms: performance.now() - t0, header: f.header };
  };
  const colour = doc.stages.findIndex((s) => s.stage === 'color');
  const full = [], recolour = [], serverFull = [], stages = {};
  for (let r = 0; r < runs + 1; r++) {
    const recipe = { ...structuredClone(doc), seed: 1000 + r };
    const a = await post(recipe);
    recipe.stages[colour].rock_slope_deg = 20 + r;
    const b = await post(recipe);
    if (r === 0) continue;  // warm-up
    full.push(a.ms);
    serverFull.push(a.header.server_ms);
    recolour.push(b.ms);
    for (const t of a.header.timings) (stages[t.label] ||= []).push(t.ms);
  }
  console.log(`island ${size}x${size}, server threads ${threads === '0' ? 'all' : threads}`);
  console.log(`  API, every stage runs (new seed):      ${fmt(full)}; server side ${fmt(serverFull)}`);
  for (const [label, xs] of Object.entries(stages)) console.log(`      ${label.padEnd(30)} ${fmt(xs)}`);
  console.log(`  API, colour stages only (rock slope):  ${fmt(recolour)}`);

  const browser = await launchBrowser({ width: 1280, height: 800 });
  try {
    const { page } = browser;
    await page.goto(`${server.url}/?size=${size}`);
    await waitIdle(page);
    // One update per change, at the preview size (no half-resolution drag preview).
    await page.evaluate(() => (window.studio.viewSettings.dragPreview = 'full'));
    const measure = async (param, values) => {
      const out = [];
      for (const v of values) {
        const gens = await page.evaluate(() => window.studio.state.generations);
        const input = page.locator(`[data-param="${param}"] input`);
        await input.scrollIntoViewIfNeeded();
        await input.fill(String(v));
        await input.press('Enter');
        await waitIdle(page, gens + 1);
        out.push(await page.evaluate(() => window.studio.state.latencies.at(-1)));
      }
      return out;
    };
    // Distinct values, so that every change misses the stage cache (the preset has 8 octaves).
    const oct = await measure('stages[0].octaves', [1, 2, 3, 4, 5, 6, 7, 9, 10, 11, 12].slice(0, runs));
    const per = await measure('stages[0].persistence', Array.from({ length: runs }, (_, k) => 0.4 + 0.01 * k));
    await page.click(`#panel-box .lil-title:text-is("${colour + 1} · ${doc.stages[colour].label}")`);
    const rock = await measure(`stages[${colour}].rock_slope_deg`, Array.from({ length: runs }, (_, k) => 40 + k));
    const m = (xs, k) => median(xs.map((x) => x[k])).toFixed(1);
    const show = (name, xs) =>
      console.log(`  page, ${name}: one update, change → picture ${fmt(xs.map((x) => x.request + x.apply + x.render))}\n` +
        `      without the frame's rendering ${fmt(xs.map((x) => x.request + x.apply))}\n` +
        `      medians: server ${m(xs, 'server')} ms, request ${m(xs, 'request')} ms, apply (JS) ${m(xs, 'apply')} ms, render ${m(xs, 'render')} ms`);
    show('octaves (noise on)      ', oct);
    show('persistence (noise on)  ', per);
    show('rock_slope_deg (colour) ', rock);
  } finally {
    await browser.close();
  }
} finally {
  await server.stop();
}
