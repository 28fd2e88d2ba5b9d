// The 3D view: the terrain as a lit, textured height mesh in metres (x east, y up, z south,
// centred on the window), a translucent sea plane at y = 0, props as instanced meshes, feature
// points as pins, and walk mode's walker, path and eye-height camera. A recipe with a volume
// (caves, overhangs, arches) shows its mesh instead of the height mesh, with a cut plane to look
// inside (volume.js fetches it).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const SKY = new THREE.Color(0xbfd6ea);
// The colour of rock cut open by the cut plane (sRGB), drawn flat on the cap.
export const CUT_COLOR = 0x5b4636;

// Display sizes of prop types in metres at scale 1 (a convention of the viewer; exports carry
// the placements, not these shapes). Matched by words in the type name, else a tree.
const PROP_SHAPES = [
  { words: ['rock', 'stone', 'boulder'], make: () => new THREE.DodecahedronGeometry(1.6, 0).translate(0, 0.8, 0), color: 0x8a8580 },
  { words: ['bush', 'shrub', 'grass', 'mushroom', 'flower'], make: () => new THREE.IcosahedronGeometry(1.2, 0).translate(0, 1.0, 0), color: 0x4f7d36 },
  { words: ['cactus'], make: () => new THREE.CylinderGeometry(0.5, 0.6, 5, 6).translate(0, 2.5, 0), color: 0x5f8f48 },
  { words: [], make: () => new THREE.ConeGeometry(2.6, 9, 7).translate(0, 4.5, 0), color: 0x2f5a2a },  // trees
];

function shapeFor(type) {
  const t = String(type).toLowerCase();
  return PROP_SHAPES.find((s) => s.words.some((w) => t.includes(w))) || PROP_SHAPES[PROP_SHAPES.length - 1];
}

// Elevation tint for steps that have no colour layer yet: water blues, then sand, green, brown,
// snow (sRGB bytes).
export function elevationTint(heights, sea) {
  const n = heights.length;
  const out = new Uint8Array(n * 3);
  const land = (f) => sea + (1 - sea) * f;
  const ramp = [
    [0.0, [24, 52, 96]], [sea, [78, 138, 186]], [sea + 0.0001, [214, 200, 150]], [land(0.03), [150, 180, 100]],
    [land(0.3), [80, 130, 64]], [land(0.55), [130, 112, 92]], [land(0.8), [170, 160, 150]], [1.0, [245, 245, 245]],
  ];
  for (let k = 0; k < n; k++) {
    const e = Math.max(0, Math.min(1, heights[k]));
    let r = ramp.length - 2;
    for (let q = 0; q < ramp.length - 1; q++) if (e <= ramp[q + 1][0]) { r = q; break; }
    const [a0, c0] = ramp[r], [a1, c1] = ramp[r + 1];
    const t = a1 > a0 ? (e - a0) / (a1 - a0) : 0;
    out[3 * k] = c0[0] + (c1[0] - c0[0]) * t;
    out[3 * k + 1] = c0[1] + (c1[1] - c0[1]) * t;
    out[3 * k + 2] = c0[2] + (c1[2] - c0[2]) * t;
  }
  return out;
}

