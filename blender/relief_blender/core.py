"""The scene-independent half of the add-on: no `bpy` here, so a Maya (or any other DCC) panel can
reuse it as is.

- the parameter table (`relief.explain()`) turned into widget specs (`ParamSpec`): kind, range,
  default, choices and the help text, one per parameter, so the UI is generated, never written by
  hand per stage;
- `RecipeDoc`: the recipe being edited (a plain dict, the same JSON the CLI reads), with the
  conversions between recipe values and widget values;
- `Job`: one generation on a Python thread (the module releases the GIL while it runs), with
  progress and cancel, for a UI that must stay responsive;
- the arrays a DCC needs to build the scene fast: grid vertex positions (Z up), quad loops, edges
  and UVs (cached per size), the albedo texture as RGBA floats, props grouped by type, river
  polylines and flat lake patches.

Coordinates: Relief's world is x east, y up, z south (metres, sea surface at y = 0). A Z-up DCC gets
X = x, Y = -z, Z = y (a proper rotation, so a rotation about +y of the props is a rotation about +Z).
Sample (i, j) sits at X = x_m(i), Y = -z_m(j); the grid's quads are wound counter-clockwise seen
from +Z.
"""
import json
import math
import os
import random
import threading
import time

import numpy as np

try:  # the copy bundled in the add-on (zip or build tree)
    from . import relief
except ImportError:  # a `relief` installed or on PYTHONPATH
    import relief

__all__ = ["relief", "ParamSpec", "table", "stage_specs", "world_specs", "RecipeDoc", "Job", "Grid", "grid",
           "positions", "albedo_rgba", "props_by_type", "river_polylines", "lake_patches", "random_seed"]

MAX_UI_INT = 2**31 - 1  # DCC integer widgets are 32-bit
SEED_MAX = 2**31 - 1    # the seed widget's range (the library takes 0..2^53-1)

# ---------------------------------------------------------------------------------------------
# The parameter table as widget specs
# ---------------------------------------------------------------------------------------------
_table = None


def table():
    """relief.explain() (the whole parameter table), read once."""
    global _table
    if _table is None:
        _table = relief.explain()
    return _table


class ParamSpec:
    """One parameter as a widget: kind is 'float', 'int', 'bool', 'enum', 'string', 'color' or
    'json' (lists, colour levels, curves: edited as JSON text). `default` is the table's default in
    widget form (see to_widget)."""

    __slots__ = ("name", "kind", "type", "default", "min", "max", "choices", "unit", "description", "effect", "raw_default")

    def __init__(self, row):
        self.name = row["name"]
        self.type = row["type"]
        self.raw_default = row.get("default")
        self.min = row.get("min")
        self.max = row.get("max")
        self.choices = list(row.get("choices", []) or [])
        self.unit = row.get("unit", "")
        self.effect = row.get("effect", "regenerate")
        t = self.type
        if t == "float":
            self.kind = "float"
        elif t == "int":
            # Integers with a [a, b] default (world.size) are not single widgets.
            self.kind = "int" if not isinstance(self.raw_default, list) else "json"
        elif t == "bool":
            self.kind = "bool"
        elif t == "choice":
            self.kind = "enum"
        elif t == "text":
            self.kind = "string"
        elif t == "color":
            self.kind = "color"
        else:
            self.kind = "json"
        desc = row.get("description", "")
        extra = []
        if self.unit:
            extra.append(self.unit)
        if self.min is not None and self.max is not None and self.kind in ("float", "int"):
            extra.append("%s..%s" % (_num(self.min), _num(self.max)))
        if self.effect and self.effect != "regenerate":
            extra.append(self.effect)
        if self.kind == "json":
            extra.append("JSON")
        self.description = desc + (" [" + ", ".join(extra) + "]" if extra else "")
        self.default = self.to_widget(self.raw_default)

    # recipe value -> widget value
    def to_widget(self, v):
        k = self.kind
        if k == "float":
            return float(v) if v is not None else 0.0
        if k == "int":
            return int(v) if v is not None else 0
        if k == "bool":
            return bool(v)
        if k == "enum":
            return str(v) if v is not None else (self.choices[0] if self.choices else "")
        if k == "string":
            return "" if v is None else str(v)
        if k == "color":
            return parse_color(v)
        return json.dumps(v, separators=(", ", ": "))

    # widget value -> recipe value (old: the recipe's current value, whose form a colour keeps)
    def to_recipe(self, w, old=None):
        k = self.kind
        if k == "float":
            return _round_float(w)
        if k == "int":
            return int(w)
        if k == "bool":
            return bool(w)
        if k in ("enum", "string"):
            return str(w)
        if k == "color":
            r, g, b = (max(0.0, min(1.0, float(c))) for c in list(w)[:3])
            if isinstance(old, list):  # keep the 0..255 triple form
                return [_round_float(r * 255.0), _round_float(g * 255.0), _round_float(b * 255.0)]
            return "#%02x%02x%02x" % (int(round(r * 255)), int(round(g * 255)), int(round(b * 255)))
        try:
            return json.loads(w)
        except ValueError as e:
            raise ValueError("%s: expected JSON: %s" % (self.name, e)) from None

    def soft_range(self):
        """A slider range for a float: the table's range, narrowed around the default when it spans
        many orders of magnitude (the hard limits stay the table's)."""
        lo, hi = self.min, self.max
        if lo is None or hi is None:
            return None
        d = abs(float(self.default or 0.0))
        if hi - lo > 1000 and d > 0:
            return (max(lo, 0.0 if lo >= 0 else -d * 10), min(hi, d * 10))
        return (lo, hi)


