// Walk mode's path finding: A* on the height grid (Hart, Nilsson & Raphael, "A Formal Basis for
// the Heuristic Determination of Minimum Cost Paths", IEEE SSC 1968), 8-connected, then
// string-pulled by line-of-sight checks so the walker does not zig-zag along grid directions.
//
// The grid is the generated terrain: nx × nz samples of normalised elevation (row-major, x
// fastest), cell_m metres apart, height_m metres per unit of elevation. A sample is walkable when
// it is at or above sea level; a step between neighbours is allowed when its slope, in real metres
// (no display exaggeration), is at most maxSlopeDeg. Cost = distance · (1 + (slope/max)²), so the
// walker prefers gentle ground; the straight-line distance is an admissible heuristic.

export function makeGrid(heights, frame) {
  return {
    h: heights,
    nx: frame.nx,
    nz: frame.nz,
    cell: frame.cell_m,
    heightM: frame.height_m,
    sea: frame.sea_level,
    x0: frame.x0_m || 0,
    z0: frame.z0_m || 0,
  };
}

const DIRS = [
  [1, 0], [-1, 0], [0, 1], [0, -1],
  [1, 1], [1, -1], [-1, 1], [-1, -1],
];

export function isLand(g, i, j) {
  return i >= 0 && j >= 0 && i < g.nx && j < g.nz && g.h[j * g.nx + i] >= g.sea;
}

// Slope in degrees of the step from sample a to sample b (indices into h) over `dist` metres.
function stepSlopeDeg(g, a, b, dist) {
  return (Math.atan(Math.abs(g.h[b] - g.h[a]) * g.heightM / dist) * 180) / Math.PI;
}

class MinHeap {
  constructor() {
    this.keys = [];
    this.items = [];
  }
  get size() {
    return this.items.length;
  }
  push(item, key) {
    const k = this.keys, it = this.items;
    let n = it.length;
    k.push(key);
    it.push(item);
    while (n > 0) {
      const p = (n - 1) >> 1;
      if (k[p] <= key) break;
      k[n] = k[p];
      it[n] = it[p];
      n = p;
    }
    k[n] = key;
    it[n] = item;
  }
  pop() {
    const k = this.keys, it = this.items;
    const top = it[0];
    const lastK = k.pop(), lastI = it.pop();
    const n = it.length;
    if (n > 0) {
      let i = 0;
      for (;;) {
        let c = 2 * i + 1;
        if (c >= n) break;
        if (c + 1 < n && k[c + 1] < k[c]) c++;
        if (k[c] >= lastK) break;
        k[i] = k[c];
        it[i] = it[c];
        i = c;
      }
      k[i] = lastK;
      it[i] = lastI;
    }
    return top;
  }
}

// A* from sample (si, sj) to (gi, gj). Returns [[i, j], …] including both ends, or null when the
// goal cannot be reached. `reason` explains a null in words.
export function findPath(g, start, goal, { maxSlopeDeg = 30 } = {}) {
  const [si, sj] = start, [gi, gj] = goal;
  if (!isLand(g, gi, gj)) return { path: null, reason: 'the target is in the water' };
  if (!isLand(g, si, sj)) return { path: null, reason: 'the walker is in the water' };
  const n = g.nx * g.nz;
  const cost = new Float64Array(n).fill(Infinity);
  const came = new Int32Array(n).fill(-1);
  const closed = new Uint8Array(n);
  const s = sj * g.nx + si, t = gj * g.nx + gi;
  const heur = (i, j) => Math.hypot(i - gi, j - gj) * g.cell;
  const heap = new MinHeap();
  cost[s] = 0;
  heap.push(s, heur(si, sj));
  let expanded = 0;
  while (heap.size) {
    const a = heap.pop();
    if (closed[a]) continue;
    if (a === t) break;
    closed[a] = 1;
    expanded++;
    const ai = a % g.nx, aj = (a - ai) / g.nx;
    for (const [di, dj] of DIRS) {
      const bi = ai + di, bj = aj + dj;
      if (bi < 0 || bj < 0 || bi >= g.nx || bj >= g.nz) continue;
      const b = bj * g.nx + bi;
      if (closed[b] || g.h[b] < g.sea) continue;
      const dist = (di && dj ? Math.SQRT2 : 1) * g.cell;
      const slope = stepSlopeDeg(g, a, b, dist);
      if (slope > maxSlopeDeg) continue;
      const r = slope / maxSlopeDeg;
      const c = cost[a] + dist * (1 + r * r);
      if (c < cost[b]) {
        cost[b] = c;
        came[b] = a;
        heap.push(b, c + heur(bi, bj));
      }
    }
  }
  if (s !== t && came[t] < 0) {
    return { path: null, reason: `no way there without crossing water or slopes steeper than ${maxSlopeDeg}°`, expanded };
  }
  const path = [];
  for (let v = t; v !== -1; v = v === s ? -1 : came[v]) path.push([v % g.nx, Math.floor(v / g.nx)]);
  path.reverse();
  return { path, cost: cost[t], expanded };
}

