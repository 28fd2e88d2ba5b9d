"""Operators (bpy): preview, bake (modal with progress and Esc to cancel), random seed, recipe
file save/load, stage add/remove/move."""
import time

import bpy
from bpy.props import EnumProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from . import core, live, props, scene as scene_build


def _generate_and_build(context, size, maps, pack):
    scn = context.scene
    s = props.ensure_recipe(scn)
    job = live.job_for(scn, size)
    t = job.run()
    tm = scene_build.build(scn, t, chunk_cells=s.chunk_cells, maps=maps, props=s.props, pack=pack)
    scene_build.widen_clip(context, t.frame["width_m"])
    return t, job.seconds, tm


class RELIEF_OT_preview(bpy.types.Operator):
    """Generate at the preview size and rebuild the Relief collection"""
    bl_idname = "relief.preview"
    bl_label = "Preview"
    bl_options = {"REGISTER", "UNDO"}
    size: IntProperty(name="Size", default=0, min=0, description="0: the panel's preview size")

    def execute(self, context):
        s = props.ensure_recipe(context.scene)
        try:
            t, gen, tm = _generate_and_build(context, self.size or s.preview_size, False, False)
        except (core.relief.Error, ValueError) as e:
            s.status = "Error: %s" % e
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        s.status = "Preview %dx%d: generate %.0f ms, build %.0f ms" % (t.size + (gen * 1000, tm["build"] * 1000))
        return {"FINISHED"}


