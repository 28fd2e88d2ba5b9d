# Imports Relief's meshes with Blender's own importers and reports what Blender sees, as JSON.
# Run: blender -b --factory-startup --python-exit-code 1 --python blender_check.py -- OUT.json FILE…
# For every file: mesh objects (name, mesh data name, vertex and face counts, UV layers, colour
# attributes, world-space bounds), the UV at the terrain corner (min x, our z-min edge), images
# (size, whether Blender has its pixels, the top-left pixel) and materials using an image.
import json
import sys

import numpy as np

# Debian's numpy removed np.bool, which Blender 3.4's glTF importer still uses.
if not hasattr(np, "bool") or np.bool is not bool:
    np.bool = bool

import bpy  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
out_path, files = args[0], args[1:]
report = {}


def import_file(path):
    if path.endswith(".glb"):
        bpy.ops.import_scene.gltf(filepath=path)
    elif path.endswith(".fbx"):
        bpy.ops.import_scene.fbx(filepath=path)
    elif path.endswith(".obj"):
        if hasattr(bpy.ops.wm, "obj_import"):
            bpy.ops.wm.obj_import(filepath=path)
        else:
            bpy.ops.import_scene.obj(filepath=path)
    else:
        raise RuntimeError("unknown format: " + path)


for path in files:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    import_file(path)
    objects = []
    corner = None
    # The terrain corner at min x on our z-min edge (Blender's max y); vertex jiggle moves it a
    # little, so take the vertex nearest to that corner of the terrain's bounds.
    terrain_co = [ob.matrix_world @ v.co for ob in bpy.data.objects if ob.type == "MESH" and ob.name.startswith("terrain")
                  for v in ob.data.vertices]
    xmin = min(c[0] for c in terrain_co) if terrain_co else 0
    ymax = max(c[1] for c in terrain_co) if terrain_co else 0
    for ob in bpy.data.objects:
        if ob.type != "MESH":
            continue
        me = ob.data
        mw = ob.matrix_world
        co = [mw @ v.co for v in me.vertices]
        entry = {
            "name": ob.name,
            "mesh": me.name,
            "vertices": len(me.vertices),
            "faces": len(me.polygons),
            "triangles": sum(1 for p in me.polygons if len(p.vertices) == 3),
            "uv_layers": len(me.uv_layers),
            "color_attributes": len(me.color_attributes) if hasattr(me, "color_attributes") else len(me.vertex_colors),
            "min": [min(c[k] for c in co) for k in range(3)] if co else None,
            "max": [max(c[k] for c in co) for k in range(3)] if co else None,
            "materials": [m.name for m in me.materials if m],
        }
        if me.uv_layers:
            uv = me.uv_layers.active.data
            us = [d.uv[0] for d in uv]
            vs = [d.uv[1] for d in uv]
            entry["uv_min"] = [min(us), min(vs)]
            entry["uv_max"] = [max(us), max(vs)]
            # Our z-min edge is Blender's max y (Y-up files are turned Z-up: y_blender = -z).
            for loop in me.loops:
                p = co[loop.vertex_index]
                key = (p[0] - xmin) ** 2 + (p[1] - ymax) ** 2
                if corner is None or key < corner[0]:
                    corner = (key, list(uv[loop.index].uv))
        if hasattr(me, "color_attributes") and len(me.color_attributes):
            attr = me.color_attributes[0]
            vals = [tuple(d.color)[:3] for d in attr.data]
            entry["color_min"] = [min(v[k] for v in vals) for k in range(3)]
            entry["color_max"] = [max(v[k] for v in vals) for k in range(3)]
        objects.append(entry)
    images = []
    for im in bpy.data.images:
        if im.type != "IMAGE":
            continue
        w, h = im.size
        has = w > 0 and h > 0 and len(im.pixels) == w * h * im.channels
        top_left = None
        if has:
            px = im.pixels[((h - 1) * w) * im.channels:((h - 1) * w) * im.channels + 3]  # rows are stored bottom-up
            top_left = [round(x * 255) for x in px]
        images.append({"name": im.name, "size": [w, h], "has_pixels": has, "packed": im.packed_file is not None,
                       "top_left": top_left})
    textured_materials = []
    for mat in bpy.data.materials:
        if mat.use_nodes and any(n.type == "TEX_IMAGE" and n.image for n in mat.node_tree.nodes):
            textured_materials.append(mat.name)
    report[path] = {"objects": objects, "images": images, "textured_materials": textured_materials,
                    "corner_uv": corner[1] if corner else None}

with open(out_path, "w") as f:
    json.dump(report, f, indent=1)
print("blender_check: wrote", out_path)
