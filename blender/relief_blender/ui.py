"""The sidebar panel "Relief" (bpy): drawn from the parameter table, so stages added to Relief
appear here without changes to the add-on. One sub-panel per recipe stage (slots registered up to
MAX_STAGES; each shows the stage at its index, if any)."""
import bpy

from . import core

MAX_STAGES = 32


class RELIEF_PT_main(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Relief"
    bl_label = "Relief"

    def draw(self, context):
        s = context.scene.relief
        lay = self.layout
        lay.use_property_split = False
        row = lay.row(align=True)
        row.prop(s, "preset", text="")
        row.operator("relief.reset", text="", icon="FILE_REFRESH")
        row = lay.row(align=True)
        row.prop(s, "seed")
        row.operator("relief.random_seed", text="", icon="MOD_NOISE")
        row = lay.row(align=True)
        row.prop(s, "preview_size")
        row.prop(s, "bake_size")
        row = lay.row(align=True)
        row.prop(s, "live", toggle=True, icon="PLAY")
        row.operator("relief.preview", icon="VIEWZOOM")
        row.operator("relief.bake", icon="RENDER_STILL")
        row = lay.row(align=True)
        row.prop(s, "props", toggle=True)
        row.prop(s, "maps", toggle=True, text="Maps")
        row.prop(s, "chunk_cells")
        row = lay.row(align=True)
        row.operator("relief.load_recipe", icon="FILE_FOLDER", text="Load")
        row.operator("relief.save_recipe", icon="FILE_TICK", text="Save")
        row.operator("relief.stage_add", icon="ADD", text="Stage")
        if s.status:
            lay.label(text=s.status, icon="ERROR" if s.status.startswith("Error") else "INFO")
        if not s.recipe_json:
            lay.label(text="Pick a preset or press Preview to start")


class RELIEF_PT_world(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Relief"
    bl_parent_id = "RELIEF_PT_main"
    bl_label = "World"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        w = context.scene.relief.world
        for p in core.world_specs():
            self.layout.prop(w, "v_" + p.name)


def _draw_params(layout, group, kind):
    layout.use_property_split = True
    layout.use_property_decorate = False
    for p in core.stage_specs(kind):
        layout.prop(group, "v_" + p.name)


def _stage_panel(index):
    def poll(cls, context):
        return index < len(context.scene.relief.stages)

    def draw_header(self, context):
        it = context.scene.relief.stages[index]
        label = it.label if it.label and it.label != it.kind else ""
        self.layout.label(text="%d. %s%s" % (index + 1, it.kind, (" · " + label) if label else ""))

    def draw_header_preset(self, context):
        row = self.layout.row(align=True)
        for action, icon in (("UP", "TRIA_UP"), ("DOWN", "TRIA_DOWN"), ("REMOVE", "X")):
            op = row.operator("relief.stage_edit", text="", icon=icon, emboss=False)
            op.index, op.action = index, action

    def draw(self, context):
        it = context.scene.relief.stages[index]
        info = core.stage_info(it.kind)
        self.layout.label(text=info.get("summary", ""))
        _draw_params(self.layout, getattr(it, "p_" + it.kind), it.kind)

    return type("RELIEF_PT_stage_%02d" % index, (bpy.types.Panel,), {
        "bl_space_type": "VIEW_3D", "bl_region_type": "UI", "bl_category": "Relief",
        "bl_parent_id": "RELIEF_PT_main", "bl_label": "Stage %d" % (index + 1), "bl_options": {"DEFAULT_CLOSED"},
        "poll": classmethod(poll), "draw_header": draw_header, "draw_header_preset": draw_header_preset, "draw": draw})


classes = [RELIEF_PT_main, RELIEF_PT_world] + [_stage_panel(i) for i in range(MAX_STAGES)]
