// Relief Studio: the page. Everything it shows comes from the server's generic registries: the
// panel from the parameter table, the view tabs from the layers the terrain has, the export menu
// from the writer registry, the playback from the recipe's stages.
import './style.css';
import GUI from 'lil-gui';
import * as api from './api.js';
import { Panel } from './panel.js';
import { View3D } from './view3d.js';
import { View2D } from './view2d.js';
import { makeGrid, findPath, simplifyPath, nearestStandable, sampleAt, Walker } from './walk.js';

const $ = (id) => document.getElementById(id);
const DRAG_BUDGET_MS = 70;  // server time above which drags preview at half resolution (auto)

const state = {
  table: null,
  presets: [],
  recipe: null,       // the resolved recipe the panel edits (its own world.size kept)
  previewSize: 513,
  view: '3d',         // '3d' or a layer name
  result: null,       // the last decoded generate frame
  latencies: [],      // end-to-end update times (ms): change → new picture on screen
  generations: 0,     // results applied
  runs: [],           // per applied result: which stages came from the server's cache
  error: null,
  ready: false,
};

const view3d = new View3D($('box3d'));
const view2d = new View2D($('box2d'));
const afterRender = [];

// Display settings of the 3D view (not part of the recipe).
const viewSettings = { relief: view3d.vscale, texture: 'lit colours', sea: true, props: true, dragPreview: 'auto' };
state.shading = 'lit';
const viewGui = new GUI({ container: $('box3d'), title: 'View', width: 230 });
viewGui.domElement.id = 'view-gui';
viewGui.add(viewSettings, 'relief', 0.5, 6, 0.1).name('relief ×').onChange((v) => {
  if (view3d.mode === 'follow') view3d.userScale = v;  // the walk view stays at true scale
  else view3d.setVerticalScale(v);
  if (walk.active && walk.pos) walk.place();
});
viewGui.add(viewSettings, 'texture', ['lit colours', 'hillshaded']).onChange((v) => {
  state.shading = v === 'hillshaded' ? 'baked' : 'lit';
  if (state.result) renderTerrain(state.result.header.frame, state.result.layers);
});
viewGui.add(viewSettings, 'sea').onChange((v) => ((view3d.sea.visible = v), (view3d.dirty = true)));
viewGui.add(viewSettings, 'props').name('props & points').onChange((v) => {
  view3d.props.visible = view3d.pins.visible = v;
  view3d.dirty = true;
});
viewGui.add(viewSettings, 'dragPreview', ['auto', 'full', 'half']).name('while dragging')
  .domElement.title = 'auto: half resolution while dragging when a full update takes longer than ' + DRAG_BUDGET_MS + ' ms on the server';
viewGui.close();

// ---------------------------------------------------------------------------------- messages
let toastTimer = null;
function toast(message, kind = 'error', ms = 9000) {
  $('toast-text').textContent = message;
  $('toast').className = kind;
  $('toast').hidden = false;
  clearTimeout(toastTimer);
  if (ms) toastTimer = setTimeout(() => ($('toast').hidden = true), ms);
  if (kind === 'error') state.error = message;
}
$('toast-close').onclick = () => ($('toast').hidden = true);

function help({ title, body }) {
  $('help').innerHTML = '';
  const b = document.createElement('b');
  b.textContent = title;
  const s = document.createElement('span');
  s.textContent = body;
  $('help').append(b, s);
}

// ---------------------------------------------------------------------------------- recipe
// The recipe sent to the server: the panel's recipe at the preview size (aspect kept).
function previewSizeOf(recipe, n) {
  const [nx, nz] = recipe.world.size;
  if (nx >= nz) return [n, Math.max(2, Math.round(((n - 1) * (nz - 1)) / (nx - 1)) + 1)];
  return [Math.max(2, Math.round(((n - 1) * (nx - 1)) / (nz - 1)) + 1), n];
}

// While a slider is dragged, the preview may run at half resolution (every other sample of the
// full preview: pointwise stages agree exactly there) when full updates are slower than the
// budget; letting go of the slider brings the full resolution back.
function dragSize() {
  const n = state.previewSize;
  const mode = viewSettings.dragPreview;
  if (mode === 'full' || n <= 129) return n;
  if (mode === 'half' || (state.fullServerMs !== null && state.fullServerMs > DRAG_BUDGET_MS)) return (n - 1) / 2 + 1;
  return n;
}

