"""Headless test of the modal Bake (run by CTest, label `blender`):

  PATH=/usr/bin:/bin BLENDER_USER_SCRIPTS=build/blender \
  blender -b --factory-startup --python-exit-code 1 --python blender/tests/test_bake_modal.py

`blender -b` has no event loop (bpy.ops.relief.bake runs synchronously there), so the test drives the
operator's modal path by hand: RELIEF_OT_bake.start_modal (what invoke does with a window) and modal()
called with stand-in TIMER and ESC events, on a stand-in context whose window manager records the
progress bar, the timer and the modal handler. Checked: progress reaches the progress bar and the
status text while the run goes on, Esc (and Blender's cancel()) stop the run and leave the previous
preview untouched, a finished bake replaces the preview (one terrain, the bake size), the timer and
progress bar are always released. Every failure is collected and the script exits 1 at the end.
"""
import os
import sys
import time
import types

import addon_utils
import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, finish  # noqa: E402


mod = addon_utils.enable("relief_blender", default_set=True, handle_error=None)
check(mod is not None, "the add-on enables")
from relief_blender import live, ops  # noqa: E402

scn = bpy.context.scene
s = scn.relief
s.live = False


class WindowManager:
    """Records what the operator asks of the window manager."""

    def __init__(self):
        self.progress = []       # progress_update values
        self.progress_open = False
        self.timers = []         # live timers
        self.handlers = []

    def event_timer_add(self, step, window=None):
        t = types.SimpleNamespace(step=step)
        self.timers.append(t)
        return t

    def event_timer_remove(self, t):
        self.timers.remove(t)

    def progress_begin(self, a, b):
        self.progress_open, self.range = True, (a, b)

    def progress_update(self, v):
        self.progress.append(v)

    def progress_end(self):
        self.progress_open = False

    def modal_handler_add(self, op):
        self.handlers.append(op)
        return True


class Workspace:
    def __init__(self):
        self.texts = []

    def status_text_set(self, text):
        self.texts.append(text)


def make_context():
    return types.SimpleNamespace(scene=scn, window_manager=WindowManager(), window=object(), workspace=Workspace(), screen=None)


class Bake:
    """Stands in for the operator instance Blender would make: RELIEF_OT_bake's own methods on a
    plain object (a registered operator class cannot be instantiated from Python)."""
    start_modal = ops.RELIEF_OT_bake.start_modal
    modal = ops.RELIEF_OT_bake.modal
    cancel = ops.RELIEF_OT_bake.cancel
    _status = ops.RELIEF_OT_bake._status
    _finish = ops.RELIEF_OT_bake._finish
    _job = None
    _timer = None

    def __init__(self, size):
        self.size = size
        self.reports = []

    def report(self, kind, text):
        self.reports.append((set(kind), text))


TIMER = types.SimpleNamespace(type="TIMER", value="NOTHING")
ESC = types.SimpleNamespace(type="ESC", value="PRESS")
MOUSE = types.SimpleNamespace(type="MOUSEMOVE", value="NOTHING")


def pump(op, ctx, until, timeout=120):
    """Sends TIMER events every 0.1 s (the operator's timer step) until modal() returns something
    other than PASS_THROUGH or until(op) holds; returns the last result."""
    deadline = time.time() + timeout
    r = {"PASS_THROUGH"}
    while time.time() < deadline:
        r = op.modal(ctx, TIMER)
        if r != {"PASS_THROUGH"} or until(op):
            return r
        time.sleep(0.1)
    return r


def terrain_objects():
    return sorted((o for o in bpy.data.objects if o.get("relief_role") == "terrain"), key=lambda o: o.name)


def heights():
    obs = terrain_objects()
    check(len(obs) == 1, "one terrain object (got %d)" % len(obs))
    me = obs[0].data
    co = np.empty(len(me.vertices) * 3, dtype=np.float32)
    me.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)[:, 2].copy()


def assert_released(ctx, tag):
    wm = ctx.window_manager
    check(not wm.timers, "%s: the timer is removed" % tag)
    check(not wm.progress_open, "%s: the progress bar is closed" % tag)
    check(ctx.workspace.texts and ctx.workspace.texts[-1] is None, "%s: the status text is cleared" % tag)
    check(not live.busy(), "%s: the live preview is no longer held off" % tag)