export class View3D {
  constructor(container) {
    this.container = container;
    // A stencil buffer for the cap of the volume's cut plane.
    const renderer = new THREE.WebGLRenderer({ antialias: true, logarithmicDepthBuffer: true, stencil: true });
    renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    renderer.domElement.id = 'view3d';
    container.appendChild(renderer.domElement);
    this.renderer = renderer;

    const scene = new THREE.Scene();
    scene.background = SKY;
    scene.fog = new THREE.Fog(SKY, 8000, 30000);
    this.scene = scene;

    this.camera = new THREE.PerspectiveCamera(42, 1, 1, 80000);
    this.controls = new OrbitControls(this.camera, renderer.domElement);
    this.controls.enableDamping = true;
    this.controls.dampingFactor = 0.12;
    this.controls.maxPolarAngle = Math.PI * 0.495;
    this.controls.screenSpacePanning = false;

    this.hemi = new THREE.HemisphereLight(0xe8f0ff, 0x6b5a48, 0.9);
    scene.add(this.hemi);
    this.sun = new THREE.DirectionalLight(0xfff4e0, 3.2);
    // From the north-west, 45° up: the hillshade stage's default light.
    this.sun.position.set(-1, Math.SQRT2, -1).normalize();
    scene.add(this.sun);

    this.terrainMaterial = new THREE.MeshLambertMaterial({ color: 0xffffff });
    this.terrain = null;
    this.texture = null;

    this.sea = new THREE.Mesh(
      new THREE.PlaneGeometry(1, 1).rotateX(-Math.PI / 2),
      new THREE.MeshPhongMaterial({ color: 0x24598a, transparent: true, opacity: 0.42, shininess: 40, specular: 0x223344, depthWrite: false }),
    );
    this.sea.renderOrder = 1;
    scene.add(this.sea);
    // The sea floor beyond the terrain, at elevation 0, so the sea does not end at the map edge.
    this.floor = new THREE.Mesh(new THREE.PlaneGeometry(1, 1).rotateX(-Math.PI / 2), new THREE.MeshLambertMaterial({ color: 0x1d4877 }));
    scene.add(this.floor);

    this.props = new THREE.Group();
    scene.add(this.props);
    this.pins = new THREE.Group();
    scene.add(this.pins);

    // The volume: caves.glb's chunks merged into one geometry (metres, y up, sea surface at 0),
    // lit in its vertex colours. The cut plane clips it (and the height mesh, the sea and its
    // floor); the volume is a closed solid, so the cut is capped where the plane lies inside it,
    // found with the stencil buffer: along each pixel's ray, the clipped solid's back faces count
    // up and its front faces down (no depth test), so a non-zero count marks rock cut open by the
    // plane; the cap (a quad in the plane, depth-tested like anything else, so that the sea behind
    // it or rock in front of it hides or shows correctly) is drawn only there.
    renderer.localClippingEnabled = true;
    this.cut = { enabled: false, axis: 'z', at: 0.5 };
    this.cutPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 0);
    this.volume = new THREE.Group();
    this.volume.name = 'volume';
    this.volume.visible = false;
    scene.add(this.volume);
    this.volumeFront = new THREE.MeshLambertMaterial({ vertexColors: true });
    const counting = (side, op) =>
      new THREE.MeshBasicMaterial({
        side, colorWrite: false, depthWrite: false, depthTest: false, stencilWrite: true,
        stencilFunc: THREE.AlwaysStencilFunc, stencilFail: op, stencilZFail: op, stencilZPass: op,
      });
    this.volumeCount = [counting(THREE.BackSide, THREE.IncrementWrapStencilOp), counting(THREE.FrontSide, THREE.DecrementWrapStencilOp)];
    this.cap = new THREE.Mesh(
      new THREE.PlaneGeometry(1, 1),
      new THREE.MeshBasicMaterial({
        color: CUT_COLOR, fog: false, side: THREE.DoubleSide, stencilWrite: true, stencilRef: 0,
        stencilFunc: THREE.NotEqualStencilFunc, stencilFail: THREE.ReplaceStencilOp, stencilZFail: THREE.ReplaceStencilOp,
        stencilZPass: THREE.ReplaceStencilOp,
      }),
    );
    this.cap.name = 'volume:cap';
    this.cap.renderOrder = 3;  // after the counting passes (renderOrder 2), before the sea (transparent)
    this.cap.visible = false;
    this.cap.onAfterRender = (r) => r.clearStencil();
    scene.add(this.cap);
    this.volumeMeshes = null;  // {front, counts: [back, front]}
    this.volumeFrame = null;   // the frame the volume was made on

    // Walk mode: a person-sized capsule (1.8 m), a beacon to find it from afar, the path.
    this.walker = new THREE.Group();
    const body = new THREE.Mesh(new THREE.CapsuleGeometry(0.3, 1.2, 4, 12).translate(0, 0.9, 0), new THREE.MeshLambertMaterial({ color: 0xff7a1a }));
    const beacon = new THREE.Mesh(
      new THREE.CylinderGeometry(0.6, 0.6, 120, 8, 1, true).translate(0, 62, 0),
      new THREE.MeshBasicMaterial({ color: 0xff7a1a, transparent: true, opacity: 0.45, depthWrite: false }),
    );
    this.beacon = beacon;
    this.walker.add(body, beacon);
    this.walker.visible = false;
    scene.add(this.walker);
    this.pathLine = new THREE.Line(new THREE.BufferGeometry(), new THREE.LineBasicMaterial({ color: 0xffe14d }));
    this.pathLine.visible = false;
    scene.add(this.pathLine);

