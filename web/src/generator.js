// Relief Studio: the recipe and its generation: the recipe sent to the server (preview size, drag
// previews), adopting a recipe (resolved by the server, shown in the panel), and the one request
// in flight that brings a result to the views.
import * as api from './api.js';
import { Panel } from './panel.js';
import { $, DRAG_BUDGET_MS, state, view3d, afterRender, viewSettings, toast, help, renderTerrain, show2d } from './page.js';
import { updateTabs } from './views.js';
import { walk } from './walkmode.js';

// ---------------------------------------------------------------------------------- recipe
// The recipe sent to the server: the panel's recipe at the preview size (aspect kept).
export function previewSizeOf(recipe, n) {
  const [nx, nz] = recipe.world.size;
  if (nx >= nz) return [n, Math.max(2, Math.round(((n - 1) * (nz - 1)) / (nx - 1)) + 1)];
  return [Math.max(2, Math.round(((n - 1) * (nx - 1)) / (nz - 1)) + 1), n];
}

// While a slider is dragged, the preview may run at half resolution (every other sample of the
// full preview: pointwise stages agree exactly there) when full updates are slower than the
// budget; letting go of the slider brings the full resolution back.
export function dragSize() {
  const n = state.previewSize;
  const mode = viewSettings.dragPreview;
  if (mode === 'full' || n <= 129) return n;
  if (mode === 'half' || (state.fullServerMs !== null && state.fullServerMs > DRAG_BUDGET_MS)) return (n - 1) / 2 + 1;
  return n;
}

export function requestRecipe({ fullSize = false, dragging = false } = {}) {
  const r = structuredClone(state.recipe);
  if (!fullSize) r.world.size = previewSizeOf(state.recipe, dragging ? dragSize() : state.previewSize);
  return r;
}

export function randomSeed() {
  const a = new Uint32Array(1);
  crypto.getRandomValues(a);
  return a[0] % 1000000000;
}

// Resolves a recipe document on the server (validation + defaults) and makes it the current one.
// Throws api.ApiError with the server's message; the current recipe is untouched on failure.
export async function adopt(doc, { keepSeed = false } = {}) {
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

// Shows the preset chosen in the toolbar, or "(loaded recipe)" for null.
export function selectPresetOption(name) {
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

export const panel = new Panel($('panel-box'), {
  onChange: ({ finished }) => generator.request(finished ? 'now-coalesced' : 'drag'),
  onHelp: help,
  onUpload: async (file, path) => {
    toast(`Uploading ${file.name}…`, 'info', 0);
    try {
      const u = await api.upload(file);
      toast(`${path} ← ${u.name} (${u.width}×${u.height} ${u.format}, ${(u.bytes / 1024).toFixed(0)} KiB; kept by the studio for this page)`, 'info', 4000);
      return u.path;
    } catch (e) {
      toast(`Could not upload ${file.name}: ${e.message}`);
      return null;
    }
  },
  onNoUploadTarget: (file) => toast(`No stage takes a file: add an image stage (Add a stage ▸ image), then drop ${file.name} on it`),
  onStructure: (recipe) => {
    // A stage was added or removed: resolve (fills defaults, checks) and rebuild the panel.
    adopt(recipe).catch((e) => toast(`Could not change the stages: ${e.message}`));
  },
});

// ---------------------------------------------------------------------------------- generation
// At most one request in flight. While dragging, changes made during a request are coalesced
// into one follow-up request with the latest values; a discrete change (preset, seed, size)
// aborts the running request, and the server cancels it between stages (409).
export class Generator {
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
export const generator = new Generator();

export function applyResult(result) {
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

export function showTimings(header, totalMs) {
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