function requestRecipe({ fullSize = false, dragging = false } = {}) {
  const r = structuredClone(state.recipe);
  if (!fullSize) r.world.size = previewSizeOf(state.recipe, dragging ? dragSize() : state.previewSize);
  return r;
}

function randomSeed() {
  const a = new Uint32Array(1);
  crypto.getRandomValues(a);
  return a[0] % 1000000000;
}

// Resolves a recipe document on the server (validation + defaults) and makes it the current one.
// Throws api.ApiError with the server's message; the current recipe is untouched on failure.
async function adopt(doc, { keepSeed = false } = {}) {
  if (!doc || typeof doc !== 'object' || Array.isArray(doc)) throw new api.ApiError(400, 'a recipe must be a JSON object');
  const d = structuredClone(doc);
  if (keepSeed && state.recipe) d.seed = state.recipe.seed;
  if (d.seed === undefined) d.seed = randomSeed();
  const resolved = await api.resolve(d);
  state.recipe = resolved;
  $('seed').value = String(resolved.seed);
  panel.build(resolved, state.table);
  generator.request('now');
}

const panel = new Panel($('panel-box'), {
  onChange: ({ finished }) => generator.request(finished ? 'now-coalesced' : 'drag'),
  onHelp: help,
  onStructure: (recipe) => {
    // A stage was added or removed: resolve (fills defaults, checks) and rebuild the panel.
    adopt(recipe).catch((e) => toast(`Could not change the stages: ${e.message}`));
  },
});

// ---------------------------------------------------------------------------------- generation
// At most one request in flight. While dragging, changes made during a request are coalesced
// into one follow-up request with the latest values; a discrete change (preset, seed, size)
// aborts the running request, and the server cancels it between stages (409).
class Generator {
  constructor() {
    this.controller = null;
    this.pending = false;
    this.pendingSince = null;
  }
  request(kind) {
    this.dragging = kind === 'drag';
    // Nothing to do when the recipe is the one already shown or on its way (lil-gui reports the
    // end of a drag as a change too).
    if (!this.controller && !this.pending && this.lastSent === this.key(this.recipe()) && state.result) return;
    const now = performance.now();
    if (this.pendingSince === null) this.pendingSince = now;
    if (this.controller && kind !== 'now') {
      this.pending = true;
      return;
    }
    if (this.controller) this.controller.abort();
    this.start();
  }
  recipe() {
    return requestRecipe({ dragging: this.dragging });
  }
  key(recipe) {
    return JSON.stringify([recipe, this.wantedLayers()]);
  }
  wantedLayers() {
    const want = new Set(['height', 'albedo', 'color']);
    if (state.view !== '3d') want.add(state.view);
    return [...want];
  }
  async start() {
    const ctrl = new AbortController();
    this.controller = ctrl;
    this.pending = false;
    const since = this.pendingSince;
    this.pendingSince = null;
    $('busy').hidden = false;
    const t0 = performance.now();
    const recipe = this.recipe();
    this.lastSent = this.key(recipe);
    const full = recipe.world.size[0] === previewSizeOf(state.recipe, state.previewSize)[0];
    try {
      const result = await api.generate(recipe, { layers: this.wantedLayers(), signal: ctrl.signal });
      if (ctrl.signal.aborted) return;
      const t1 = performance.now();
      if (full) state.fullServerMs = result.header.server_ms;
      applyResult(result);
      const tApplied = performance.now();
      afterRender.push(() => {
        const t2 = performance.now();
        state.latencies.push({
          total: t2 - since,                    // the change → its picture on screen
          request: t1 - t0,                     // fetch + transfer + decode
          apply: tApplied - t1,                 // mesh, normals, texture, tabs (JavaScript)
          render: t2 - tApplied,                // until the frame is drawn (GPU / SwiftShader)
          server: result.header.server_ms,
          size: result.header.frame.nx,
        });
        if (state.latencies.length > 200) state.latencies.shift();
        showTimings(result.header, t2 - since);
      });
      if (state.error) state.error = null;
    } catch (e) {
      this.lastSent = null;
      if (e.name === 'AbortError' || (e instanceof api.ApiError && e.status === 409)) return;
      toast(e instanceof api.ApiError ? e.message : `Generation failed: ${e.message}`);
    } finally {
      if (this.controller === ctrl) {
        this.controller = null;
        $('busy').hidden = true;
        if (this.pending) {
          if (this.lastSent !== this.key(this.recipe())) this.start();
          else (this.pending = false), (this.pendingSince = null);
        }
      }
    }
  }
  get idle() {
    return !this.controller && !this.pending;
  }
}
const generator = new Generator();

