"""Headless test of the Relief add-on against the CLI (run by CTest, label `blender`):

  PATH=/usr/bin:/bin BLENDER_USER_SCRIPTS=build/blender RELIEF_BINARY=build/relief \
  blender -b --factory-startup --python-exit-code 1 --python blender/tests/test_addon.py -- --work DIR

Enables the add-on, generates island and volcanic-island at 129² and 513² through the panel's
operators and compares the scene with the CLI's files for the same preset, seed and size: vertex and
face counts, vertex heights against height.r16, the material's albedo image against albedo.png
(byte for byte), prop instances (count, type, position, rotation, scale) against props.json, the sea
plane's height against height.json, river curves and lake meshes against rivers.json and lakes.json
(island with a flow stage, loaded from a recipe file). Then: Bake replaces the preview (no second
terrain, no stray datablocks), chunked terrains join, a widget edit gives the CLI's `--set` result,
every parameter of the table has a widget with its help text, and a broken recipe file is refused
naming its field. Every failure is collected and the script exits 1 at the end.
"""
import json
import math
import os
import subprocess
import sys
import time

import addon_utils
import bpy
import numpy as np

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
WORK = argv[argv.index("--work") + 1] if "--work" in argv else "/tmp/relief-blender-test"
RELIEF = os.environ["RELIEF_BINARY"]
SEED = 7
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, finish  # noqa: E402


def cli(out, *args):
    os.makedirs(out, exist_ok=True)
    cmd = [RELIEF, "generate", *args, "--seed", str(SEED), "-o", out, "-q", "--formats", "default,-obj,-color"]
    subprocess.run(cmd, check=True)
    return out


