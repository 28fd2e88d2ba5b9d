"""Blender properties generated from the parameter table (bpy).

At register time, one PropertyGroup per stage of `relief.explain()` gets one property per
parameter (float, int, bool, enum, string, colour; lists, colour levels and curves as JSON text),
with the table's default, range and help text (the tooltip). A recipe stage is an item of
`scene.relief.stages` whose pointer `p_<stage>` holds its values. The recipe itself is stored as
JSON in `scene.relief.recipe_json` (the source of truth: values never touched stay as the preset
wrote them); editing a widget writes that one value into it and asks for a preview.
"""
import re

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, FloatVectorProperty,
                       IntProperty, PointerProperty, StringProperty)

from . import core

_classes = []
_syncing = [False]
_preset_items = []
_stage_re = re.compile(r"stages\[(\d+)\]")


def settings(context_or_scene):
    scene = getattr(context_or_scene, "scene", context_or_scene)
    return scene.relief


def _request_preview(context):
    from . import live
    live.request(context.scene if context and getattr(context, "scene", None) else bpy.context.scene)


def _prop_for(spec, update):
    kw = dict(name=spec.name.replace("_", " "), description=spec.description, update=update)
    k = spec.kind
    if k == "float":
        kw["default"] = spec.default
        if spec.min is not None:
            kw["min"] = float(spec.min)
        if spec.max is not None:
            kw["max"] = float(spec.max)
        sr = spec.soft_range()
        if sr:
            kw["soft_min"], kw["soft_max"] = float(sr[0]), float(sr[1])
        d = abs(spec.default)
        kw["precision"] = 5 if (0 < d < 0.01) else 3
        kw["step"] = 1 if (spec.max is not None and spec.min is not None and spec.max - spec.min <= 2) else 10
        return FloatProperty(**kw)
    if k == "int":
        lo = int(max(spec.min if spec.min is not None else -core.MAX_UI_INT, -core.MAX_UI_INT))
        hi = int(min(spec.max if spec.max is not None else core.MAX_UI_INT, core.MAX_UI_INT))
        return IntProperty(default=max(lo, min(hi, spec.default)), min=lo, max=hi, **kw)
    if k == "bool":
        return BoolProperty(default=spec.default, **kw)
    if k == "enum":
        items = [(c, c, spec.description) for c in spec.choices] or [(spec.default, spec.default, "")]
        return EnumProperty(items=items, default=spec.default, **kw)
    if k == "color":
        return FloatVectorProperty(subtype="COLOR_GAMMA", size=3, min=0.0, max=1.0, default=spec.default, **kw)
    return StringProperty(default=spec.default, **kw)


def _stage_update(pname):
    def update(self, context):
        if _syncing[0]:
            return
        m = _stage_re.search(self.path_from_id())
        if not m:
            return
        s = settings(context)
        doc = core.RecipeDoc.from_json(s.recipe_json)
        try:
            doc.set_param(int(m.group(1)), pname, getattr(self, "v_" + pname))
        except ValueError as e:
            s.status = str(e)
            return
        s.recipe_json = doc.to_json()
        _request_preview(context)
    return update


def _world_update(pname):
    def update(self, context):
        if _syncing[0]:
            return
        s = settings(context)
        doc = core.RecipeDoc.from_json(s.recipe_json)
        doc.set_world(pname, getattr(self, "v_" + pname))
        s.recipe_json = doc.to_json()
        _request_preview(context)
    return update


def _make_group(clsname, specs, make_update):
    ann = {"v_" + p.name: _prop_for(p, make_update(p.name)) for p in specs}
    return type(clsname, (bpy.types.PropertyGroup,), {"__annotations__": ann})


def _preset_enum(self, context):
    if not _preset_items:
        for name, desc in core.presets():
            _preset_items.append((name, name, desc))
    return _preset_items


def _on_preset(self, context):
    if _syncing[0]:
        return
    load_recipe(self, core.RecipeDoc.from_preset(self.preset))
    _request_preview(context)


def _on_setting(self, context):
    if not _syncing[0]:
        _request_preview(context)