def _num(x):
    return ("%g" % x) if isinstance(x, float) else str(x)


def _round_float(v):
    """A float widget value (single precision in Blender) back to the shortest decimal that reads
    the same, so 0.4 stays 0.4 in the recipe rather than 0.4000000059604645."""
    v = float(v)
    if not math.isfinite(v):
        return v
    f32 = np.float32(v)
    for digits in range(6, 10):
        s = float("%.*g" % (digits, v))
        if np.float32(s) == f32:
            return s
    return v


def parse_color(v):
    """'#rrggbb' or [r, g, b] in 0..255 -> (r, g, b) in 0..1."""
    if isinstance(v, str) and v.startswith("#") and len(v) == 7:
        return tuple(int(v[k:k + 2], 16) / 255.0 for k in (1, 3, 5))
    if isinstance(v, (list, tuple)) and len(v) >= 3:
        return tuple(max(0.0, min(1.0, float(c) / 255.0)) for c in v[:3])
    return (0.0, 0.0, 0.0)


def stage_names():
    return [s["name"] for s in table()["stages"]]


def stage_info(name):
    for s in table()["stages"]:
        if s["name"] == name:
            return s
    raise ValueError("stages: unknown stage %r" % name)


_specs = {}


def stage_specs(name):
    """[ParamSpec] of stage `name`, in the table's order."""
    if name not in _specs:
        _specs[name] = [ParamSpec(r) for r in stage_info(name)["params"]]
    return _specs[name]


def world_specs():
    """[ParamSpec] of the world block, without `size` (the preview and bake sizes set it)."""
    if "__world__" not in _specs:
        _specs["__world__"] = [ParamSpec(r) for r in table()["world"] if r["name"] != "size"]
    return _specs["__world__"]


def presets():
    """[(name, description)] of every preset the module knows (built-in and user presets)."""
    return [(p["name"], p.get("description", "")) for p in relief.presets()]


def random_seed(rng=None):
    return (rng or random).randint(0, SEED_MAX)


# ---------------------------------------------------------------------------------------------
# The recipe being edited
# ---------------------------------------------------------------------------------------------
class RecipeDoc:
    """A recipe as the CLI reads it ({"world": {...}, "stages": [{"stage": ..., ...}], ...}).
    Values the user never touched stay exactly as the preset or file wrote them, so generating
    it gives the CLI's bytes for the same recipe and seed."""

    def __init__(self, doc):
        if not isinstance(doc, dict):
            raise ValueError("recipe: expected a JSON object")
        self.doc = doc
        self.doc.setdefault("world", {})
        self.doc.setdefault("stages", [])

    @classmethod
    def from_preset(cls, name):
        return cls(relief.preset(name))

    @classmethod
    def from_json(cls, text):
        return cls(json.loads(text) if text else relief.preset("island"))

    @classmethod
    def load(cls, path):
        with open(path, "r", encoding="utf-8") as f:
            doc = json.load(f)
        relief.resolve(doc)  # raises relief.Error naming the field if it is not a valid recipe
        return cls(doc)

    def to_json(self, indent=None):
        return json.dumps(self.doc, indent=indent)

    def save(self, path, seed=None):
        doc = dict(self.doc)
        if seed is not None:
            doc["seed"] = int(seed)
        tmp = path + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(doc, f, indent=2)
            f.write("\n")
        os.replace(tmp, path)

    @property
    def stages(self):
        return self.doc["stages"]

    def stage_label(self, idx):
        s = self.stages[idx]
        return s.get("label") or s.get("stage", "?")

    def values(self, idx):
        """{param: widget value} of stage idx: the recipe's values, the table's defaults for the rest."""
        s = self.stages[idx]
        return {p.name: (p.to_widget(s[p.name]) if p.name in s else p.default) for p in stage_specs(s["stage"])}

    def world_values(self):
        w = self.doc["world"]
        return {p.name: (p.to_widget(w[p.name]) if p.name in w else p.default) for p in world_specs()}

    def set_param(self, idx, name, widget_value):
        s = self.stages[idx]
        spec = next(p for p in stage_specs(s["stage"]) if p.name == name)
        s[name] = spec.to_recipe(widget_value, s.get(name, spec.raw_default))

    def set_world(self, name, widget_value):
        spec = next(p for p in world_specs() if p.name == name)
        w = self.doc["world"]
        w[name] = spec.to_recipe(widget_value, w.get(name, spec.raw_default))

    def add_stage(self, name, at=None):
        stage_info(name)
        entry = {"stage": name}
        if at is None:
            self.stages.append(entry)
        else:
            self.stages.insert(at, entry)

    def remove_stage(self, idx):
        del self.stages[idx]

    def move_stage(self, idx, delta):
        j = idx + delta
        if 0 <= j < len(self.stages):
            self.stages[idx], self.stages[j] = self.stages[j], self.stages[idx]