# ---- the previous result: a 129² preview of eroded-mountains --------------------------------
s.preset = "eroded-mountains"
bpy.ops.relief.reset()
s.seed = 7
s.threads = 1
check(bpy.ops.relief.preview(size=129) == {"FINISHED"}, "the preview runs")
z_preview = heights()
check(len(z_preview) == 129 * 129, "the preview has 129² vertices")

# ---- Esc: progress is reported, then the run stops and the preview stays ---------------------
ctx = make_context()
op = Bake(513)
r = op.start_modal(ctx)
check(r == {"RUNNING_MODAL"}, "start_modal returns RUNNING_MODAL (%s)" % r)
wm = ctx.window_manager
check(wm.handlers == [op] and len(wm.timers) == 1 and wm.progress_open, "a modal handler, a timer and a progress bar")
check(live.busy(), "the live preview is held off during the bake")
check(op.modal(ctx, MOUSE) == {"PASS_THROUGH"}, "other events pass through")
r = pump(op, ctx, lambda o: o._job.fraction > 0.05)
check(r == {"PASS_THROUGH"} and not op._job.done, "the bake is still running when progress shows (%s)" % r)
check(wm.progress and max(wm.progress) > 0 and all(0 <= v <= 1000 for v in wm.progress),
      "the progress bar moves within 0..1000 (%s)" % wm.progress[-5:])
check(wm.progress == sorted(wm.progress), "the progress bar never goes back")
texts = [t for t in ctx.workspace.texts if t]
check(any("Esc to cancel" in t and "%" in t for t in texts), "the status text shows the stage and percentage (%s)" % texts[-1:])
t_esc = time.perf_counter()
check(op.modal(ctx, ESC) == {"PASS_THROUGH"}, "Esc asks the run to stop")
r = pump(op, ctx, lambda o: False, timeout=60)
print("Esc stopped the bake in %.2f s" % (time.perf_counter() - t_esc))
check(r == {"CANCELLED"}, "the bake ends CANCELLED after Esc (%s)" % r)
check(op._job.cancelled and op._job.result is None, "the job was cancelled without a result")
check(s.status == "Bake cancelled", "the panel says the bake was cancelled (%s)" % s.status)
check(any("WARNING" in k for k, _ in op.reports), "a warning is reported")
assert_released(ctx, "Esc")
check(np.array_equal(heights(), z_preview), "a cancelled bake leaves the previous preview")

# ---- Blender's cancel() (the window closes mid-run) stops the run and releases everything ----
ctx = make_context()
op = Bake(513)
op.start_modal(ctx)
pump(op, ctx, lambda o: o._job.fraction > 0.0)
op.cancel(ctx)
check(op._job.wait(60) and op._job.cancelled and op._job.result is None, "cancel() stops the run without a result")
assert_released(ctx, "cancel()")
check(np.array_equal(heights(), z_preview), "cancel() leaves the previous preview")

# ---- a finished bake replaces the preview ----------------------------------------------------
s.preset = "island"
bpy.ops.relief.reset()
s.seed = 7
ctx = make_context()
op = Bake(257)
op.start_modal(ctx)
r = pump(op, ctx, lambda o: False)
check(r == {"FINISHED"}, "the bake finishes (%s)" % r)
check(s.status.startswith("Baked 257x257"), "the panel reports the bake (%s)" % s.status)
check(any("INFO" in k for k, _ in op.reports), "the result is reported")
assert_released(ctx, "finished")
z = heights()
check(len(z) == 257 * 257 and len(terrain_objects()) == 1, "the bake replaced the preview: one terrain of 257² vertices")
img = bpy.data.materials["Relief Terrain"].node_tree.nodes["Albedo"].image
check(img is not None and img.packed_file is not None and tuple(img.size) == (257, 257), "the bake's albedo is packed at 257²")
# Same heights as the synchronous bake (the operator's execute path).
check(bpy.ops.relief.bake(size=257) == {"FINISHED"}, "the synchronous bake runs")
check(np.array_equal(heights(), z), "the modal bake builds what the synchronous bake builds")

finish("blender modal bake tests")