class RELIEF_OT_bake(bpy.types.Operator):
    """Generate at the bake size with every map (a modal run: progress in the status bar, Esc cancels)"""
    bl_idname = "relief.bake"
    bl_label = "Bake"
    bl_options = {"REGISTER"}
    size: IntProperty(name="Size", default=0, min=0, description="0: the panel's bake size")

    _job = None
    _timer = None

    def execute(self, context):  # scripts and background mode: synchronous
        s = props.ensure_recipe(context.scene)
        try:
            t, gen, tm = _generate_and_build(context, self.size or s.bake_size, s.maps, True)
        except (core.relief.Error, ValueError) as e:
            s.status = "Error: %s" % e
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        s.status = "Baked %dx%d: generate %.2f s, build %.2f s" % (t.size + (gen, tm["build"]))
        return {"FINISHED"}

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        return self.start_modal(context)

    def start_modal(self, context):
        """Starts the run on a thread and the timer that drives modal(); blender/tests/test_bake_modal.py
        calls it (and modal) directly, since background mode has no event loop."""
        scn = context.scene
        s = props.ensure_recipe(scn)
        live.cancel()
        live.set_busy(True)
        self._size = self.size or s.bake_size
        self._job = live.job_for(scn, self._size).start()
        self._t0 = time.perf_counter()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 1000)
        wm.modal_handler_add(self)
        self._status(context, "Relief: baking %dx%d… (Esc to cancel)" % (self._size, self._size))
        return {"RUNNING_MODAL"}

    def _status(self, context, text):
        if context.workspace is not None:
            context.workspace.status_text_set(text)

    def _finish(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        self._status(context, None)
        live.set_busy(False)

    def modal(self, context, event):
        job = self._job
        if event.type == "ESC" and event.value == "PRESS":
            job.cancel()
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        s = context.scene.relief
        if not job.done:
            context.window_manager.progress_update(int(job.fraction * 1000))
            self._status(context, "Relief: baking %dx%d: %s %d%% (%.1f s, Esc to cancel)" % (
                self._size, self._size, job.what, job.fraction * 100, time.perf_counter() - self._t0))
            return {"PASS_THROUGH"}
        self._finish(context)
        if job.cancelled:
            s.status = "Bake cancelled"
            self.report({"WARNING"}, "Relief: bake cancelled")
            return {"CANCELLED"}
        if job.error is not None:
            s.status = "Error: %s" % job.error
            self.report({"ERROR"}, str(job.error))
            return {"CANCELLED"}
        t = job.result
        tm = scene_build.build(context.scene, t, chunk_cells=s.chunk_cells, maps=s.maps, props=s.props, pack=True)
        scene_build.widen_clip(context, t.frame["width_m"])
        s.status = "Baked %dx%d: generate %.2f s, build %.2f s" % (t.size + (job.seconds, tm["build"]))
        self.report({"INFO"}, s.status)
        return {"FINISHED"}

    def cancel(self, context):
        if self._job is not None:
            self._job.cancel()
        self._finish(context)


class RELIEF_OT_random_seed(bpy.types.Operator):
    """Draw a random seed"""
    bl_idname = "relief.random_seed"
    bl_label = "Random seed"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        context.scene.relief.seed = core.random_seed()
        return {"FINISHED"}


class RELIEF_OT_reset(bpy.types.Operator):
    """Reload the selected preset (drops the edits)"""
    bl_idname = "relief.reset"
    bl_label = "Reset to preset"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        s = context.scene.relief
        props.load_recipe(s, core.RecipeDoc.from_preset(s.preset))
        live.request(context.scene)
        return {"FINISHED"}


class RELIEF_OT_save_recipe(bpy.types.Operator, ExportHelper):
    """Save the recipe (with its seed) as JSON, readable by `relief generate FILE`"""
    bl_idname = "relief.save_recipe"
    bl_label = "Save recipe"
    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def execute(self, context):
        s = props.ensure_recipe(context.scene)
        core.RecipeDoc.from_json(s.recipe_json).save(self.filepath, seed=s.seed)
        s.status = "Saved %s" % self.filepath
        return {"FINISHED"}


class RELIEF_OT_load_recipe(bpy.types.Operator, ImportHelper):
    """Load a recipe JSON file (a bad file is refused with the field it names; the recipe stays)"""
    bl_idname = "relief.load_recipe"
    bl_label = "Load recipe"
    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def execute(self, context):
        s = context.scene.relief
        try:
            doc = core.RecipeDoc.load(self.filepath)
        except (core.relief.Error, ValueError, OSError) as e:
            s.status = "Error: %s" % e
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        props.load_recipe(s, doc)
        live.request(context.scene)
        return {"FINISHED"}


def _stage_items(self, context):
    return [(n, n, core.stage_info(n).get("summary", "")) for n in core.stage_names()]


class RELIEF_OT_stage_add(bpy.types.Operator):
    """Append a stage (with the table's defaults) to the recipe"""
    bl_idname = "relief.stage_add"
    bl_label = "Add stage"
    bl_options = {"REGISTER", "UNDO"}
    bl_property = "stage"
    stage: EnumProperty(name="Stage", items=_stage_items)

    def invoke(self, context, event):
        context.window_manager.invoke_search_popup(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        s = props.ensure_recipe(context.scene)
        doc = core.RecipeDoc.from_json(s.recipe_json)
        doc.add_stage(self.stage)
        props.load_recipe(s, doc, seed=s.seed)
        live.request(context.scene)
        return {"FINISHED"}


class RELIEF_OT_stage_edit(bpy.types.Operator):
    """Remove a stage or move it up or down"""
    bl_idname = "relief.stage_edit"
    bl_label = "Edit stage"
    bl_options = {"REGISTER", "UNDO", "INTERNAL"}
    index: IntProperty()
    action: EnumProperty(items=[("REMOVE", "Remove", ""), ("UP", "Up", ""), ("DOWN", "Down", "")])

    def execute(self, context):
        s = props.ensure_recipe(context.scene)
        doc = core.RecipeDoc.from_json(s.recipe_json)
        if self.action == "REMOVE":
            doc.remove_stage(self.index)
        else:
            doc.move_stage(self.index, -1 if self.action == "UP" else 1)
        props.load_recipe(s, doc, seed=s.seed)
        live.request(context.scene)
        return {"FINISHED"}


classes = (RELIEF_OT_preview, RELIEF_OT_bake, RELIEF_OT_random_seed, RELIEF_OT_reset, RELIEF_OT_save_recipe,
           RELIEF_OT_load_recipe, RELIEF_OT_stage_add, RELIEF_OT_stage_edit)
