"""Builds the Relief result in a Blender scene (bpy), from a relief.Terrain and core's arrays.

Everything lands in one collection "Relief": the terrain (one object, or chunk objects "Relief
Terrain x<i>_y<j>" when a side exceeds the chunk size), the material "Relief Terrain" with the
albedo image (and, when asked, the splat and normal maps as images in the same node tree), the sea
plane at sea level (Z = 0), props as geometry-nodes instances of one collection per prop type
(rotation and scale per instance), rivers as one curve object (one spline per river) and lakes as
flat meshes. Rebuilding replaces what the previous build made (objects carry a "relief_role"
property); a terrain of the same size only gets its vertex positions rewritten.
"""
import os
import tempfile
import time

import bpy
import numpy as np

from . import core

ROOT = "Relief"
PROPS = "Relief Props"
PROTOS = "Relief Prop Types"
TERRAIN_MAT = "Relief Terrain"
ALBEDO = "Relief Albedo"


# ---- collections and housekeeping ------------------------------------------------------------
def _collection(name, parent):
    c = bpy.data.collections.get(name)
    if c is None:
        c = bpy.data.collections.new(name)
    if parent is not None and c.name not in parent.children:
        parent.children.link(c)
    return c


def root_collection(scene):
    c = bpy.data.collections.get(ROOT)
    if c is None:
        c = bpy.data.collections.new(ROOT)
    if c.name not in scene.collection.children:
        scene.collection.children.link(c)
    return c


def _exclude(scene, coll):
    """Excludes coll from the scene's view layers (prop models: used only through instances)."""
    def walk(lc):
        if lc.collection == coll:
            lc.exclude = True
            return True
        return any(walk(ch) for ch in lc.children)

    for vl in scene.view_layers:
        walk(vl.layer_collection)


def _remove_object(ob):
    data = ob.data
    bpy.data.objects.remove(ob, do_unlink=True)
    if data is not None and data.users == 0:
        if isinstance(data, bpy.types.Mesh):
            bpy.data.meshes.remove(data)
        elif isinstance(data, bpy.types.Curve):
            bpy.data.curves.remove(data)


def objects_with_role(role=None):
    return [o for o in bpy.data.objects if "relief_role" in o and (role is None or o["relief_role"] == role)]


def _link(ob, coll, role):
    ob["relief_role"] = role
    coll.objects.link(ob)
    return ob