# ---------------------------------------------------------------------------------------------
# Generation on a thread
# ---------------------------------------------------------------------------------------------
class Cancelled(Exception):
    pass


class Job:
    """relief.generate on a Python thread. The module releases the GIL while the library runs, so
    the caller's thread (a DCC's UI) keeps going; poll `done`, read `fraction`/`what`, call
    `cancel()` (the run stops at the library's next progress report, e.g. the next stage)."""

    def __init__(self, recipe, seed, size, threads=0, tag=None):
        self.recipe, self.seed, self.size, self.threads, self.tag = recipe, seed, size, threads, tag
        self.fraction, self.what = 0.0, "starting"
        self.result = None
        self.error = None
        self.cancelled = False
        self.seconds = 0.0
        self._cancel = threading.Event()
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="relief-generate", daemon=True)

    def start(self):
        self._thread.start()
        return self

    def run(self):
        """Runs on the caller's thread (scripts, background mode)."""
        self._run()
        if self.error:
            raise self.error
        return self.result

    def _progress(self, what, fraction):
        self.what, self.fraction = what, fraction
        if self._cancel.is_set():
            raise Cancelled()

    def _run(self):
        t0 = time.perf_counter()
        try:
            self.result = relief.generate(self.recipe, seed=self.seed, size=self.size, threads=self.threads,
                                          progress=self._progress)
        except Cancelled:
            self.cancelled = True
        except BaseException as e:  # handed to the UI thread
            if self._cancel.is_set():
                self.cancelled = True
            else:
                self.error = e
        finally:
            self.seconds = time.perf_counter() - t0
            self._done.set()

    def cancel(self):
        self._cancel.set()

    @property
    def done(self):
        return self._done.is_set()

    def wait(self, timeout=None):
        return self._done.wait(timeout)