def load_json(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


# ---- enable ---------------------------------------------------------------------------------
mod = addon_utils.enable("relief_blender", default_set=True, handle_error=None)
check(mod is not None, "the add-on enables")
import relief_blender  # noqa: E402
from relief_blender import core  # noqa: E402

scripts = os.environ.get("BLENDER_USER_SCRIPTS", "")
check(os.path.realpath(core.relief.__file__).startswith(os.path.realpath(scripts)),
      "the relief module is the one bundled in the add-on (%s)" % core.relief.__file__)
check(hasattr(bpy.types, "RELIEF_PT_main") and bpy.types.RELIEF_PT_main.bl_space_type == "VIEW_3D"
      and bpy.types.RELIEF_PT_main.bl_category == "Relief", "the sidebar panel 'Relief' is registered")
scn = bpy.context.scene
s = scn.relief
s.live = False  # no timers in background mode; the operators run synchronously


def terrain_objects():
    return sorted((o for o in bpy.data.objects if o.get("relief_role") == "terrain"), key=lambda o: o.name)


def vertices(ob):
    co = np.empty(len(ob.data.vertices) * 3, dtype=np.float32)
    ob.data.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def check_heights(tag, ob, out, size):
    hj = load_json(os.path.join(out, "height.json"))
    r16 = np.fromfile(os.path.join(out, "height.r16"), dtype="<u2").astype(np.float64)
    e = r16 / 65535.0
    z_cli = (e - hj["sea_level"]) * hj["height_m"]
    co = vertices(ob)
    tol = hj["height_m"] / 65535.0 * 0.5 + 1e-3  # r16 quantisation
    err = np.abs(co[:, 2].astype(np.float64) - z_cli)
    check(err.max() <= tol, "%s: vertex z equals the CLI's height.r16 (max error %.4g m, tolerance %.4g)" % (tag, err.max(), tol))
    cell = hj["metres_per_pixel"]
    i = np.tile(np.arange(size), size)
    j = np.repeat(np.arange(size), size)
    dx = np.abs(co[:, 0] - i * cell).max()
    dy = np.abs(co[:, 1] + j * cell).max()
    check(dx <= 0.5 * cell and dy <= 0.5 * cell, "%s: vertex (i, j) at X = i·cell, Y = -j·cell (±jiggle)" % tag)
    return hj


def image_pixels(img):
    px = np.empty(img.size[0] * img.size[1] * img.channels, dtype=np.float32)
    img.pixels.foreach_get(px)
    return px.reshape(img.size[1], img.size[0], img.channels)


def check_albedo(tag, out):
    mat = bpy.data.materials.get("Relief Terrain")
    if not check(mat is not None, "%s: material 'Relief Terrain' exists" % tag):
        return
    node = mat.node_tree.nodes.get("Albedo")
    img = node.image if node else None
    if not check(img is not None, "%s: the material has an albedo image" % tag):
        return
    linked = any(l.from_node == node and l.to_socket.name == "Base Color" for l in mat.node_tree.links)
    check(linked, "%s: the albedo image feeds the base colour" % tag)
    ref = bpy.data.images.load(os.path.join(out, "albedo.png"), check_existing=False)
    a, b = image_pixels(img)[:, :, :3], image_pixels(ref)[:, :, :3]
    same = a.shape == b.shape and np.array_equal(np.round(a * 255), np.round(b * 255))
    diff = int(np.count_nonzero(np.round(a * 255) != np.round(b * 255))) if a.shape == b.shape else -1
    check(same, "%s: the material's image equals the CLI's albedo.png (%s vs %s, %d values differ)" % (
        tag, a.shape, b.shape, diff))
    bpy.data.images.remove(ref)


def expected_uv(n, vidx):
    i, j = vidx % n, vidx // n
    return np.stack([i / (n - 1), 1.0 - j / (n - 1)], axis=-1)


def check_texture_placement(tag, ob, n, cell=None):
    """Where the albedo lands: through the mesh's UVs (bake), or the Mapping node from object
    coordinates (preview); either way sample (i, j) reads texture (i/(n-1), 1 - j/(n-1)), as the
    OBJ writer's UVs."""
    if ob is None:
        return
    nt = bpy.data.materials["Relief Terrain"].node_tree
    mp = nt.nodes.get("Relief placement")
    src = [l.from_socket.name for l in nt.links if l.to_node == mp]
    vidx = np.arange(n * n)
    if ob.data.uv_layers:
        check(src == ["UV"], "%s: the texture is mapped through the UVs" % tag)
        lv = np.empty(len(ob.data.loops), dtype=np.int32)
        ob.data.loops.foreach_get("vertex_index", lv)
        uv = np.empty(len(ob.data.loops) * 2, dtype=np.float32)
        ob.data.uv_layers[0].data.foreach_get("uv", uv)
        err = np.abs(uv.reshape(-1, 2) - expected_uv(n, lv)).max()
        check(err < 1e-6, "%s: UVs are the OBJ writer's (max error %.3g)" % (tag, err))
    else:
        check(src == ["Object"], "%s: the preview maps the texture from object coordinates (%s)" % (tag, src))
        loc, sc = np.array(mp.inputs["Location"].default_value), np.array(mp.inputs["Scale"].default_value)
        i, j = vidx % n, vidx // n
        xy = np.stack([i * cell, -j * cell], axis=-1)
        uv = xy * sc[:2] + loc[:2]
        err = np.abs(uv - expected_uv(n, vidx)).max()
        check(err < 1e-5, "%s: the object-space mapping places sample (i, j) at the OBJ writer's UV (max error %.3g)" % (tag, err))


def instances():
    """[(type, matrix_world)] of the prop instances the depsgraph produces."""
    dg = bpy.context.evaluated_depsgraph_get()
    out = []
    for inst in dg.object_instances:
        if inst.is_instance and inst.parent is not None and inst.parent.original.get("relief_role") == "props":
            out.append((inst.parent.original["relief_prop_type"], np.array(inst.matrix_world)))
    return out


def check_props(tag, out):
    path = os.path.join(out, "props.json")
    ref = load_json(path)["props"] if os.path.exists(path) else []  # no props stage: no props.json
    got = instances()
    check(len(got) == len(ref), "%s: %d prop instances, props.json has %d" % (tag, len(got), len(ref)))
    if not ref or len(got) != len(ref):
        return
    # Match each props.json entry to the nearest instance of its type (props.json rounds to mm).
    perr = serr = aerr = 0.0
    g_by, matched = {}, 0
    for t_, m in got:
        g_by.setdefault(t_, []).append(m)
    for t_ in sorted(set(p["type"] for p in ref)):
        rr = [p for p in ref if p["type"] == t_]
        gg = np.array(g_by.get(t_, []))
        if not check(len(gg) == len(rr), "%s: %d instances of %s, props.json has %d" % (tag, len(gg), t_, len(rr))):
            continue
        rp = np.array([(p["x_m"], -p["z_m"], p["y_m"]) for p in rr])
        gp = gg[:, :3, 3]
        near = np.empty(len(rp), dtype=int)
        for a in range(0, len(rp), 512):
            d2 = ((rp[a:a + 512, None, :] - gp[None, :, :]) ** 2).sum(-1)
            near[a:a + 512] = d2.argmin(1)
        check(len(np.unique(near)) == len(rp), "%s: every %s instance matches one props.json entry" % (tag, t_))
        perr = max(perr, np.abs(rp - gp[near]).max())
        gm = gg[near]
        serr = max(serr, np.abs(np.array([p["scale"] for p in rr]) - np.linalg.norm(gm[:, :3, 0], axis=1)).max())
        ra = np.radians([p["rotation_deg"] for p in rr])
        ga = np.arctan2(gm[:, 1, 0], gm[:, 0, 0])
        aerr = max(aerr, np.abs((ra - ga + np.pi) % (2 * np.pi) - np.pi).max())
        matched += len(rr)
    check(matched == len(ref), "%s: instances of every prop type" % tag)
    check(perr < 0.01, "%s: prop positions match props.json (max error %.4g m)" % (tag, perr))
    check(serr < 6e-4, "%s: prop scales match props.json (max error %.3g)" % (tag, serr))
    check(aerr < 1e-4, "%s: prop rotations about Z match props.json (max error %.3g rad)" % (tag, aerr))
    g = [m for _, m in got]
    up = np.array([m[:3, 2] / np.linalg.norm(m[:3, 2]) for m in g])
    check(np.abs(up[:, 2] - 1).max() < 1e-5, "%s: props stand upright" % tag)


def check_sea(tag, hj):
    sea = bpy.data.objects.get("Relief Sea")
    if not check(sea is not None, "%s: sea plane exists" % tag):
        return
    z = [(sea.matrix_world @ v.co).z for v in sea.data.vertices]
    check(max(abs(v - hj["sea_level_m"]) for v in z) < 1e-6, "%s: the sea plane is at sea level (%s m)" % (tag, hj["sea_level_m"]))
    xs = [v.co.x for v in sea.data.vertices]
    check(abs(max(xs) - min(xs) - hj["width_m"]) < 1e-3, "%s: the sea plane covers the terrain" % tag)


def check_water(tag, out):
    rivers_path = os.path.join(out, "rivers.json")
    nriv = len(load_json(rivers_path)["rivers"]) if os.path.exists(rivers_path) else 0
    ob = bpy.data.objects.get("Relief Rivers")
    got = len(ob.data.splines) if ob else 0
    check(got == nriv, "%s: %d river curves, rivers.json has %d" % (tag, got, nriv))
    lakes_path = os.path.join(out, "lakes.json")
    lakes = load_json(lakes_path)["lakes"] if os.path.exists(lakes_path) else []
    obs = sorted((o for o in bpy.data.objects if o.get("relief_role") == "lake"), key=lambda o: o.name)
    check(len(obs) == len(lakes), "%s: %d lake meshes, lakes.json has %d" % (tag, len(obs), len(lakes)))
    for o, k in zip(obs, lakes):
        z = vertices(o)[:, 2]
        lvl = k.get("level_m", k.get("water_level_m"))
        check(np.abs(z - lvl).max() < 1e-3, "%s: %s is flat at its level %.3f m" % (tag, o.name, lvl))
    return nriv, len(lakes)


def run_case(preset, size):
    tag = "%s %d²" % (preset, size)
    t0 = time.perf_counter()
    out = cli(os.path.join(WORK, "%s-%d" % (preset, size)), "--preset", preset, "--size", str(size))
    t1 = time.perf_counter()
    s.preset = preset
    s.seed = SEED
    check(bpy.ops.relief.preview(size=size) == {"FINISHED"}, "%s: preview runs" % tag)
    t2 = time.perf_counter()
    obs = terrain_objects()
    if check(len(obs) == 1, "%s: one terrain object (got %d)" % (tag, len(obs))):
        me = obs[0].data
        check(len(me.vertices) == size * size, "%s: %d vertices (expected %d)" % (tag, len(me.vertices), size * size))
        check(len(me.polygons) == (size - 1) ** 2, "%s: %d faces (expected %d)" % (tag, len(me.polygons), (size - 1) ** 2))
        check(obs[0].name in bpy.data.collections["Relief"].objects, "%s: the terrain is in collection Relief" % tag)
        hj = check_heights(tag, obs[0], out, size)
        check_sea(tag, hj)
        check_texture_placement(tag, obs[0], size, hj["metres_per_pixel"])
    check_albedo(tag, out)
    check_props(tag, out)
    check_water(tag, out)
    print("%s: CLI %.2f s, add-on %.2f s (%s)" % (tag, t1 - t0, t2 - t1, s.status), flush=True)


# ---- the table: every parameter has a widget with its help text ----------------------------
table = core.relief.explain()
s.preset = "island"
missing = []
for st in table["stages"]:
    item = bpy.types.Scene.bl_rna.properties["relief"].fixed_type.properties["stages"].fixed_type
    group = item.properties.get("p_" + st["name"])
    if group is None:
        missing.append(st["name"])
        continue
    rna = group.fixed_type.properties
    for p in st["params"]:
        prop = rna.get("v_" + p["name"])
        if prop is None or not prop.description.startswith(p.get("description", "")[:40]):
            missing.append("%s.%s" % (st["name"], p["name"]))
check(not missing, "every parameter of relief.explain() has a widget with its help text (missing: %s)" % missing[:8])
check([it.kind for it in s.stages] == [x["stage"] for x in core.relief.preset("island")["stages"]],
      "the island preset's stages are listed")

# ---- the panels draw (a recording layout: background Blender has no UI to draw into) ----------
class Layout:
    """Stands in for bpy.types.UILayout: checks that every prop() names a property of its data
    and every operator() a registered operator, and counts them."""
    props, ops, labels = [], [], []

    def __getattr__(self, name):  # row(), column(), box(), split(), …
        if name in ("use_property_split", "use_property_decorate", "enabled", "active", "alignment"):
            raise AttributeError(name)
        return lambda *a, **k: Layout()

    def prop(self, data, name, **kw):
        ok = name in data.bl_rna.properties
        check(ok, "panel draws an existing property %s.%s" % (type(data).__name__, name))
        Layout.props.append(name)

    def operator(self, idname, **kw):
        cat, op = idname.split(".")
        check(hasattr(getattr(bpy.ops, cat), op) and getattr(getattr(bpy.ops, cat), op).poll is not None,
              "panel draws a registered operator %s" % idname)
        Layout.ops.append(idname)
        return type("OpProps", (), {})()

    def label(self, text="", **kw):
        Layout.labels.append(text)


class Panel:
    layout = Layout()


from relief_blender import ui  # noqa: E402
s.preset = "volcanic-island"
for cls in ui.classes:
    if hasattr(cls, "poll") and not cls.poll(bpy.context):
        continue
    for fn in ("draw_header", "draw_header_preset", "draw"):
        if hasattr(cls, fn):
            getattr(cls, fn)(Panel(), bpy.context)
nparams = sum(len(core.stage_specs(x["stage"])) for x in core.relief.preset("volcanic-island")["stages"])
check(len([p for p in Layout.props if p.startswith("v_")]) == nparams + len(core.world_specs()),
      "the panels draw every parameter of the recipe's stages and the world (%d of %d)" % (
          len([p for p in Layout.props if p.startswith("v_")]), nparams + len(core.world_specs())))
check(any(l.startswith("3. biomes") for l in Layout.labels), "stage sub-panels are titled by index and stage")
for op in ("relief.preview", "relief.bake", "relief.random_seed", "relief.save_recipe", "relief.load_recipe"):
    check(op in Layout.ops, "the panel has %s" % op)
seed0 = s.seed
bpy.ops.relief.random_seed()
check(s.seed != seed0 or bpy.ops.relief.random_seed() and s.seed != seed0, "the random seed button changes the seed")

# ---- the four cases of the issue -----------------------------------------------------------
for preset in ("island", "volcanic-island"):
    for size in (129, 513):
        run_case(preset, size)

# ---- rivers and lakes: island plus a flow stage, loaded from a recipe file -----------------
recipe = core.relief.preset("island")
recipe["stages"].insert(3, {"stage": "flow"})
recipe_path = os.path.join(WORK, "island-flow.json")
with open(recipe_path, "w") as f:
    json.dump(recipe, f)
out = cli(os.path.join(WORK, "island-flow-129"), recipe_path, "--size", "129")
check(bpy.ops.relief.load_recipe(filepath=recipe_path) == {"FINISHED"}, "a recipe file loads")
check([it.kind for it in s.stages][3] == "flow", "the loaded recipe's flow stage is listed")
s.seed = SEED
bpy.ops.relief.preview(size=129)
nriv, nlakes = check_water("island+flow 129²", out)
check(nriv > 0 and nlakes > 0, "island+flow has rivers and lakes to compare (%d, %d)" % (nriv, nlakes))
check_heights("island+flow 129²", terrain_objects()[0], out, 129)

# ---- save: the CLI reads what the panel saves ----------------------------------------------
saved = os.path.join(WORK, "saved.json")
bpy.ops.relief.save_recipe(filepath=saved)
doc = load_json(saved)
check(doc.get("seed") == SEED and doc["stages"][3]["stage"] == "flow", "the saved recipe has the seed and the stages")

# ---- a widget edit equals the CLI's --set ---------------------------------------------------
s.preset = "island"
bpy.ops.relief.reset()
s.seed = SEED
g = s.stages[0].p_noise
g.v_octaves = 3
g.v_frequency = 3.7
check(json.loads(s.recipe_json)["stages"][0]["octaves"] == 3, "a widget edit lands in the recipe")
check(json.loads(s.recipe_json)["stages"][0]["frequency"] == 3.7, "a float widget writes the decimal typed (3.7)")
bpy.ops.relief.preview(size=129)
out = cli(os.path.join(WORK, "island-set-129"), "--preset", "island", "--size", "129", "--set", "stages[0].octaves=3",
          "--set", "stages[0].frequency=3.7")
check_heights("island octaves=3 frequency=3.7", terrain_objects()[0], out, 129)

# ---- Bake replaces the preview --------------------------------------------------------------
s.preset = "volcanic-island"
s.seed = SEED
bpy.ops.relief.preview(size=129)
check(bpy.ops.relief.bake(size=257) == {"FINISHED"}, "bake runs")
obs = terrain_objects()
check(len(obs) == 1 and len(obs[0].data.vertices) == 257 * 257, "bake replaced the preview terrain (%d objects)" % len(obs))
before = {k: len(getattr(bpy.data, k)) for k in ("objects", "meshes", "materials", "node_groups", "collections", "curves", "images")}
s.maps = True
bpy.ops.relief.preview(size=129)
bpy.ops.relief.bake(size=257)
after = {k: len(getattr(bpy.data, k)) for k in before}
check(after == before, "bake, preview, bake leaves no stray datablocks (%s -> %s)" % (before, after))
check(not [o.name for o in bpy.data.objects if "." in o.name[-4:]], "no duplicated object names (.001)")
out = cli(os.path.join(WORK, "volcanic-island-257"), "--preset", "volcanic-island", "--size", "257")
check_albedo("bake 257² (packed PNG)", out)
check_props("bake 257²", out)
check_heights("bake 257²", terrain_objects()[0], out, 257)
check_texture_placement("bake 257²", terrain_objects()[0], 257)
img = bpy.data.materials["Relief Terrain"].node_tree.nodes["Albedo"].image
check(img.packed_file is not None, "the baked albedo image is packed into the .blend")
maps = [n.image.name for n in bpy.data.materials["Relief Terrain"].node_tree.nodes if n.name.startswith("Relief map")]
check("Relief normal" in maps and any(m.startswith("Relief splat") for m in maps), "splat and normal maps are images (%s)" % maps)

# ---- chunks join ------------------------------------------------------------------------------
s.chunk_cells = 128
bpy.ops.relief.preview(size=257)
obs = terrain_objects()
check(len(obs) == 4, "257² with 128-cell chunks gives 4 chunk objects (got %d)" % len(obs))
pts = np.concatenate([vertices(o) for o in obs])
check(len(pts) == 4 * 129 * 129, "chunks have 129² vertices each")
whole = np.unique(np.round(pts[:, :2] / (4000 / 256)).astype(int), axis=0)
check(len(whole) == 257 * 257, "chunks cover every sample and share their borders")
s.chunk_cells = 1024

# ---- live preview: a widget edit schedules a threaded regeneration (the timer pumped by hand) ----
from relief_blender import live  # noqa: E402
s.preset = "island"
bpy.ops.relief.reset()
s.preview_size = 129
bpy.ops.relief.preview()
z0 = vertices(terrain_objects()[0])[:, 2].copy()
s.live = True
s.stages[0].p_noise.v_octaves = 2  # the update callback asks for a preview
check(bpy.app.timers.is_registered(live._tick), "a widget edit registers the live-preview timer")
deadline = time.time() + 30
while time.time() < deadline:
    nxt = live._tick()
    if nxt is None:
        break
    time.sleep(nxt)
s.live = False
obs = terrain_objects()
z1 = vertices(obs[0])[:, 2]
check(len(z1) == 129 * 129 and not np.array_equal(z0, z1), "the live preview rebuilt the terrain with the edit")
out = cli(os.path.join(WORK, "island-oct2-129"), "--preset", "island", "--size", "129", "--set", "stages[0].octaves=2")
check_heights("live preview octaves=2", obs[0], out, 129)

# ---- cancel: a long run on a thread stops when asked, leaving no result --------------------
job = core.Job(core.relief.preset("eroded-mountains"), SEED, 513).start()
time.sleep(0.2)
t_cancel = time.perf_counter()
job.cancel()
job.wait(60)
check(job.done and job.cancelled and job.result is None and job.error is None,
      "a cancelled job stops without a result (done %s, cancelled %s, error %s)" % (job.done, job.cancelled, job.error))
print("cancel took %.2f s" % (time.perf_counter() - t_cancel))

# ---- a broken recipe file is refused, naming the field; the recipe stays -----------------------
bad = os.path.join(WORK, "bad.json")
broken = core.relief.preset("island")
broken["stages"][0]["octaves"] = 40
with open(bad, "w") as f:
    json.dump(broken, f)
keep = s.recipe_json
try:
    r = bpy.ops.relief.load_recipe(filepath=bad)
except RuntimeError:
    r = {"CANCELLED"}
check(r == {"CANCELLED"} and "stages[0].octaves" in s.status, "a bad recipe is refused naming the field (%s)" % s.status)
check(s.recipe_json == keep, "a refused recipe leaves the current one")

finish("blender add-on tests")
