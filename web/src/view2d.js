// 2D views of any layer the terrain has: three-channel layers as images, elevation with a
// hypsometric tint, categorical layers (names containing "biome" or "tile", or small sets of
// whole numbers) with a palette and legend, other one-channel layers as grey from min to max.
import { elevationTint } from './view3d.js';

// Distinct colours for category ids: golden-ratio hue steps.
export function categoryColor(id) {
  const h = ((id * 0.618033988749895) % 1 + 1) % 1;
  const s = 0.55, l = 0.55;
  const f = (n) => {
    const k = (n + h * 12) % 12;
    return Math.round(255 * (l - s * Math.min(l, 1 - l) * Math.max(-1, Math.min(k - 3, 9 - k, 1))));
  };
  return [f(0), f(8), f(4)];
}

export function isCategorical(name, data) {
  if (/biome|tile|class|region/i.test(name)) return true;
  const seen = new Set();
  for (let k = 0; k < data.length; k += 97) {
    const v = data[k];
    if (v !== Math.round(v)) return false;
    seen.add(v);
    if (seen.size > 64) return false;
  }
  return seen.size > 1 && seen.size <= 64;
}

export class View2D {
  constructor(container) {
    this.container = container;
    this.canvas = document.createElement('canvas');
    this.canvas.id = 'view2d';
    container.appendChild(this.canvas);
    this.legend = document.createElement('div');
    this.legend.className = 'legend';
    container.appendChild(this.legend);
    this.readout = document.createElement('div');
    this.readout.className = 'readout';
    container.appendChild(this.readout);
    this.canvas.addEventListener('mousemove', (e) => this.hover(e));
    this.canvas.addEventListener('mouseleave', () => (this.readout.textContent = ''));
    new ResizeObserver(() => this.fit()).observe(container);
  }

  // layer: {type: 'rgb8'|'f32', data}; frame: the server's frame.
  show(name, layer, frame) {
    const { nx, nz } = frame;
    this.name = name;
    this.layer = layer;
    this.frame = frame;
    this.canvas.width = nx;
    this.canvas.height = nz;
    const ctx = this.canvas.getContext('2d');
    const img = ctx.createImageData(nx, nz);
    const px = img.data, n = nx * nz;
    let rgb;
    this.legend.innerHTML = '';
    this.categorical = false;
    if (layer.type === 'rgb8') {
      rgb = layer.data;
    } else if (name === 'height') {
      rgb = elevationTint(layer.data, frame.sea_level);
      this.legendText(`elevation 0 … 1, sea level ${frame.sea_level}`);
    } else if (isCategorical(name, layer.data)) {
      this.categorical = true;
      rgb = new Uint8Array(n * 3);
      const counts = new Map();
      for (let k = 0; k < n; k++) {
        const id = Math.round(layer.data[k]);
        const c = categoryColor(id);
        rgb[3 * k] = c[0];
        rgb[3 * k + 1] = c[1];
        rgb[3 * k + 2] = c[2];
        counts.set(id, (counts.get(id) || 0) + 1);
      }
      for (const [id, count] of [...counts].sort((a, b) => a[0] - b[0])) {
        const c = categoryColor(id);
        const row = document.createElement('div');
        row.innerHTML = `<span class="swatch" style="background:rgb(${c.join(',')})"></span>${name} ${id} · ${((100 * count) / n).toFixed(1)}%`;
        this.legend.appendChild(row);
      }
    } else {
      let lo = Infinity, hi = -Infinity;
      for (let k = 0; k < n; k++) {
        const v = layer.data[k];
        if (Number.isFinite(v)) (lo = Math.min(lo, v)), (hi = Math.max(hi, v));
      }
      const span = hi > lo ? hi - lo : 1;
      rgb = new Uint8Array(n * 3);
      for (let k = 0; k < n; k++) rgb[3 * k] = rgb[3 * k + 1] = rgb[3 * k + 2] = ((layer.data[k] - lo) / span) * 255;
      this.legendText(`${name}: black ${lo.toPrecision(3)} … white ${hi.toPrecision(3)}`);
    }
    for (let k = 0; k < n; k++) {
      px[4 * k] = rgb[3 * k];
      px[4 * k + 1] = rgb[3 * k + 1];
      px[4 * k + 2] = rgb[3 * k + 2];
      px[4 * k + 3] = 255;
    }
    ctx.putImageData(img, 0, 0);
    this.fit();
  }

  legendText(t) {
    const row = document.createElement('div');
    row.textContent = t;
    this.legend.appendChild(row);
  }

  fit() {
    if (!this.frame) return;
    const W = this.container.clientWidth, H = this.container.clientHeight;
    const s = Math.min((W - 40) / this.frame.nx, (H - 40) / this.frame.nz);
    this.canvas.style.width = `${Math.max(1, Math.floor(this.frame.nx * s))}px`;
    this.canvas.style.height = `${Math.max(1, Math.floor(this.frame.nz * s))}px`;
  }

  hover(e) {
    if (!this.frame || !this.layer) return;
    const r = this.canvas.getBoundingClientRect();
    const i = Math.floor(((e.clientX - r.left) / r.width) * this.frame.nx);
    const j = Math.floor(((e.clientY - r.top) / r.height) * this.frame.nz);
    if (i < 0 || j < 0 || i >= this.frame.nx || j >= this.frame.nz) return;
    const k = j * this.frame.nx + i;
    const f = this.frame;
    let value;
    if (this.layer.type === 'rgb8') value = `rgb(${this.layer.data[3 * k]}, ${this.layer.data[3 * k + 1]}, ${this.layer.data[3 * k + 2]})`;
    else {
      const v = this.layer.data[k];
      value = this.name === 'height' ? `${v.toFixed(4)} (y ${((v - f.sea_level) * f.height_m).toFixed(1)} m)` : this.categorical ? `${Math.round(v)}` : v.toPrecision(4);
    }
    this.readout.textContent = `x ${(f.x0_m + i * f.cell_m).toFixed(0)} m, z ${(f.z0_m + j * f.cell_m).toFixed(0)} m · ${this.name} ${value}`;
  }
}