function applyResult(result) {
  state.result = result;
  state.generations++;
  state.runs.push({ first_stage: result.header.first_stage, cached: result.header.timings.map((t) => t.cached) });
  if (state.runs.length > 50) state.runs.shift();
  const { header, layers } = result;
  renderTerrain(header.frame, layers);
  view3d.setPoints(result.points);
  updateTabs(header.available);
  if (state.view !== '3d') show2d(state.view);
  if (walk.active) walk.onTerrain();
  const f = header.frame;
  let water = 0;
  const h = layers.height ? layers.height.data : null;
  if (h) for (let k = 0; k < h.length; k++) water += h[k] < f.sea_level;
  $('status-text').textContent = `${header.recipe.name} · ${f.nx}×${f.nz} samples · ${(f.width_m / 1000).toFixed(1)}×${(f.depth_m / 1000).toFixed(1)} km · ` +
    `cell ${f.cell_m.toFixed(1)} m · seed ${header.seed}` + (h ? ` · water ${((100 * water) / h.length).toFixed(0)}%` : '') +
    (result.points && result.points.count ? ` · ${result.points.count} points` : '');
}

// The 3D texture: flat colours lit by the scene's sun when the terrain has them, else the
// hillshaded colour as it is, else an elevation tint.
function renderTerrain(frame, layers) {
  const h = layers.height;
  if (!h) return;
  const pick = state.shading === 'baked' ? ['color', 'albedo'] : ['albedo', 'color'];
  const name = pick.find((n) => layers[n] && layers[n].type === 'rgb8');
  const lit = !name || name === 'albedo';
  view3d.setTerrain(frame, h.data, name ? layers[name].data : null, lit);
}

function showTimings(header, totalMs) {
  const el = $('timings');
  el.innerHTML = '';
  const head = document.createElement('span');
  head.textContent = `update ${totalMs.toFixed(0)} ms (server ${header.server_ms.toFixed(0)} ms): `;
  el.appendChild(head);
  header.timings.forEach((t, i) => {
    const s = document.createElement('span');
    s.className = t.cached ? 'cached' : '';
    s.textContent = `${i ? ' · ' : ''}${t.label} ${t.cached ? 'cached' : t.ms.toFixed(0) + ' ms'}`;
    el.appendChild(s);
  });
}

// ---------------------------------------------------------------------------------- views
const LAYER_ORDER = ['color', 'albedo', 'height'];
function tabLabel(name) {
  return { color: 'Colour', albedo: 'Albedo', height: 'Height' }[name] || name.replace(/_/g, ' ').replace(/^./, (c) => c.toUpperCase());
}
function updateTabs(available) {
  const names = Object.keys(available || {});
  names.sort((a, b) => {
    const ra = LAYER_ORDER.indexOf(a), rb = LAYER_ORDER.indexOf(b);
    const ka = ra >= 0 ? ra : /biome|tile/.test(a) ? 10 : 20, kb = rb >= 0 ? rb : /biome|tile/.test(b) ? 10 : 20;
    return ka - kb || a.localeCompare(b);
  });
  const want = ['3d', ...names];
  const nav = $('views');
  const have = [...nav.children].map((b) => b.dataset.view);
  if (want.join() !== have.join()) {
    nav.innerHTML = '';
    for (const v of want) {
      const b = document.createElement('button');
      b.dataset.view = v;
      b.textContent = v === '3d' ? '3D' : tabLabel(v);
      b.title = v === '3d' ? '3D view: drag to orbit, right-drag to pan, wheel to zoom' : `2D view of the layer "${v}"`;
      b.onclick = () => setView(v);
      nav.appendChild(b);
    }
  }
  for (const b of nav.children) b.classList.toggle('active', b.dataset.view === state.view);
}