# ---- terrain -----------------------------------------------------------------------------------
def _fill_mesh(me, pos, g, uvs):
    """A grid mesh from core.Grid topology: every array already has the dtype foreach_set copies
    directly (float32, uint32, bool), and the edges come with the topology, so Blender computes
    nothing but normals. `uvs` adds the UV layer (the bake; a preview's material maps the texture
    from object coordinates instead, which costs the mesh nothing)."""
    me.vertices.add(len(pos) // 3)
    me.vertices.foreach_set("co", pos)
    me.edges.add(len(g.edges) // 2)
    me.edges.foreach_set("vertices", g.edges)
    me.loops.add(len(g.loops))
    me.loops.foreach_set("vertex_index", g.loops)
    me.loops.foreach_set("edge_index", g.loop_edges)
    me.polygons.add(g.faces)
    me.polygons.foreach_set("loop_start", g.loop_start)
    me.polygons.foreach_set("loop_total", g.loop_total)
    me.polygons.foreach_set("use_smooth", g.smooth)
    if uvs:
        me.uv_layers.new(name="UVMap").data.foreach_set("uv", g.loop_uvs)
    me.update()


def _chunk_uvs(g, window, nx, nz):
    """UVs of a chunk in the whole terrain's texture space."""
    i0, i1, j0, j1 = window
    if (i0, i1, j0, j1) == (0, nx - 1, 0, nz - 1):
        return g.loop_uvs
    sub = g.loop_uvs.reshape(-1, 2).copy()
    w, h = (i1 - i0), (j1 - j0)
    # local u = i/(w), v = 1 - j/h  ->  global u = (i0 + i)/(nx-1), v = 1 - (j0 + j)/(nz-1)
    sub[:, 0] = (i0 + sub[:, 0] * w) / (nx - 1)
    sub[:, 1] = 1.0 - (j0 + (1.0 - sub[:, 1]) * h) / (nz - 1)
    return np.ascontiguousarray(sub.reshape(-1), dtype=np.float32)


def build_terrain(scene, coll, t, chunk_cells, material, uvs=True):
    f = t.frame
    nx, nz = f["nx"], f["nz"]
    windows = core.chunks(nx, nz, chunk_cells)
    names = ["Relief Terrain"] if len(windows) == 1 else \
        ["Relief Terrain x%d_y%d" % (w[0] // chunk_cells, w[2] // chunk_cells) for w in windows]
    old = {o.name: o for o in objects_with_role("terrain")}
    reuse = set(old) == set(names) and all(
        len(old[n].data.vertices) == (w[1] - w[0] + 1) * (w[3] - w[2] + 1) and old[n].get("relief_window") == list(w)
        for n, w in zip(names, windows))
    if not reuse:
        for o in old.values():
            _remove_object(o)
    obs = []
    for name, w in zip(names, windows):
        pos = core.positions(t, w)
        g = core.grid(w[1] - w[0] + 1, w[3] - w[2] + 1)
        if reuse:
            ob = old[name]
            ob.data.vertices.foreach_set("co", pos)
            if uvs and len(ob.data.uv_layers) == 0:
                ob.data.uv_layers.new(name="UVMap").data.foreach_set("uv", _chunk_uvs(g, w, nx, nz))
            ob.data.update()
        else:
            me = bpy.data.meshes.new(name)
            _fill_mesh(me, pos, g, uvs and len(windows) == 1)
            if uvs and len(windows) > 1:
                me.uv_layers.new(name="UVMap").data.foreach_set("uv", _chunk_uvs(g, w, nx, nz))
            ob = _link(bpy.data.objects.new(name, me), coll, "terrain")
            ob["relief_window"] = list(w)
        if material is not None:
            if len(ob.data.materials) == 0:
                ob.data.materials.append(material)
            else:
                ob.data.materials[0] = material
        obs.append(ob)
    return obs


# ---- material and images -------------------------------------------------------------------
def _image(name, nx, nz, is_data=False):
    img = bpy.data.images.get(name)
    if img is not None and (img.size[0] != nx or img.size[1] != nz or img.is_float):
        bpy.data.images.remove(img)
        img = None
    if img is None:
        img = bpy.data.images.new(name, nx, nz, alpha=False, float_buffer=False, is_data=is_data)
    return img


def _image_from_png(name, data, non_color=False):
    """An image datablock holding PNG bytes written by the library (packed, so the .blend keeps it)."""
    old = bpy.data.images.get(name)
    if old is not None:
        bpy.data.images.remove(old)
    fd, path = tempfile.mkstemp(suffix=".png", prefix="relief-")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        img = bpy.data.images.load(path)
        img.name = name
        img.pack()
        img.filepath = "//" + name.replace(" ", "_") + ".png"
    finally:
        os.unlink(path)
    if non_color:
        img.colorspace_settings.name = "Non-Color"
    return img


def terrain_material(t, maps, packed=False, uvs=True):
    """The material "Relief Terrain": Principled BSDF with the albedo image as base colour; with
    maps, the normal map and splat weight images (from the library's writers) as image nodes
    beside it. The albedo image is filled from the layer (preview: fastest), or with `packed` is
    the library's albedo.png itself, packed into the .blend (bake: the file's bytes, saved with
    the scene). With `uvs` the image is mapped through the mesh's UVs, otherwise from object
    coordinates by a Mapping node (u = (X - x0)/width, v = 1 + (Y + z0)/depth: the same texture
    placement as the UVs). Returns (material, albedo image or None)."""
    mat = bpy.data.materials.get(TERRAIN_MAT)
    if mat is None:
        mat = bpy.data.materials.new(TERRAIN_MAT)
        mat.use_nodes = True
    nt = mat.node_tree
    bsdf = next((n for n in nt.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is None:
        bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = 0.9
    tex = nt.nodes.get("Albedo")
    if tex is None:
        tex = nt.nodes.new("ShaderNodeTexImage")
        tex.name = tex.label = "Albedo"
        tex.location = (-400, 300)
        nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    f = t.frame
    tc = nt.nodes.get("Relief texcoord") or nt.nodes.new("ShaderNodeTexCoord")
    tc.name, tc.location = "Relief texcoord", (-900, 300)
    mp = nt.nodes.get("Relief placement") or nt.nodes.new("ShaderNodeMapping")
    mp.name, mp.location, mp.vector_type = "Relief placement", (-650, 300), "POINT"
    if uvs:
        mp.inputs["Location"].default_value = (0.0, 0.0, 0.0)
        mp.inputs["Scale"].default_value = (1.0, 1.0, 1.0)
    else:
        x0, z0 = f["ix0"] * f["cell_m"], f["iz0"] * f["cell_m"]
        mp.inputs["Location"].default_value = (-x0 / f["width_m"], 1.0 + z0 / f["depth_m"], 0.0)
        mp.inputs["Scale"].default_value = (1.0 / f["width_m"], 1.0 / f["depth_m"], 1.0)
    nt.links.new(tc.outputs["UV" if uvs else "Object"], mp.inputs["Vector"])
    nt.links.new(mp.outputs["Vector"], tex.inputs["Vector"])
    img = None
    if core.colour_layer(t) is not None:
        if packed:
            img = _image_from_png(ALBEDO, t.encode("albedo.png"))
        else:
            if bpy.data.images.get(ALBEDO) is not None and bpy.data.images[ALBEDO].packed_file is not None:
                bpy.data.images.remove(bpy.data.images[ALBEDO])
            img = _image(ALBEDO, f["nx"], f["nz"])
            img.pixels.foreach_set(core.albedo_rgba(t))
            img.update()
    tex.image = img
    for n in [n for n in nt.nodes if n.name.startswith("Relief map")]:
        nt.nodes.remove(n)
    if maps:
        y = -50
        files = {"normal.png": t.encode("normal.png")}
        splat = t.encode("splat")
        if isinstance(splat, dict):
            files.update({k: v for k, v in splat.items() if k.endswith(".png")})
        for fname in sorted(files):
            name = "Relief " + fname[:-4]
            im = _image_from_png(name, files[fname], non_color=True)
            node = nt.nodes.new("ShaderNodeTexImage")
            node.name = "Relief map " + fname
            node.label = fname
            node.image = im
            node.location = (-700, y)
            y -= 280
    return mat, img


def _flat_material(name, rgba, alpha=1.0, roughness=0.1):
    mat = bpy.data.materials.get(name)
    if mat is None:
        mat = bpy.data.materials.new(name)
        mat.use_nodes = True
        bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
        bsdf.inputs["Base Color"].default_value = rgba
        bsdf.inputs["Roughness"].default_value = roughness
        bsdf.inputs["Alpha"].default_value = alpha
        mat.diffuse_color = rgba[:3] + (alpha,)
        if alpha < 1.0:
            mat.blend_method = "BLEND"
    return mat


# ---- sea, rivers, lakes ----------------------------------------------------------------------
def build_sea(coll, t):
    f = t.frame
    x0 = f["ix0"] * f["cell_m"]
    z0 = f["iz0"] * f["cell_m"]
    x1, z1 = x0 + f["width_m"], z0 + f["depth_m"]
    me = bpy.data.meshes.new("Relief Sea")
    me.from_pydata([(x0, -z0, 0.0), (x0, -z1, 0.0), (x1, -z1, 0.0), (x1, -z0, 0.0)], [], [(0, 1, 2, 3)])
    me.materials.append(_flat_material("Relief Sea", (0.05, 0.22, 0.42, 1.0), alpha=0.75))
    ob = _link(bpy.data.objects.new("Relief Sea", me), coll, "sea")
    ob["relief_sea_level"] = f["sea_level"]
    return ob


def build_rivers(coll, t):
    rivers = core.river_polylines(t)
    if not rivers:
        return None
    cu = bpy.data.curves.new("Relief Rivers", "CURVE")
    cu.dimensions = "3D"
    cu.bevel_depth = 1.0
    cu.bevel_resolution = 0
    cu.use_fill_caps = False
    for pts, widths, order in rivers:
        sp = cu.splines.new("POLY")
        sp.points.add(len(pts) - 1)
        co = np.ones((len(pts), 4), dtype=np.float32)
        co[:, :3] = pts
        sp.points.foreach_set("co", co.reshape(-1))
        sp.points.foreach_set("radius", np.ascontiguousarray(widths * 0.5, dtype=np.float32))
    cu.materials.append(_flat_material("Relief Water", (0.12, 0.35, 0.6, 1.0)))
    return _link(bpy.data.objects.new("Relief Rivers", cu), coll, "rivers")


def build_lakes(coll, t):
    obs = []
    mat = None
    for k, (verts, quads) in enumerate(core.lake_patches(t)):
        me = bpy.data.meshes.new("Relief Lake %03d" % k)
        me.vertices.add(len(verts))
        me.vertices.foreach_set("co", verts.reshape(-1))
        me.loops.add(quads.size)
        me.loops.foreach_set("vertex_index", np.ascontiguousarray(quads.reshape(-1), dtype=np.uint32))
        me.polygons.add(len(quads))
        me.polygons.foreach_set("loop_start", np.arange(0, quads.size, 4, dtype=np.uint32))
        me.polygons.foreach_set("loop_total", np.full(len(quads), 4, dtype=np.uint32))
        me.update(calc_edges=True)
        mat = mat or _flat_material("Relief Water", (0.12, 0.35, 0.6, 1.0))
        me.materials.append(mat)
        obs.append(_link(bpy.data.objects.new("Relief Lake %03d" % k, me), coll, "lake"))
    return obs


# ---- props ---------------------------------------------------------------------------------
# Low-poly stand-ins per prop type (metres): (kind, height, radius, colour). Unknown types get a
# cone. Swap the object in collection "Relief prop: TYPE" for your own model; instances follow.
PROP_LOOK = {
    "tree": ("tree", 8.0, 2.6, (0.16, 0.38, 0.12, 1)),
    "pine": ("cone", 11.0, 2.2, (0.10, 0.28, 0.14, 1)),
    "bush": ("blob", 1.4, 1.2, (0.25, 0.45, 0.16, 1)),
    "rock": ("blob", 1.6, 1.5, (0.45, 0.43, 0.40, 1)),
    "cactus": ("column", 3.5, 0.35, (0.30, 0.50, 0.25, 1)),
    "mushroom": ("tree", 0.5, 0.3, (0.75, 0.20, 0.15, 1)),
}


def _proto_mesh(name, look):
    kind, h, r, rgba = look
    verts, faces = [], []
    n = 8
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False)

    def ring(z, rad):
        base = len(verts)
        verts.extend((float(rad * np.cos(a)), float(rad * np.sin(a)), z) for a in ang)
        return base

    def cone(z0, z1, rad):
        b = ring(z0, rad)
        verts.append((0.0, 0.0, z1))
        tip = len(verts) - 1
        faces.extend((b + k, b + (k + 1) % n, tip) for k in range(n))
        faces.append(tuple(b + k for k in reversed(range(n))))

    if kind in ("tree", "cone"):
        trunk = 0.25 * h if kind == "tree" else 0.12 * h
        b0, b1 = ring(0.0, r * 0.12), ring(trunk, r * 0.12)
        faces.extend((b0 + k, b0 + (k + 1) % n, b1 + (k + 1) % n, b1 + k) for k in range(n))
        cone(trunk, h, r)
    elif kind == "column":
        b0, b1 = ring(0.0, r), ring(h, r)
        faces.extend((b0 + k, b0 + (k + 1) % n, b1 + (k + 1) % n, b1 + k) for k in range(n))
        faces.append(tuple(b1 + k for k in range(n)))
    else:  # blob: a squashed octahedron-ish double cone
        b = ring(h * 0.4, r)
        verts.append((0.0, 0.0, h))
        verts.append((0.0, 0.0, -0.1 * h))
        top, bot = len(verts) - 2, len(verts) - 1
        faces.extend((b + k, b + (k + 1) % n, top) for k in range(n))
        faces.extend((b + (k + 1) % n, b + k, bot) for k in range(n))
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.materials.append(_flat_material("Relief prop " + name, rgba, roughness=0.8))
    return me


def _prop_collection(scene, protos, ptype):
    name = "Relief prop: " + ptype
    c = bpy.data.collections.get(name)
    if c is None:
        c = bpy.data.collections.new(name)
    if c.name not in protos.children:
        protos.children.link(c)
    if len(c.objects) == 0:
        look = PROP_LOOK.get(ptype, ("cone", 3.0, 1.0, (0.5, 0.5, 0.5, 1)))
        ob = bpy.data.objects.new("Relief model: " + ptype, _proto_mesh(ptype, look))
        ob["relief_role"] = "prop_model"
        c.objects.link(ob)
    return c


def _instancer_tree(ptype, coll):
    """Geometry nodes: the points of the object instance collection `coll`, rotated about Z by the
    point attribute relief_rot and scaled by relief_scale."""
    name = "Relief instances: " + ptype
    ng = bpy.data.node_groups.get(name)
    if ng is not None:
        ng.nodes["Collection Info"].inputs["Collection"].default_value = coll
        return ng
    ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
    ng.inputs.new("NodeSocketGeometry", "Geometry")
    ng.outputs.new("NodeSocketGeometry", "Geometry")
    n = ng.nodes
    gi, go = n.new("NodeGroupInput"), n.new("NodeGroupOutput")
    inst = n.new("GeometryNodeInstanceOnPoints")
    ci = n.new("GeometryNodeCollectionInfo")
    ci.name = "Collection Info"
    ci.transform_space = "ORIGINAL"
    ci.inputs["Collection"].default_value = coll
    ci.inputs["Separate Children"].default_value = False
    ci.inputs["Reset Children"].default_value = True
    links = ng.links
    links.new(gi.outputs[0], inst.inputs["Points"])
    links.new(ci.outputs[0], inst.inputs["Instance"])
    for attr, sock in (("relief_rot", "Rotation"), ("relief_scale", "Scale")):
        na = n.new("GeometryNodeInputNamedAttribute")
        na.data_type = "FLOAT_VECTOR"
        na.inputs["Name"].default_value = attr
        out = next(s for s in na.outputs if s.enabled)
        links.new(out, inst.inputs[sock])
    links.new(inst.outputs[0], go.inputs[0])
    return ng


def build_props(scene, root, t):
    groups = core.props_by_type(t)
    props = _collection(PROPS, root)
    protos = _collection(PROTOS, root)
    _exclude(scene, protos)
    obs = []
    for ptype, (pos, rot, scale) in groups.items():
        pc = _prop_collection(scene, protos, ptype)
        name = "Relief Props: " + ptype
        me = bpy.data.meshes.new(name)
        me.vertices.add(len(pos))
        me.vertices.foreach_set("co", np.ascontiguousarray(pos.reshape(-1)))
        r = np.zeros((len(pos), 3), dtype=np.float32)
        r[:, 2] = rot
        s = np.repeat(scale[:, None], 3, axis=1).astype(np.float32)
        me.attributes.new("relief_rot", "FLOAT_VECTOR", "POINT").data.foreach_set("vector", r.reshape(-1))
        me.attributes.new("relief_scale", "FLOAT_VECTOR", "POINT").data.foreach_set("vector", s.reshape(-1))
        me.update()
        ob = _link(bpy.data.objects.new(name, me), props, "props")
        ob["relief_prop_type"] = ptype
        mod = ob.modifiers.new("Relief instances", "NODES")
        mod.node_group = _instancer_tree(ptype, pc)
        obs.append(ob)
    return obs


# ---- the whole result ------------------------------------------------------------------------
def clear(keep_terrain=False):
    """Removes what a previous build made (the terrain too unless keep_terrain)."""
    for ob in objects_with_role():
        role = ob["relief_role"]
        if role == "prop_model" or (keep_terrain and role == "terrain"):
            continue
        _remove_object(ob)


def build(scene, t, chunk_cells=1024, maps=False, props=True, pack=False):
    """Builds (or replaces) the scene's Relief collection from terrain t: `maps` adds the splat
    and normal map images; `pack` is the bake: the albedo image is albedo.png packed into the
    .blend and the mesh gets UVs; otherwise (the preview) pixels are filled from the layer and the
    texture is mapped from object coordinates. Returns timings (s)."""
    tm = {}
    t0 = time.perf_counter()
    root = root_collection(scene)
    clear(keep_terrain=True)
    mat, img = terrain_material(t, maps, packed=pack, uvs=pack)
    tm["material"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    build_terrain(scene, root, t, chunk_cells, mat, uvs=pack)
    tm["terrain"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    build_sea(root, t)
    build_rivers(root, t)
    build_lakes(root, t)
    if props:
        build_props(scene, root, t)
    tm["rest"] = time.perf_counter() - t1
    f = t.frame
    root["relief_size"] = [f["nx"], f["nz"]]
    root["relief_seed"] = t.seed
    tm["build"] = time.perf_counter() - t0
    return tm


def widen_clip(context, extent_m):
    """Lets the 3D views see a terrain kilometres wide (the default clip end is 1 km)."""
    try:
        screen = context.screen
    except AttributeError:
        return
    if screen is None:
        return
    for area in screen.areas:
        if area.type == "VIEW_3D":
            for sp in area.spaces:
                if sp.type == "VIEW_3D" and sp.clip_end < extent_m * 3:
                    sp.clip_end = extent_m * 3