    this.vscale = 2;
    this.frame = null;
    this.heights = null;
    this.mode = 'orbit';
    this.dirty = true;
    this.controls.addEventListener('change', () => (this.dirty = true));
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  resize() {
    const w = Math.max(1, this.container.clientWidth), h = Math.max(1, this.container.clientHeight);
    this.renderer.setSize(w, h, false);
    this.renderer.domElement.style.width = '100%';
    this.renderer.domElement.style.height = '100%';
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.dirty = true;
  }

  // Display position (metres, centred) of sample coordinates (fractional allowed).
  toDisplay(fi, fj, e) {
    const f = this.frame;
    return new THREE.Vector3(fi * f.cell_m - f.width_m / 2, (e - f.sea_level) * f.height_m * this.vscale, fj * f.cell_m - f.depth_m / 2);
  }

  // frame: the server's frame; heights: Float32Array (nx·nz); rgb: Uint8Array (nx·nz·3, sRGB) or
  // null for an elevation tint; lit: light the texture (flat colours) or show it as is (shaded).
  setTerrain(frame, heights, rgb, lit) {
    const { nx, nz } = frame;
    const sizeChanged = !this.frame || this.frame.nx !== nx || this.frame.nz !== nz || this.frame.cell_m !== frame.cell_m;
    const extentChanged = !this.frame || this.frame.width_m !== frame.width_m || this.frame.depth_m !== frame.depth_m;
    const first = !this.frame;
    this.frame = frame;
    this.heights = heights;
    if (sizeChanged) this.buildGeometry(nx, nz);
    this.terrain.visible = !this.volume.visible;
    this.updateHeights();
    if (!rgb) rgb = elevationTint(heights, frame.sea_level);
    this.setTexture(nx, nz, rgb);
    const mat = lit ? 'lambert' : 'basic';
    if (this.materialKind !== mat) {
      this.terrainMaterial.dispose();
      this.terrainMaterial = lit ? new THREE.MeshLambertMaterial({ map: this.texture }) : new THREE.MeshBasicMaterial({ map: this.texture });
      this.terrain.material = this.terrainMaterial;
      this.materialKind = mat;
      this.applyCut();
    } else if (this.terrainMaterial.map !== this.texture) {
      this.terrainMaterial.map = this.texture;
      this.terrainMaterial.needsUpdate = true;
    }
    const span = Math.max(frame.width_m, frame.depth_m);
    this.sea.scale.set(span * 60, 1, span * 60);
    this.placeVolume();
    this.applyCut();
    this.floor.scale.set(span * 60, 1, span * 60);
    this.floor.position.y = (0 - frame.sea_level) * frame.height_m * this.vscale - 0.5;
    this.scene.fog.near = span * 1.5;
    this.scene.fog.far = span * 6;
    if (first || extentChanged) this.frameCamera();
    this.dirty = true;
  }

  buildGeometry(nx, nz) {
    if (this.terrain) {
      this.scene.remove(this.terrain);
      this.terrain.geometry.dispose();
    }
    const g = new THREE.BufferGeometry();
    const pos = new Float32Array(nx * nz * 3), nor = new Float32Array(nx * nz * 3), uv = new Float32Array(nx * nz * 2);
    for (let j = 0; j < nz; j++)
      for (let i = 0; i < nx; i++) {
        const k = j * nx + i;
        uv[2 * k] = i / (nx - 1);
        uv[2 * k + 1] = j / (nz - 1);  // texture row j (z-min first) at v = j/(nz−1), flipY off
      }
    const idx = new Uint32Array((nx - 1) * (nz - 1) * 6);
    let q = 0;
    for (let j = 0; j < nz - 1; j++)
      for (let i = 0; i < nx - 1; i++) {
        const a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
        idx[q++] = a; idx[q++] = c; idx[q++] = b;
        idx[q++] = b; idx[q++] = c; idx[q++] = d;
      }
    // Heights and normals change on every update: dynamic buffers.
    g.setAttribute('position', new THREE.BufferAttribute(pos, 3).setUsage(THREE.DynamicDrawUsage));
    g.setAttribute('normal', new THREE.BufferAttribute(nor, 3).setUsage(THREE.DynamicDrawUsage));
    g.setAttribute('uv', new THREE.BufferAttribute(uv, 2));
    g.setIndex(new THREE.BufferAttribute(idx, 1));
    this.terrain = new THREE.Mesh(g, this.terrainMaterial);
    this.terrain.name = 'terrain';
    this.scene.add(this.terrain);
  }