function setView(v) {
  state.view = v;
  $('box3d').hidden = v !== '3d';
  $('box2d').hidden = v === '3d';
  $('walk-bar').hidden = !(walk.active && v === '3d');
  for (const b of $('views').children) b.classList.toggle('active', b.dataset.view === v);
  if (v === '3d') {
    view3d.resize();
    view3d.dirty = true;
  } else if (!show2d(v)) {
    generator.request('now');  // the layer was not in the last frame: fetch it
  }
}

function show2d(name) {
  const r = state.result;
  if (!r || !r.layers[name]) return false;
  view2d.show(name, r.layers[name], r.header.frame);
  return true;
}

// ---------------------------------------------------------------------------------- playback
const playback = { running: false, log: [], delayMs: 1500, stop: false };

async function playStages() {
  if (playback.running) {
    playback.stop = true;
    return;
  }
  if (!state.recipe) return;
  playback.running = true;
  playback.stop = false;
  playback.log = [];
  $('play').classList.add('active');
  $('play').textContent = '■ Stop';
  try {
    const res = await api.steps(requestRecipe());
    const steps = res.steps;
    const bar = $('steps-bar');
    bar.innerHTML = '';
    steps.forEach((s, k) => {
      const b = document.createElement('button');
      b.textContent = String(k + 1);
      b.title = s.label;
      b.onclick = () => showStep(res, k);
      bar.appendChild(b);
    });
    bar.hidden = false;
    if (state.view !== '3d') setView('3d');
    for (let k = 0; k < steps.length && !playback.stop; k++) {
      showStep(res, k);
      await new Promise((r) => setTimeout(r, playback.delayMs));
    }
  } catch (e) {
    toast(`Stage playback failed: ${e.message}`);
  } finally {
    playback.running = false;
    $('play').classList.remove('active');
    $('play').innerHTML = '&#x25B6; Stages';
    $('caption').hidden = true;
    $('steps-bar').hidden = true;
    if (state.result) renderTerrain(state.result.header.frame, state.result.layers);
  }
}

function showStep(res, k) {
  const s = res.steps[k];
  const n = res.steps.length;
  const frame = res.header.frame;
  if (s.layers.height) {
    const rgbName = s.layers.color ? 'color' : s.layers.albedo ? 'albedo' : null;
    view3d.setTerrain(frame, s.layers.height.data, rgbName ? s.layers[rgbName].data : null, rgbName !== 'color');
  }
  const cap = $('caption');
  cap.innerHTML = '';
  cap.append(`Step ${k + 1} of ${n} · ${s.label}`);
  const small = document.createElement('small');
  small.textContent = `${s.stage}: ${s.summary} · ${s.cached ? 'cached' : s.ms.toFixed(0) + ' ms'}`;
  cap.appendChild(small);
  cap.hidden = false;
  [...$('steps-bar').children].forEach((b, q) => b.classList.toggle('active', q === k));
  playback.log.push({ index: k, label: s.label, stage: s.stage, caption: cap.textContent });
}

// ---------------------------------------------------------------------------------- walk mode
const walk = {
  active: false,
  state: 'off',     // off | idle | walking | arrived | blocked
  grid: null,
  walker: null,
  pos: null,        // sample coordinates [fi, fj]
  heading: 0,
  target: null,
  follow: true,
  message: '',
  onTerrain(frame, heights) {
    const r = state.result;
    if (!frame) {
      if (!r || !r.layers.height) return;
      (frame = r.header.frame), (heights = r.layers.height.data);
    }
    const old = this.grid;
    this.grid = makeGrid(heights, frame);
    // Another resolution (drag previews): keep the walker where it is in metres.
    if (old && old.cell !== this.grid.cell) {
      const k = old.cell / this.grid.cell;
      const scale = (p) => [p[0] * k, p[1] * k];
      if (this.pos) this.pos = scale(this.pos);
      if (this.target) this.target = scale(this.target).map(Math.round);
      if (this.walker) {
        this.walker.path = this.walker.path.map(scale);
        this.walker.pos = scale(this.walker.pos);
      }
    }
    if (this.pos) this.place();
  },
};

function maxSlope() {
  return Math.max(5, Math.min(80, Number($('walk-slope').value) || 30));
}

function walkText(t) {
  walk.message = t;
  $('walk-text').textContent = t;
}

function groundDisplay(fi, fj) {
  return view3d.toDisplay(fi, fj, sampleAt(walk.grid, fi, fj));
}

