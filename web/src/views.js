// Relief Studio: the view tabs (3D and one per layer the terrain has) and switching between them.
import { $, state, view3d, show2d } from './page.js';
import { generator } from './generator.js';
import { walk } from './walkmode.js';

// ---------------------------------------------------------------------------------- views
export const LAYER_ORDER = ['color', 'albedo', 'height'];
export function tabLabel(name) {
  return { color: 'Colour', albedo: 'Albedo', height: 'Height' }[name] || name.replace(/_/g, ' ').replace(/^./, (c) => c.toUpperCase());
}
export function updateTabs(available) {
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

export function setView(v) {
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