  updateHeights() {
    const f = this.frame, h = this.heights, { nx, nz } = f;
    const g = this.terrain.geometry;
    const pos = g.attributes.position.array, nor = g.attributes.normal.array;
    const ys = f.height_m * this.vscale, cell = f.cell_m;
    const x0 = -f.width_m / 2, z0 = -f.depth_m / 2;
    for (let j = 0; j < nz; j++)
      for (let i = 0; i < nx; i++) {
        const k = j * nx + i;
        pos[3 * k] = x0 + i * cell;
        pos[3 * k + 1] = (h[k] - f.sea_level) * ys;
        pos[3 * k + 2] = z0 + j * cell;
        // Normal of y(x, z) from central differences (one-sided at the border).
        const il = i > 0 ? k - 1 : k, ir = i < nx - 1 ? k + 1 : k;
        const jd = j > 0 ? k - nx : k, ju = j < nz - 1 ? k + nx : k;
        const dx = ((h[ir] - h[il]) * ys) / (((ir - il) || 1) * cell);
        const dz = ((h[ju] - h[jd]) * ys) / ((((ju - jd) / nx) || 1) * cell);
        const inv = 1 / Math.sqrt(dx * dx + 1 + dz * dz);
        nor[3 * k] = -dx * inv;
        nor[3 * k + 1] = inv;
        nor[3 * k + 2] = -dz * inv;
      }
    g.attributes.position.needsUpdate = true;
    g.attributes.normal.needsUpdate = true;
    g.computeBoundingSphere();
    g.computeBoundingBox();
  }

  setTexture(nx, nz, rgb) {
    const n = nx * nz;
    if (!this.texture || this.texture.image.width !== nx || this.texture.image.height !== nz) {
      if (this.texture) this.texture.dispose();
      this.texture = new THREE.DataTexture(new Uint8Array(n * 4), nx, nz, THREE.RGBAFormat);
      this.texture.colorSpace = THREE.SRGBColorSpace;
      this.texture.magFilter = THREE.LinearFilter;
      this.texture.minFilter = THREE.LinearMipmapLinearFilter;
      this.texture.generateMipmaps = true;
      this.texture.anisotropy = this.renderer.capabilities.getMaxAnisotropy();
    }
    const d = this.texture.image.data;
    for (let k = 0; k < n; k++) {
      d[4 * k] = rgb[3 * k];
      d[4 * k + 1] = rgb[3 * k + 1];
      d[4 * k + 2] = rgb[3 * k + 2];
      d[4 * k + 3] = 255;
    }
    this.texture.needsUpdate = true;
  }

  setVerticalScale(v) {
    this.vscale = v;
    if (this.frame) {
      this.updateHeights();
      this.floor.position.y = (0 - this.frame.sea_level) * this.frame.height_m * this.vscale - 0.5;
      if (this.lastPoints) this.setPoints(this.lastPoints);
      this.placeVolume();
      this.applyCut();
    }
    this.dirty = true;
  }

  frameCamera() {
    const f = this.frame;
    const span = Math.max(f.width_m, f.depth_m);
    this.camera.position.set(span * 0.58, span * 0.4, span * 0.82);
    this.controls.target.set(0, 0, 0);
    this.controls.minDistance = span * 0.02;
    this.controls.maxDistance = span * 4;
    this.controls.update();
    this.dirty = true;
  }

  // points: the decoded frame points ({data, count, stride, kinds, types}).
  setPoints(points) {
    this.lastPoints = points;
    for (const group of [this.props, this.pins])
      for (const m of [...group.children]) {
        group.remove(m);
        m.geometry.dispose();
        m.material.dispose();
      }
    if (!points || !points.count || !this.frame) return;
    const f = this.frame, d = points.data, s = points.stride;
    const byType = new Map();
    for (let p = 0; p < points.count; p++) {
      const kind = points.kinds[d[p * s + 5]];
      const type = points.types[d[p * s + 6]];
      const key = kind === 'prop' ? `prop:${type}` : 'pin';
      if (!byType.has(key)) byType.set(key, { type, kind, idx: [] });
      byType.get(key).idx.push(p);
    }
    const m = new THREE.Matrix4(), q = new THREE.Quaternion(), v = new THREE.Vector3(), sc = new THREE.Vector3();
    const up = new THREE.Vector3(0, 1, 0);
    for (const { type, kind, idx } of byType.values()) {
      const isProp = kind === 'prop';
      const shape = isProp ? shapeFor(type) : null;
      const geo = isProp ? shape.make() : new THREE.ConeGeometry(6, 40, 8).rotateX(Math.PI).translate(0, 20, 0);
      const mat = new THREE.MeshLambertMaterial({ color: isProp ? shape.color : 0xd23c3c });
      const mesh = new THREE.InstancedMesh(geo, mat, idx.length);
      mesh.name = isProp ? `props:${type}` : 'points';
      idx.forEach((p, n) => {
        const x = d[p * s] - f.x0_m - f.width_m / 2, y = d[p * s + 1] * this.vscale, z = d[p * s + 2] - f.z0_m - f.depth_m / 2;
        q.setFromAxisAngle(up, (d[p * s + 3] * Math.PI) / 180);
        const k = isProp ? d[p * s + 4] || 1 : 1;
        m.compose(v.set(x, y, z), q, sc.set(k, k, k));
        mesh.setMatrixAt(n, m);
      });
      mesh.instanceMatrix.needsUpdate = true;
      (isProp ? this.props : this.pins).add(mesh);
    }
    this.dirty = true;
  }