walk.place = function () {
  const p = groundDisplay(walk.pos[0], walk.pos[1]);
  view3d.placeWalker(p, walk.heading);
  if (view3d.mode === 'follow') {
    const f = state.result.header.frame;
    view3d.followWalker(p, walk.heading, (x, z) => groundDisplay((x + f.width_m / 2) / f.cell_m, (z + f.depth_m / 2) / f.cell_m).y);
  }
};

function enterWalk() {
  if (!state.result) return;
  walk.onTerrain();
  const g = walk.grid;
  const start = nearestStandable(g, Math.floor(g.nx / 2), Math.floor(g.nz / 2), maxSlope());
  if (!start) {
    toast('Walk mode needs land: this terrain has no place gentle enough to stand on.', 'info');
    return;
  }
  walk.active = true;
  walk.state = 'idle';
  walk.pos = start.slice();
  walk.target = null;
  walk.walker = null;
  walk.follow = true;
  $('walk').classList.add('active');
  $('walk-bar').hidden = false;
  $('box3d').classList.add('walking');
  $('walk-view').textContent = 'Eye height';
  if (state.view !== '3d') setView('3d');
  view3d.setMode('orbit');
  walk.place();
  walkText('Click on land to walk there.');
}

function exitWalk() {
  walk.active = false;
  walk.path = null;
  walk.state = 'off';
  view3d.walker.visible = false;
  view3d.pathLine.visible = false;
  $('walk').classList.remove('active');
  $('walk-bar').hidden = true;
  $('box3d').classList.remove('walking');
  view3d.setMode('orbit');
  view3d.frameCamera();
}

function walkTo(fi, fj) {
  const g = walk.grid;
  const goal = [Math.round(fi), Math.round(fj)];
  const start = [Math.round(walk.pos[0]), Math.round(walk.pos[1])];
  const slope = maxSlope();
  const t0 = performance.now();
  const { path, reason } = findPath(g, start, goal, { maxSlopeDeg: slope });
  if (!path) {
    walk.state = 'blocked';
    walkText(`Can't go there: ${reason}.`);
    return false;
  }
  const simple = simplifyPath(g, path, slope);
  simple[0] = walk.pos.slice();
  walk.walker = new Walker(simple);
  walk.target = goal;
  walk.state = 'walking';
  walk.path = simple;
  if (walk.follow) view3d.setMode('follow');
  showWalkPath();
  const metres = path.length > 1 ? pathLength(simple) * g.cell : 0;
  walkText(`Walking ${metres.toFixed(0)} m (path found in ${(performance.now() - t0).toFixed(0)} ms)…`);
  return true;
}

// The path line, 0.6 m above the ground at the current vertical scale.
function showWalkPath() {
  if (walk.path) view3d.showPath(walk.path.map(([a, b]) => groundDisplay(a, b).add({ x: 0, y: 0.6, z: 0 })));
}

function pathLength(p) {
  let s = 0;
  for (let k = 1; k < p.length; k++) s += Math.hypot(p[k][0] - p[k - 1][0], p[k][1] - p[k - 1][1]);
  return s;
}

function walkTick(dt) {
  if (!walk.active || walk.state !== 'walking' || !walk.walker) return;
  const speedMs = 1.4 * Math.max(1, Number($('walk-speed').value) || 1);  // 1.4 m/s × time-lapse
  walk.pos = walk.walker.advance((speedMs * dt) / walk.grid.cell);
  walk.heading = walk.walker.heading;
  walk.place();
  if (walk.walker.done) {
    walk.state = 'arrived';
    walkText('Arrived. Click on land to walk on.');
  }
}

$('walk').onclick = () => (walk.active ? exitWalk() : enterWalk());
$('walk-exit').onclick = exitWalk;
$('walk-view').onclick = () => {
  walk.follow = !walk.follow;
  $('walk-view').textContent = walk.follow ? 'Overview' : 'Eye height';
  view3d.setMode(walk.follow ? 'follow' : 'orbit');
  if (!walk.follow) view3d.frameCamera();
  walk.place();
  showWalkPath();
};

