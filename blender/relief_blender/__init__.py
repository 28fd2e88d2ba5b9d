"""Relief for Blender: procedural terrain from a seed and a recipe, through the compiled `relief`
module (bundled in this add-on). The 3D view's sidebar has a "Relief" tab.

Layout: core.py holds everything that does not need Blender (the parameter table as widget specs,
the recipe being edited, generation on a thread, the arrays a DCC builds its scene from) so another
DCC's panel (Maya) can reuse it; props.py, ui.py, ops.py, live.py and scene.py are the Blender layer.
"""
bl_info = {
    "name": "Relief",
    "author": "Relief",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "3D View > Sidebar > Relief",
    "description": "Procedural terrain from a seed and a recipe: live preview, bake, props, rivers, lakes",
    "category": "Add Mesh",
}

import bpy

from . import core, live, ops, props, scene, ui

_classes = list(ops.classes) + list(ui.classes)


@bpy.app.handlers.persistent
def _init_scenes(*_):
    """Gives every scene the selected preset's recipe, so the panel shows its stages at once
    (a panel's draw may not write to the scene)."""
    for scn in bpy.data.scenes:
        try:
            props.ensure_recipe(scn)
        except Exception as e:  # never break file loading
            print("relief_blender:", e)
    return None


def register():
    props.register()
    for c in _classes:
        bpy.utils.register_class(c)
    bpy.app.handlers.load_post.append(_init_scenes)
    bpy.app.timers.register(_init_scenes, first_interval=0.0)


def unregister():
    live.cancel()
    if _init_scenes in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_init_scenes)
    if bpy.app.timers.is_registered(_init_scenes):
        bpy.app.timers.unregister(_init_scenes)
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
    props.unregister()