def load_recipe(s, doc, seed=None):
    """Makes `doc` (a core.RecipeDoc) the scene's recipe and fills every widget from it."""
    _syncing[0] = True
    try:
        if seed is None and isinstance(doc.doc.get("seed"), int) and 0 <= doc.doc["seed"] <= core.SEED_MAX:
            seed = doc.doc["seed"]
        doc.doc.pop("seed", None)  # the seed widget holds it
        s.recipe_json = doc.to_json()
        if seed is not None:
            s.seed = seed
        wv = doc.world_values()
        for p in core.world_specs():
            setattr(s.world, "v_" + p.name, wv[p.name])
        s.stages.clear()
        for i, st in enumerate(doc.stages):
            item = s.stages.add()
            item.kind = st["stage"]
            item.label = doc.stage_label(i)
            g = getattr(item, "p_" + st["stage"])
            for name, v in doc.values(i).items():
                try:
                    setattr(g, "v_" + name, v)
                except (TypeError, ValueError):
                    pass  # a value outside the widget's range: the recipe keeps it as written
        s.status = ""
    finally:
        _syncing[0] = False


def register():
    _classes.clear()
    stage_groups = {}
    for name in core.stage_names():
        cls = _make_group("RELIEF_PG_stage_" + name, core.stage_specs(name), _stage_update)
        stage_groups[name] = cls
        _classes.append(cls)
    world = _make_group("RELIEF_PG_world", core.world_specs(), _world_update)
    _classes.append(world)
    item_ann = {"kind": StringProperty(), "label": StringProperty(), "show": BoolProperty(default=True)}
    for name, cls in stage_groups.items():
        item_ann["p_" + name] = PointerProperty(type=cls)
    item = type("RELIEF_PG_stage", (bpy.types.PropertyGroup,), {"__annotations__": item_ann})
    _classes.append(item)
    sizes = "Samples per side, corners included (2^n+1 suits engines)"
    names = [it[0] for it in _preset_enum(None, None)]
    island = names.index("island") if "island" in names else 0
    ann = {
        "preset": EnumProperty(name="Preset", description="Built-in and user presets (relief presets)",
                               items=_preset_enum, default=island, update=_on_preset),
        "seed": IntProperty(name="Seed", description="Same recipe and seed, same terrain (0..2^31-1 here)",
                            min=0, max=core.SEED_MAX, default=7, update=_on_setting),
        "preview_size": IntProperty(name="Preview", description="Preview size. " + sizes, default=257, min=2,
                                    max=4097, update=_on_setting),
        "bake_size": IntProperty(name="Bake", description="Bake size. " + sizes, default=1025, min=2, max=16385),
        "live": BoolProperty(name="Live preview", default=True,
                             description="Regenerate the preview whenever a value changes"),
        "props": BoolProperty(name="Props", default=True, description="Build the props as instances",
                              update=_on_setting),
        "maps": BoolProperty(name="Splat and normal maps", default=True,
                             description="Bake also loads the splat weight maps and the normal map as images"),
        "chunk_cells": IntProperty(name="Chunk", default=1024, min=16, max=16384,
                                   description="Terrains wider than this many cells are split into chunk objects"),
        "threads": IntProperty(name="Threads", default=0, min=0, max=256, description="0 = all cores"),
        "recipe_json": StringProperty(name="Recipe", description="The recipe being edited, as JSON"),
        "recipe_path": StringProperty(name="Recipe file", subtype="FILE_PATH", default="//recipe.json"),
        "status": StringProperty(name="Status"),
        "world": PointerProperty(type=world),
        "stages": CollectionProperty(type=item),
    }
    settings_cls = type("RELIEF_PG_settings", (bpy.types.PropertyGroup,), {"__annotations__": ann})
    _classes.append(settings_cls)
    for c in _classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.relief = PointerProperty(type=settings_cls)


def unregister():
    del bpy.types.Scene.relief
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
    _classes.clear()


def ensure_recipe(scene):
    """A scene the add-on has not seen yet gets the selected preset's recipe."""
    s = scene.relief
    if not s.recipe_json:
        load_recipe(s, core.RecipeDoc.from_preset(s.preset or "island"))
    return s