// Clicks (not drags) on the 3D view pick walk targets.
let downAt = null;
view3d.renderer.domElement.addEventListener('pointerdown', (e) => (downAt = [e.clientX, e.clientY]));
view3d.renderer.domElement.addEventListener('pointerup', (e) => {
  if (!downAt || Math.hypot(e.clientX - downAt[0], e.clientY - downAt[1]) > 5) return;
  downAt = null;
  if (!walk.active) return;
  const hit = view3d.pick(e.clientX, e.clientY);
  if (!hit) return;
  const i = Math.round(hit.fi), j = Math.round(hit.fj);
  if (sampleAt(walk.grid, hit.fi, hit.fj) < walk.grid.sea) {
    walk.state = 'blocked';
    walkText("That's water: click on land.");
    return;
  }
  walkTo(i, j);
});

// ---------------------------------------------------------------------------------- save/load/export
function download(blob, filename) {
  const url = URL.createObjectURL(blob);
  const a = document.createElement('a');
  a.href = url;
  a.download = filename;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
}

$('save').onclick = () => {
  if (!state.recipe) return;
  const r = requestRecipe({ fullSize: true });
  download(new Blob([JSON.stringify(r, null, 2) + '\n'], { type: 'application/json' }), `${r.name || 'recipe'}-${r.seed}.json`);
};
$('load').onclick = () => $('load-file').click();
$('load-file').onchange = async () => {
  const file = $('load-file').files[0];
  $('load-file').value = '';
  if (file) await loadRecipeText(await file.text(), file.name);
};

async function loadRecipeText(text, name) {
  let doc;
  try {
    doc = JSON.parse(text);
  } catch (e) {
    toast(`Could not load ${name}: not valid JSON (${e.message})`);
    return false;
  }
  try {
    await adopt(doc);
    selectPresetOption(null);
    toast(`Loaded ${name}`, 'info', 2500);
    return true;
  } catch (e) {
    toast(`Could not load ${name}: ${e.message}`);
    return false;
  }
}

function buildExportMenu() {
  const menu = $('export-menu');
  menu.innerHTML = '';
  const head = document.createElement('div');
  head.className = 'head';
  head.innerHTML = '<span>Export through the same writers as <code>relief generate</code></span>';
  const sizeSel = document.createElement('select');
  sizeSel.id = 'export-size';
  sizeSel.innerHTML = '<option value="preview">at preview size</option><option value="recipe">at recipe size</option>';
  head.appendChild(sizeSel);
  menu.appendChild(head);
  for (const f of state.table.formats) {
    const row = document.createElement('div');
    row.className = 'row';
    const b = document.createElement('button');
    b.className = 'format';
    b.dataset.format = f.name;
    b.textContent = f.files.length > 1 ? `${f.name} (.zip)` : `${f.name} (${f.files[0] || ''})`;
    b.onclick = () => doExport(f.name);
    const desc = document.createElement('div');
    desc.className = 'desc';
    desc.textContent = f.description;
    row.append(b, desc);
    if (f.files.length > 1) {
      const files = document.createElement('div');
      files.className = 'files';
      for (const file of f.files) {
        const a = document.createElement('a');
        a.textContent = file;
        a.dataset.file = file;
        a.onclick = () => doExport(f.name, file);
        files.appendChild(a);
      }
      row.appendChild(files);
    }
    menu.appendChild(row);
  }
}

async function doExport(format, file) {
  $('export-menu').hidden = true;
  const full = $('export-size') && $('export-size').value === 'recipe';
  toast(`Exporting ${file || format}…`, 'info', 0);
  try {
    const { blob, filename } = await api.exportFormat(requestRecipe({ fullSize: full }), format, file);
    download(blob, filename);
    toast(`Exported ${filename} (${(blob.size / 1024).toFixed(0)} KiB)`, 'info', 3000);
  } catch (e) {
    toast(`Export failed: ${e.message}`);
  }
}
$('export').onclick = (e) => {
  e.stopPropagation();
  $('export-menu').hidden = !$('export-menu').hidden;
};
document.addEventListener('click', (e) => {
  if (!$('export-menu').hidden && !$('export-menu').contains(e.target)) $('export-menu').hidden = true;
});

// ---------------------------------------------------------------------------------- toolbar
function selectPresetOption(name) {
  const sel = $('preset');
  let custom = [...sel.options].find((o) => o.value === '');
  if (name === null) {
    if (!custom) {
      custom = new Option('(loaded recipe)', '');
      sel.add(custom, 0);
    }
    sel.value = '';
  } else {
    if (custom) custom.remove();
    sel.value = name;
  }
}