# ---------------------------------------------------------------------------------------------
# Arrays for the scene
# ---------------------------------------------------------------------------------------------
class Grid:
    """Topology of an nx x nz grid of samples as flat arrays (uint32 indices: the dtype Blender's
    foreach_set copies without conversion): quads a=(i,j), b=(i,j+1), c=(i+1,j+1), d=(i+1,j)
    (counter-clockwise seen from +Z once Y = -z), edges (rows first, then columns), each loop's
    edge, and per-loop UVs (u = i/(nx-1), v = 1 - j/(nz-1): the OBJ writer's, image row 0 at the
    top)."""

    def __init__(self, nx, nz):
        self.nx, self.nz = nx, nz
        u32 = np.uint32
        cx, cz = nx - 1, nz - 1
        self.faces = cx * cz
        # Quads written straight into preallocated arrays (no stacking temporaries).
        col = np.arange(cx, dtype=u32)[None, :]
        row = (np.arange(cz, dtype=u32) * u32(nx))[:, None]
        a = row + col  # (i, j)
        loops = np.empty((cz, cx, 4), dtype=u32)
        loops[:, :, 0] = a
        np.add(a, u32(nx), out=loops[:, :, 1])
        np.add(a, u32(nx + 1), out=loops[:, :, 2])
        np.add(a, u32(1), out=loops[:, :, 3])
        self.loops = loops.reshape(-1)
        self.loop_start = np.arange(0, 4 * self.faces, 4, dtype=u32)
        self.loop_total = np.full(self.faces, 4, dtype=u32)
        nh = nz * cx  # horizontal edges (along x), row by row, then vertical ones
        edges = np.empty(2 * (nh + cz * nx), dtype=u32)
        eh = edges[:2 * nh].reshape(nz, cx, 2)
        eh[:, :, 0] = (np.arange(nz, dtype=u32) * u32(nx))[:, None] + col
        np.add(eh[:, :, 0], u32(1), out=eh[:, :, 1])
        ev = edges[2 * nh:].reshape(cz, nx, 2)
        ev[:, :, 0] = row + np.arange(nx, dtype=u32)[None, :]
        np.add(ev[:, :, 0], u32(nx), out=ev[:, :, 1])
        self.edges = edges
        le = np.empty((cz, cx, 4), dtype=u32)
        rv = (np.arange(cz, dtype=u32) * u32(nx) + u32(nh))[:, None]
        rh = (np.arange(cz, dtype=u32) * u32(cx))[:, None]
        np.add(rv, col, out=le[:, :, 0])              # (i, j)-(i, j+1)
        np.add(rh + u32(cx), col, out=le[:, :, 1])    # (i, j+1)-(i+1, j+1)
        np.add(le[:, :, 0], u32(1), out=le[:, :, 2])  # (i+1, j+1)-(i+1, j)
        np.add(rh, col, out=le[:, :, 3])              # (i+1, j)-(i, j)
        self.loop_edges = le.reshape(-1)
        self.smooth = np.ones(self.faces, dtype=bool)
        self._uvs = None

    @property
    def loop_uvs(self):
        """Per-loop UVs, float32 (made on first use: a preview does not need them)."""
        if self._uvs is not None:
            return self._uvs
        nx, nz = self.nx, self.nz
        cx, cz = nx - 1, nz - 1
        u = (np.arange(nx, dtype=np.float64) / max(cx, 1)).astype(np.float32)
        v = (1.0 - np.arange(nz, dtype=np.float64) / max(cz, 1)).astype(np.float32)
        uv = np.empty((cz, cx, 4, 2), dtype=np.float32)
        uv[:, :, 0, 0] = uv[:, :, 1, 0] = u[None, :-1]
        uv[:, :, 2, 0] = uv[:, :, 3, 0] = u[None, 1:]
        uv[:, :, 0, 1] = uv[:, :, 3, 1] = v[:-1, None]
        uv[:, :, 1, 1] = uv[:, :, 2, 1] = v[1:, None]
        self._uvs = uv.reshape(-1)
        return self._uvs


_grids = {}


def grid(nx, nz):
    """The Grid of nx x nz samples, cached (a preview refresh reuses its topology)."""
    key = (nx, nz)
    g = _grids.get(key)
    if g is None:
        if len(_grids) > 4:
            _grids.clear()
        g = _grids[key] = Grid(nx, nz)
    return g


def chunks(nx, nz, cells):
    """Sample windows (i0, i1, j0, j1), inclusive ends, of at most `cells` quads per side; adjacent
    windows share their border samples, so the chunks join without seams. One window when the grid
    fits."""
    cells = max(1, int(cells))
    xs = list(range(0, nx - 1, cells)) or [0]
    zs = list(range(0, nz - 1, cells)) or [0]
    return [(i0, min(i0 + cells, nx - 1), j0, min(j0 + cells, nz - 1)) for j0 in zs for i0 in xs]


def positions(t, window=None):
    """float32 (n*3,) vertex positions of the terrain (or of a window (i0, i1, j0, j1)), Z up:
    X = x_m + dx, Y = -(z_m + dz), Z = (e - sea_level) * height_m, with the jiggle stage's `offset`
    layer (dx, dz in metres) applied as the mesh writers do."""
    f = t.frame
    h = t.height
    off = t.layers.get("offset") if "offset" in t.layer_names else None
    i0, i1, j0, j1 = window or (0, f["nx"] - 1, 0, f["nz"] - 1)
    h = h[j0:j1 + 1, i0:i1 + 1]
    nz, nx = h.shape
    cell = f["cell_m"]
    p = np.empty((nz, nx, 3), dtype=np.float32)
    x = (f["ix0"] + np.arange(i0, i1 + 1, dtype=np.float64)) * cell
    z = (f["iz0"] + np.arange(j0, j1 + 1, dtype=np.float64)) * cell
    p[:, :, 0] = x[None, :]
    p[:, :, 1] = -z[:, None]
    # y_m(e) = (e - sea_level) * height_m, in double as Frame::y_m
    p[:, :, 2] = (h.astype(np.float64) - f["sea_level"]) * f["height_m"]
    if off is not None:
        o = off[j0:j1 + 1, i0:i1 + 1]
        p[:, :, 0] += o[:, :, 0]
        p[:, :, 1] -= o[:, :, 1]
    return p.reshape(-1)