// Bilinear elevation at fractional sample coordinates.
export function sampleAt(g, fi, fj) {
  const i0 = Math.max(0, Math.min(g.nx - 2, Math.floor(fi)));
  const j0 = Math.max(0, Math.min(g.nz - 2, Math.floor(fj)));
  const tx = Math.max(0, Math.min(1, fi - i0)), tz = Math.max(0, Math.min(1, fj - j0));
  const h = g.h, nx = g.nx;
  const a = h[j0 * nx + i0], b = h[j0 * nx + i0 + 1], c = h[(j0 + 1) * nx + i0], d = h[(j0 + 1) * nx + i0 + 1];
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * tz;
}

// True when a straight walk from p to q (sample coordinates) stays on land and within the slope
// limit, checked every quarter cell.
export function clearLine(g, p, q, maxSlopeDeg) {
  const len = Math.hypot(q[0] - p[0], q[1] - p[1]);
  const steps = Math.max(1, Math.ceil(len * 4));
  const stepM = (len / steps) * g.cell;
  const maxRise = Math.tan((maxSlopeDeg * Math.PI) / 180) * stepM;
  let prev = sampleAt(g, p[0], p[1]);
  for (let k = 1; k <= steps; k++) {
    const t = k / steps;
    const e = sampleAt(g, p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t);
    if (e < g.sea) return false;
    if (Math.abs(e - prev) * g.heightM > maxRise) return false;
    prev = e;
  }
  return true;
}

// Drops intermediate grid points wherever the straight line is walkable.
export function simplifyPath(g, path, maxSlopeDeg) {
  if (!path || path.length <= 2) return path;
  const out = [path[0]];
  let anchor = 0;
  while (anchor < path.length - 1) {
    let far = anchor + 1;
    for (let k = anchor + 2; k < path.length; k++) {
      if (clearLine(g, path[anchor], path[k], maxSlopeDeg)) far = k;
      else if (k - far > 8) break;  // give up looking far past the first blocked point
    }
    out.push(path[far]);
    anchor = far;
  }
  return out;
}

// The walkable sample nearest to (i, j) whose 8 neighbours are all walkable steps (a place to
// stand), searching outwards ring by ring; null if there is no such sample.
export function nearestStandable(g, i, j, maxSlopeDeg) {
  const ok = (a, b) => {
    if (!isLand(g, a, b)) return false;
    for (const [di, dj] of DIRS) {
      const c = a + di, d = b + dj;
      if (!isLand(g, c, d)) return false;
      const dist = (di && dj ? Math.SQRT2 : 1) * g.cell;
      if (stepSlopeDeg(g, b * g.nx + a, d * g.nx + c, dist) > maxSlopeDeg) return false;
    }
    return true;
  };
  const maxR = Math.max(g.nx, g.nz);
  for (let r = 0; r < maxR; r++) {
    let best = null, bestD = Infinity;
    for (let b = j - r; b <= j + r; b++)
      for (let a = i - r; a <= i + r; a++) {
        if (Math.max(Math.abs(a - i), Math.abs(b - j)) !== r) continue;
        if (!ok(a, b)) continue;
        const d = Math.hypot(a - i, b - j);
        if (d < bestD) (bestD = d), (best = [a, b]);
      }
    if (best) return best;
  }
  return null;
}

// Moves along a polyline of sample coordinates at `speed` samples per second.
export class Walker {
  constructor(path) {
    this.path = path;
    this.segment = 0;
    this.t = 0;
    this.pos = path[0].slice();
    this.done = path.length < 2;
    this.heading = 0;
  }
  advance(distanceSamples) {
    let left = distanceSamples;
    while (!this.done && left > 0) {
      const a = this.path[this.segment], b = this.path[this.segment + 1];
      const len = Math.hypot(b[0] - a[0], b[1] - a[1]);
      const remaining = len * (1 - this.t);
      this.heading = Math.atan2(b[1] - a[1], b[0] - a[0]);
      if (left < remaining) {
        this.t += left / len;
        left = 0;
      } else {
        left -= remaining;
        this.segment++;
        this.t = 0;
        if (this.segment >= this.path.length - 1) this.done = true;
      }
      const s = Math.min(this.segment, this.path.length - 2);
      const p = this.path[s], q = this.path[s + 1];
      const tt = this.done ? 1 : this.t;
      this.pos = [p[0] + (q[0] - p[0]) * tt, p[1] + (q[1] - p[1]) * tt];
    }
    return this.pos;
  }
}
