// Relief Studio: the volume (caves, overhangs, arches). When the terrain shown has a volume (the
// generate frame's header says "volume": true), the page asks POST /api/volume for that terrain's
// caves.glb (the same recipe, size and seed: the server meshes its cached terrain) once the
// generator has settled, and the 3D view shows it instead of the height mesh. A cut plane (the
// View menu's Volume folder) clips everything beyond it to look inside; the cut faces show flat in
// the rock colour. While the terrain changes (a slider drag), the height mesh is shown and the
// volume request of the older terrain is dropped (the server stops it when its connection closes).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import * as api from './api.js';
import { $, state, view3d, toast } from './page.js';
import { generator } from './generator.js';
import { playback } from './playback.js';

// What the page knows of the volume (read by the browser tests as window.studio.volume).
//   status: 'none' (the terrain has no volume), 'loading', 'shown', 'empty' (no surface in the
//   band), 'error'; triangles, vertices, chunks (glTF nodes caves_x…), bytes of the GLB; timings
//   from the server; loads: volumes applied; cut: the cut plane's settings.
export const volume = {
  status: 'none',
  show: true,
  cut: { enabled: false, axis: 'z', at: 0.5 },
  triangles: 0,
  vertices: 0,
  chunks: 0,
  bytes: 0,
  timings: null,
  error: null,
  loads: 0,
  forResult: null,  // the generate result whose volume is loaded or on its way
  clipping: () => view3d.clipping(),
};

let controller = null;
let folder = null;
const loader = new GLTFLoader();

// Copies `count` vectors of a 3-component attribute into out[3·v0 …] (plain float arrays at once;
// interleaved, normalised or 4-component ones one by one); `fill` in every component without one.
function copyVec3(out, v0, count, a, fill) {
  if (!a) {
    out.fill(fill, 3 * v0, 3 * (v0 + count));
  } else if (!a.isInterleavedBufferAttribute && !a.normalized && a.itemSize === 3 && a.array instanceof Float32Array) {
    out.set(a.array.subarray(0, count * 3), 3 * v0);
  } else {
    for (let k = 0; k < count; k++) {
      const o = 3 * (v0 + k);
      out[o] = a.getX(k), out[o + 1] = a.getY(k), out[o + 2] = a.getZ(k);
    }
  }
}