def colour_layer(t):
    for name in ("albedo", "color"):
        if name in t.layer_names:
            return t.layers[name]
    return None


def albedo_rgba(t):
    """The albedo layer as a DCC image's RGBA float pixels (rows bottom-up, as Blender stores them),
    quantised to the 8 bits albedo.png holds (byte = floor(clamp(v) * 255 + 0.5)), so a byte image
    filled with these holds exactly albedo.png's bytes. None without a colour layer."""
    a = colour_layer(t)
    if a is None:
        return None
    nz, nx = a.shape[:2]
    # floor(v * 255 + 0.5) in double (exact for a float32 v), clamped to 0..255; fmax maps NaN to 0
    # as the writer's unit() does.
    x = np.multiply(a, 255.0, dtype=np.float64)
    x += 0.5
    np.floor(x, out=x)
    np.fmax(x, 0.0, out=x)
    np.minimum(x, 255.0, out=x)
    px = np.empty((nz, nx, 4), dtype=np.float32)
    px[:, :, 3] = 1.0
    np.multiply(x[::-1], 1.0 / 255.0, out=px[:, :, :3], casting="same_kind")
    return px.reshape(-1)


def props_by_type(t):
    """{type: (positions float32 (n,3) Z up, rotation about +Z in radians (n,), scale (n,))}."""
    groups = {}
    for p in t.props:
        groups.setdefault(p["type"], []).append(p)
    out = {}
    for name, ps in sorted(groups.items()):
        pos = np.array([(p["x_m"], -p["z_m"], p["y_m"]) for p in ps], dtype=np.float32).reshape(-1, 3)
        rot = np.radians(np.array([p["rotation_deg"] for p in ps], dtype=np.float64)).astype(np.float32)
        scale = np.array([p["scale"] for p in ps], dtype=np.float32)
        out[name] = (pos, rot, scale)
    return out


def river_polylines(t):
    """[(points float32 (n,3) Z up, widths (n,), order)] of the terrain's rivers."""
    out = []
    for r in t.rivers:
        vs = r["vertices"]
        pts = np.array([(v["x_m"], -v["z_m"], v["y_m"]) for v in vs], dtype=np.float32).reshape(-1, 3)
        w = np.array([v["width_m"] for v in vs], dtype=np.float32)
        out.append((pts, w, r.get("order", 1)))
    return out


def lake_patches(t):
    """Flat lake meshes: per lake, (vertices float32 (n,3), quads uint32 (m,4)) at the lake's level:
    the grid cells inside the lake's bounds with a corner below its level. A (vertices, quads) pair
    per lake; lakes with no such cell are left out."""
    f = t.frame
    cell = f["cell_m"]
    h = t.height
    out = []
    for k in t.lakes:
        level = float(k["level_m"])
        x0, z0, x1, z1 = k["bbox_m"]
        i0 = max(0, int(math.floor(x0 / cell - f["ix0"])) - 1)
        i1 = min(f["nx"] - 1, int(math.ceil(x1 / cell - f["ix0"])) + 1)
        j0 = max(0, int(math.floor(z0 / cell - f["iz0"])) - 1)
        j1 = min(f["nz"] - 1, int(math.ceil(z1 / cell - f["iz0"])) + 1)
        if i1 <= i0 or j1 <= j0:
            continue
        y = (h[j0:j1 + 1, i0:i1 + 1].astype(np.float64) - f["sea_level"]) * f["height_m"]
        below = y < level
        cellmask = below[:-1, :-1] | below[1:, :-1] | below[1:, 1:] | below[:-1, 1:]
        if not cellmask.any():
            continue
        nz, nx = y.shape
        idx = np.arange(nx * nz, dtype=np.uint32).reshape(nz, nx)
        quads = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], axis=-1)[cellmask]
        used = np.unique(quads)
        remap = np.zeros(nx * nz, dtype=np.uint32)
        remap[used] = np.arange(len(used), dtype=np.uint32)
        jj, ii = np.divmod(used.astype(np.int64), nx)
        verts = np.empty((len(used), 3), dtype=np.float32)
        verts[:, 0] = (f["ix0"] + i0 + ii) * cell
        verts[:, 1] = -(f["iz0"] + j0 + jj) * cell
        verts[:, 2] = level
        out.append((verts, remap[quads]))
    return out