  // ------------------------------------------------------------------------------ volume
  // geometry: a BufferGeometry (position, normal, color; indexed) in the volume's coordinates:
  // metres, x and z from the world's origin, y above the sea surface. frame: the frame it was made
  // on (the server's). Replaces the volume shown before (whose geometry is disposed).
  setVolume(geometry, frame) {
    this.clearVolume();
    const front = new THREE.Mesh(geometry, this.volumeFront);
    front.name = 'volume';
    const counts = this.volumeCount.map((m) => {
      const c = new THREE.Mesh(geometry, m);
      c.name = 'volume:stencil';
      c.renderOrder = 2;
      c.frustumCulled = false;  // counted along every ray, also where the solid is off screen
      return c;
    });
    this.volume.add(front, ...counts);
    this.volumeMeshes = { front, counts };
    this.volumeFrame = frame;
    this.placeVolume();
    this.applyCut();
    this.dirty = true;
  }

  clearVolume() {
    if (this.volumeMeshes) {
      this.volume.remove(this.volumeMeshes.front, ...this.volumeMeshes.counts);
      this.volumeMeshes.front.geometry.dispose();
      this.volumeMeshes = null;
      this.volumeFrame = null;
    }
    this.showVolume(false);
  }

  // Shows the volume instead of the height mesh (true), or the height mesh (false).
  showVolume(on) {
    const v = !!on && !!this.volumeMeshes;
    if (this.volume.visible === v) return;
    this.volume.visible = v;
    if (this.terrain) this.terrain.visible = !v;
    this.applyCut();
    this.dirty = true;
  }

  // The volume's coordinates to the display's: centred on the window like the height mesh, the
  // heights exaggerated by the relief scale (points are placed the same way).
  placeVolume() {
    const f = this.volumeFrame;
    if (!f) return;
    this.volume.position.set(-(f.x0_m || 0) - f.width_m / 2, 0, -(f.z0_m || 0) - f.depth_m / 2);
    this.volume.scale.set(1, this.vscale, 1);
    this.volume.updateMatrixWorld(true);
  }

  // cut: {enabled, axis: 'x' | 'z', at: 0..1 across the world along the axis}. Everything beyond
  // the plane (the side towards the start camera, +x or +z) is clipped away: the volume, the
  // height mesh, the sea and the sea floor; the volume's cut rock is capped in CUT_COLOR.
  setCut(cut) {
    this.cut = { ...this.cut, ...cut };
    this.applyCut();
    this.dirty = true;
  }

  applyCut() {
    const { enabled, axis, at } = this.cut;
    const f = this.frame || this.volumeFrame;
    if (f) {
      const extent = axis === 'x' ? f.width_m : f.depth_m;
      this.cutPlane.normal.set(axis === 'x' ? -1 : 0, 0, axis === 'x' ? 0 : -1);
      this.cutPlane.constant = (Math.min(1, Math.max(0, at)) - 0.5) * extent;  // keeps axis ≤ constant
    }
    const planes = enabled ? [this.cutPlane] : [];
    for (const m of [this.volumeFront, ...this.volumeCount, this.terrainMaterial, this.sea.material, this.floor.material]) m.clippingPlanes = planes;
    if (this.volumeMeshes) for (const c of this.volumeMeshes.counts) c.visible = enabled;
    // The cap: a square in the plane, larger than the world's cross-section (the stencil trims it).
    this.cap.visible = enabled && this.volume.visible;
    if (f) {
      const span = 4 * Math.max(f.width_m, f.depth_m, f.height_m * this.vscale);
      this.cap.scale.set(span, span, 1);
      this.cutPlane.coplanarPoint(this.cap.position);
      this.cap.lookAt(this.cap.position.clone().add(this.cutPlane.normal));
      this.cap.updateMatrixWorld();
    }
  }

