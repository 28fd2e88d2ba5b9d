// Relief Studio: the page. Everything it shows comes from the server's generic registries: the
// panel from the parameter table, the view tabs from the layers the terrain has, the export menu
// from the writer registry, the playback from the recipe's stages.
import './style.css';
import GUI from 'lil-gui';
import * as api from './api.js';
import { findPath } from './walk.js';
import { $, DRAG_BUDGET_MS, state, view3d, viewSettings, afterRender, toast, renderTerrain } from './page.js';
import { generator, adopt, randomSeed, selectPresetOption } from './generator.js';
import { playback, playStages } from './playback.js';
import { walk, exitWalk, walkTick, groundDisplay, maxSlope } from './walkmode.js';
import { buildExportMenu, loadRecipeText } from './export.js';
import { volume, volumeTick, buildVolumeGui } from './volume.js';

// The menu of the 3D view's display settings (page.js).
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
buildVolumeGui(viewGui);  // shown when the terrain has a volume
viewGui.close();

// ---------------------------------------------------------------------------------- toolbar
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
// A file dropped outside the panel (which takes image files) is not opened by the browser in
// place of the studio.
for (const type of ['dragover', 'drop'])
  window.addEventListener(type, (e) => {
    if (e.dataTransfer && [...e.dataTransfer.types].includes('Files') && !e.defaultPrevented) e.preventDefault();
  });
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
  volumeTick();
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
  volume,  // the volume's status, counts and cut plane (volume.js); volume.clipping(): the renderer's planes
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