async function loadPreset(name) {
  const doc = await api.getJson(`api/presets/${encodeURIComponent(name)}`);
  await adopt(doc, { keepSeed: true });
  selectPresetOption(name);
}

$('preset').onchange = () => {
  const name = $('preset').value;
  if (name) loadPreset(name).catch((e) => toast(`Could not load preset ${name}: ${e.message}`));
};
$('seed').onchange = () => {
  const v = Number($('seed').value);
  if (!Number.isInteger(v) || v < 0 || v > Number.MAX_SAFE_INTEGER) {
    toast(`seed: expected an integer in 0..${Number.MAX_SAFE_INTEGER}, got ${$('seed').value}`);
    $('seed').value = String(state.recipe.seed);
    return;
  }
  state.recipe.seed = v;
  generator.request('now');
};
$('randomise').onclick = () => {
  state.recipe.seed = randomSeed();
  $('seed').value = String(state.recipe.seed);
  generator.request('now');
};
$('size').onchange = () => {
  state.previewSize = Number($('size').value);
  generator.request('now');
};
$('play').onclick = playStages;
document.addEventListener('keydown', (e) => {
  if (e.key !== 'Escape') return;
  if (walk.active) exitWalk();
  if (playback.running) playback.stop = true;
});

// ---------------------------------------------------------------------------------- loop
let last = performance.now();
function loop(t) {
  const dt = Math.min(0.1, Math.max(0, (t - last) / 1000));
  last = t;
  if (view3d.controls.enabled) view3d.controls.update();
  walkTick(dt);
  if (view3d.dirty && state.view === '3d') view3d.render();
  while (afterRender.length) afterRender.shift()();
  requestAnimationFrame(loop);
}
requestAnimationFrame(loop);

// ---------------------------------------------------------------------------------- start
async function init() {
  try {
    const [table, presets] = await Promise.all([api.getJson('api/params'), api.getJson('api/presets')]);
    state.table = table;
    state.presets = presets;
    const sel = $('preset');
    for (const p of presets) {
      const o = new Option(p.name, p.name);
      o.title = p.description;
      sel.add(o);
    }
    buildExportMenu();
    // ?preset=NAME&seed=N&size=N pick the start (bookmarkable); the island otherwise.
    const q = new URLSearchParams(location.search);
    const size = Number(q.get('size'));
    if ([...$('size').options].some((o) => Number(o.value) === size)) {
      $('size').value = String(size);
      state.previewSize = size;
    }
    const start = presets.find((p) => p.name === (q.get('preset') || 'island')) || presets[0];
    if (!start) throw new Error('the server has no presets');
    const doc = await api.getJson(`api/presets/${encodeURIComponent(start.name)}`);
    const seed = Number(q.get('seed'));
    if (q.get('seed') !== null && Number.isSafeInteger(seed) && seed >= 0) doc.seed = seed;
    if (doc.seed === undefined) doc.seed = 7;
    await adopt(doc);
    selectPresetOption(start.name);
    state.ready = true;
  } catch (e) {
    toast(`Relief Studio could not start: ${e.message}`, 'error', 0);
  }
}
init();

// ---------------------------------------------------------------------------------- test hooks
// Read-only views of the page's state for the browser tests and the latency probe; the tests
// drive the page through its real controls (mouse, keyboard, file inputs).
window.studio = {
  state,
  view3d,
  viewSettings,
  playback,
  walk,
  get idle() {
    return generator.idle;
  },
  readPixels: (step) => view3d.readPixels(step),
  // Screen position (client px) of sample (i, j) on the terrain, for clicking it.
  sampleToScreen(i, j) {
    view3d.camera.updateMatrixWorld();  // as pick() does: the current view, drawn or not
    const p = groundDisplay(i, j).project(view3d.camera);
    const r = view3d.renderer.domElement.getBoundingClientRect();
    return { x: r.left + ((p.x + 1) / 2) * r.width, y: r.top + ((1 - p.y) / 2) * r.height, visible: Math.abs(p.x) < 0.95 && Math.abs(p.y) < 0.95 && p.z > -1 && p.z < 1 };
  },
  canReach(i, j) {
    if (!walk.grid || !walk.pos) return false;
    const { path } = findPath(walk.grid, [Math.round(walk.pos[0]), Math.round(walk.pos[1])], [i, j], { maxSlopeDeg: maxSlope() });
    return !!path;
  },
  loadRecipeText,
};