  // What the renderer clips with now (tests): {local, planes: [{normal: [x, y, z], constant}]}.
  clipping() {
    return {
      local: this.renderer.localClippingEnabled,
      planes: (this.volumeFront.clippingPlanes || []).map((p) => ({ normal: p.normal.toArray(), constant: p.constant })),
    };
  }

  // Sample coordinates under the pointer, or null.
  pick(clientX, clientY) {
    if (!this.terrain) return null;
    const r = this.renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    // The camera's world matrix is otherwise refreshed only when a frame is drawn: a click between
    // a camera move and the next frame (about a second apart on a software renderer) would be
    // picked through the previous view.
    this.camera.updateMatrixWorld();
    ray.setFromCamera(ndc, this.camera);
    const hit = ray.intersectObject(this.terrain, false)[0];
    if (!hit) return null;
    const f = this.frame;
    return { fi: (hit.point.x + f.width_m / 2) / f.cell_m, fj: (hit.point.z + f.depth_m / 2) / f.cell_m, point: hit.point };
  }

  showPath(points3) {
    this.pathLine.geometry.dispose();
    this.pathLine.geometry = new THREE.BufferGeometry().setFromPoints(points3);
    this.pathLine.visible = points3.length > 1;
    this.dirty = true;
  }

  placeWalker(p, heading) {
    this.walker.position.copy(p);
    this.walker.rotation.y = -heading;
    this.walker.visible = true;
    this.dirty = true;
  }

  // Walk camera: at eye height (1.7 m above the ground) a few metres behind the walker, looking
  // along the ground ahead.
  followWalker(p, heading, groundAt) {
    const back = 6, eye = 1.7, ahead = 80;
    const cx = p.x - Math.cos(heading) * back, cz = p.z - Math.sin(heading) * back;
    const cy = Math.max(groundAt(cx, cz), p.y) + eye;
    const lx = p.x + Math.cos(heading) * ahead, lz = p.z + Math.sin(heading) * ahead;
    const ly = Math.max(groundAt(lx, lz), 0) + eye;
    this.camera.position.set(cx, cy, cz);
    this.camera.lookAt(lx, Math.min(ly, cy + ahead * 0.2), lz);
    this.dirty = true;
  }

  // orbit: the orbit controls; follow: the walk camera, at true vertical scale (a person next to
  // exaggerated hills would give a false sense of scale) and a wider field of view.
  setMode(mode) {
    if (mode === this.mode) return;
    this.mode = mode;
    this.controls.enabled = mode === 'orbit';
    this.beacon.visible = mode !== 'follow';
    this.camera.near = mode === 'follow' ? 0.1 : 1;
    this.camera.fov = mode === 'follow' ? 60 : 42;
    if (mode === 'follow') {
      this.userScale = this.vscale;
      this.setVerticalScale(1);
    } else if (this.userScale !== undefined) {
      this.setVerticalScale(this.userScale);
      this.userScale = undefined;
    }
    this.camera.updateProjectionMatrix();
    if (mode === 'orbit') {
      this.controls.update();
    }
    this.dirty = true;
  }

  render() {
    this.renderer.render(this.scene, this.camera);
    this.dirty = false;
  }

  // Renders and reads the pixels back in the same task (the drawing buffer is still valid), for
  // tests and the latency probe: {width, height, mean, variance, pixels (downsampled RGB)}.
  readPixels(step = 8) {
    this.render();
    const gl = this.renderer.getContext();
    const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    const buf = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, buf);
    let sum = 0, sum2 = 0, n = 0;
    const small = [];
    for (let y = 0; y < h; y += step)
      for (let x = 0; x < w; x += step) {
        const k = 4 * (y * w + x);
        const l = 0.299 * buf[k] + 0.587 * buf[k + 1] + 0.114 * buf[k + 2];
        sum += l;
        sum2 += l * l;
        n++;
        small.push(buf[k], buf[k + 1], buf[k + 2]);
      }
    const mean = sum / n;
    return { width: w, height: h, mean, variance: sum2 / n - mean * mean, pixels: small };
  }
}
