// Relief Studio: what every part of the page shares: the page state, the two views, the display
// settings of the 3D view, messages and help, and drawing a result into the views.
import { View3D } from './view3d.js';
import { View2D } from './view2d.js';

export const $ = (id) => document.getElementById(id);
export const DRAG_BUDGET_MS = 70;  // server time above which drags preview at half resolution (auto)

export const state = {
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

export const view3d = new View3D($('box3d'));
export const view2d = new View2D($('box2d'));
export const afterRender = [];

// Display settings of the 3D view (not part of the recipe); main.js builds their menu.
export const viewSettings = { relief: view3d.vscale, texture: 'lit colours', sea: true, props: true, dragPreview: 'auto' };
state.shading = 'lit';

// ---------------------------------------------------------------------------------- messages
let toastTimer = null;
export function toast(message, kind = 'error', ms = 9000) {
  $('toast-text').textContent = message;
  $('toast').className = kind;
  $('toast').hidden = false;
  clearTimeout(toastTimer);
  if (ms) toastTimer = setTimeout(() => ($('toast').hidden = true), ms);
  if (kind === 'error') state.error = message;
}
$('toast-close').onclick = () => ($('toast').hidden = true);

export function help({ title, body }) {
  $('help').innerHTML = '';
  const b = document.createElement('b');
  b.textContent = title;
  const s = document.createElement('span');
  s.textContent = body;
  $('help').append(b, s);
}

// ---------------------------------------------------------------------------------- drawing
// The 3D texture: flat colours lit by the scene's sun when the terrain has them, else the
// hillshaded colour as it is, else an elevation tint.
export function renderTerrain(frame, layers) {
  const h = layers.height;
  if (!h) return;
  const pick = state.shading === 'baked' ? ['color', 'albedo'] : ['albedo', 'color'];
  const name = pick.find((n) => layers[n] && layers[n].type === 'rgb8');
  const lit = !name || name === 'albedo';
  view3d.setTerrain(frame, h.data, name ? layers[name].data : null, lit);
}

export function show2d(name) {
  const r = state.result;
  if (!r || !r.layers[name]) return false;
  view2d.show(name, r.layers[name], r.header.frame);
  return true;
}