// caves.glb → one indexed BufferGeometry (position, normal, color) in the volume's coordinates,
// and its counts. Each chunk is a glTF node of its own; their seam vertices coincide but are kept
// apart (as in the file), which does not show.
export async function decodeVolume(buffer) {
  const gltf = await loader.parseAsync(buffer, '');
  gltf.scene.updateMatrixWorld(true);
  const parts = [];
  gltf.scene.traverse((o) => {
    if (!o.isMesh || !o.geometry.attributes.position) return;
    let g = o.geometry;
    if (!o.matrixWorld.equals(new THREE.Matrix4())) g = g.clone().applyMatrix4(o.matrixWorld);
    parts.push(g);
  });
  let nv = 0, ni = 0;
  for (const g of parts) {
    nv += g.attributes.position.count;
    ni += g.index ? g.index.count : g.attributes.position.count;
  }
  const pos = new Float32Array(nv * 3), nor = new Float32Array(nv * 3), col = new Float32Array(nv * 3);
  const idx = new Uint32Array(ni);
  let v0 = 0, q = 0;
  for (const g of parts) {
    const p = g.attributes.position, n = g.attributes.normal, c = g.attributes.color;
    copyVec3(pos, v0, p.count, p, 0);
    copyVec3(nor, v0, p.count, n, 0);
    copyVec3(col, v0, p.count, c, 0.6);
    if (g.index) {
      const a = g.index.array;
      for (let k = 0; k < a.length; k++) idx[q++] = v0 + a[k];
    } else {
      for (let k = 0; k < p.count; k++) idx[q++] = v0 + k;
    }
    v0 += p.count;
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  geometry.setAttribute('normal', new THREE.BufferAttribute(nor, 3));
  geometry.setAttribute('color', new THREE.BufferAttribute(col, 3));
  geometry.setIndex(new THREE.BufferAttribute(idx, 1));
  geometry.computeBoundingSphere();
  geometry.computeBoundingBox();
  const chunks = (gltf.parser.json.nodes || []).filter((n) => /^caves_x/.test(n.name || '')).length;
  for (const g of parts) g.dispose();
  return { geometry, triangles: ni / 3, vertices: nv, chunks };
}

// The Volume folder of the View menu: show the volume, and the cut plane (on/off, axis, position).
export function buildVolumeGui(viewGui) {
  folder = viewGui.addFolder('Volume');
  folder.domElement.id = 'volume-gui';
  const on = folder.add(volume, 'show').name('show volume').onChange(() => (update(), (view3d.dirty = true)));
  on.domElement.dataset.volume = 'show';
  on.domElement.title = 'The caves, overhangs and arches of the recipe\'s volume stages, meshed by the server (caves.glb); off: the height mesh';
  const cut = (c, name, title) => {
    c.name(name).onChange(() => view3d.setCut(volume.cut));
    c.domElement.dataset.volume = name;
    c.domElement.title = title;
  };
  cut(folder.add(volume.cut, 'enabled'), 'cut plane', 'Clip away everything beyond a plane to look inside the caves; cut rock shows flat');
  cut(folder.add(volume.cut, 'axis', ['x', 'z']), 'cut axis', 'x: a plane facing east (cuts along north–south); z: a plane facing south');
  cut(folder.add(volume.cut, 'at', 0, 1, 0.005), 'cut at', 'Where the plane cuts, across the world along the axis (0 = west / north edge)');
  folder.hide();
  const info = document.createElement('div');
  info.id = 'volume-info';
  info.hidden = true;
  $('box3d').appendChild(info);
}

function setInfo(text, kind = '') {
  const el = $('volume-info');
  if (!el) return;
  el.textContent = text;
  el.className = kind;
  el.hidden = !text;
}

// Shows the volume or the height mesh, from what the page has now.
function update() {
  const current = volume.forResult === state.result && volume.status === 'shown';
  view3d.showVolume(volume.show && current && !playback.running);
}

async function load(result) {
  if (controller) controller.abort();
  const ctrl = new AbortController();
  controller = ctrl;
  volume.forResult = result;
  volume.status = 'loading';
  volume.error = null;
  setInfo('Meshing the volume…', 'busy');
  try {
    const { buffer, timings } = await api.volume(result.header.recipe, { signal: ctrl.signal });
    if (ctrl.signal.aborted || volume.forResult !== result) return;
    const t0 = performance.now();
    const d = await decodeVolume(buffer);
    if (ctrl.signal.aborted || volume.forResult !== result) return d.geometry.dispose();
    Object.assign(volume, { triangles: d.triangles, vertices: d.vertices, chunks: d.chunks, bytes: buffer.byteLength, timings });
    volume.decode_ms = performance.now() - t0;
    if (d.triangles === 0) {
      d.geometry.dispose();
      view3d.clearVolume();
      volume.status = 'empty';
      setInfo('The volume has no surface here', 'note');
    } else {
      view3d.setVolume(d.geometry, result.header.frame);
      volume.status = 'shown';
      const k = (n) => (n >= 1e6 ? (n / 1e6).toFixed(2) + ' M' : n >= 1e4 ? (n / 1e3).toFixed(0) + ' k' : String(n));
      setInfo(`Volume · ${k(d.triangles)} triangles · ${d.chunks} chunks · ${((timings.server_ms || 0) / 1000).toFixed(2)} s`);
    }
    volume.loads++;
    update();
  } catch (e) {
    if (e.name === 'AbortError' || (e instanceof api.ApiError && e.status === 409)) return;
    if (volume.forResult !== result) return;
    volume.status = 'error';
    volume.error = e.message;
    setInfo('Volume: ' + e.message, 'error');
    toast(e instanceof api.ApiError ? `Volume: ${e.message}` : `The volume could not be shown: ${e.message}`);
  } finally {
    if (controller === ctrl) controller = null;
  }
}

// Called every animation frame (main.js), before drawing.
export function volumeTick() {
  const r = state.result;
  if (r !== volume.forResult) {
    // A new terrain: the volume shown (or on its way) is of the old one.
    if (volume.status === 'shown' || volume.status === 'loading') view3d.showVolume(false);
    if (!r || !r.header.volume) {
      if (controller) controller.abort();
      if (volume.status !== 'none') {
        view3d.clearVolume();
        Object.assign(volume, { status: 'none', triangles: 0, vertices: 0, chunks: 0, bytes: 0, error: null });
        setInfo('');
      }
      volume.forResult = r;
      if (folder) folder.hide();
      return;
    }
    if (folder) folder.show();
    // Fetched once the generator has settled (no drag in progress), no playback runs and the 3D
    // view is the one shown, so a slider drag or a 2D view costs no volume meshing.
    if (volume.show && generator.idle && !playback.running && state.view === '3d') load(r);
    else if (controller) controller.abort(), (volume.status = 'stale'), setInfo('');
  }
  update();
}
