// Relief Studio: walk mode: a walker on the terrain that goes where the user clicks, along a path
// no steeper than the slope limit (the path finding is in walk.js).
import { makeGrid, findPath, simplifyPath, nearestStandable, sampleAt, Walker } from './walk.js';
import { $, state, view3d, toast } from './page.js';
import { setView } from './views.js';

// ---------------------------------------------------------------------------------- walk mode
export const walk = {
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

export function maxSlope() {
  return Math.max(5, Math.min(80, Number($('walk-slope').value) || 30));
}

export function walkText(t) {
  walk.message = t;
  $('walk-text').textContent = t;
}

export function groundDisplay(fi, fj) {
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

export function enterWalk() {
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

export function exitWalk() {
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

export function walkTo(fi, fj) {
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
export function showWalkPath() {
  if (walk.path) view3d.showPath(walk.path.map(([a, b]) => groundDisplay(a, b).add({ x: 0, y: 0.6, z: 0 })));
}

export function pathLength(p) {
  let s = 0;
  for (let k = 1; k < p.length; k++) s += Math.hypot(p[k][0] - p[k - 1][0], p[k][1] - p[k - 1][1]);
  return s;
}

export function walkTick(dt) {
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

