# Imports Relief's volume files with Blender's own importers and reports what Blender sees, as JSON.
# Run: blender -b --factory-startup --python-exit-code 1 --python blender_volume.py -- OUT.json CAVES.glb CAVES.vdb
# glb: the mesh objects (name, vertex and face counts, colour attributes); vdb: the volume object's
# type and its grids (name, value type, voxel count) after loading them.
import json
import sys

import numpy as np

# Debian's numpy removed np.bool, which Blender 3.4's glTF importer still uses.
if not hasattr(np, "bool") or np.bool is not bool:
    np.bool = bool

import bpy  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
out_path, glb, vdb = args[0], args[1], args[2]
report = {}

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=glb)
objects = []
for o in bpy.context.scene.objects:
    if o.type != "MESH":
        continue
    m = o.data
    objects.append({"name": o.name, "vertices": len(m.vertices), "faces": len(m.polygons),
                    "color_attributes": len(getattr(m, "color_attributes", getattr(m, "vertex_colors", [])))})
report["glb"] = {"objects": objects}

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.object.volume_import(filepath=vdb)
volumes = []
for o in bpy.context.scene.objects:
    entry = {"name": o.name, "type": o.type, "grids": []}
    if o.type == "VOLUME":
        v = o.data
        v.grids.load()
        entry["loaded"] = bool(v.grids.is_loaded)
        for g in v.grids:
            g.load()
            entry["grids"].append({"name": g.name, "data_type": g.data_type, "channels": g.channels,
                                   "is_loaded": bool(g.is_loaded)})
    volumes.append(entry)
report["vdb"] = {"objects": volumes}

with open(out_path, "w") as f:
    json.dump(report, f, indent=1)
