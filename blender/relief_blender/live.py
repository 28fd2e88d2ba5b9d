"""Live preview (bpy): a changed value asks for a preview; DEBOUNCE_S after the first change of a
burst, a generation at the preview size runs on a thread (core.Job) and, when it returns, the scene
is rebuilt. One job in flight; a request made while it runs is remembered and served next with the
newest values (as the studio does), so dragging a slider keeps refreshing without piling up runs.
"""
import time

import bpy

from . import core, scene as scene_build

DEBOUNCE_S = 0.12
POLL_S = 0.03

_state = {"scene": None, "due": 0.0, "pending": False, "job": None, "busy": False, "last_ms": 0.0}


def busy():
    """True while a modal bake runs (the live preview stays out of its way)."""
    return _state["busy"]


def set_busy(v):
    _state["busy"] = v


def request(scene, immediate=False):
    s = scene.relief
    if not s.live:
        return
    _state["scene"] = scene.name
    if not _state["pending"] or immediate:
        # The first change of a burst sets the time; later ones do not push it back, so a drag
        # refreshes every DEBOUNCE_S (or every run, when a run takes longer) instead of waiting
        # for the drag to stop.
        _state["due"] = time.monotonic() + (0.0 if immediate else DEBOUNCE_S)
    _state["pending"] = True
    if not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=0.0 if immediate else DEBOUNCE_S)


def job_for(scene, size):
    s = scene.relief
    doc = core.RecipeDoc.from_json(s.recipe_json)
    return core.Job(doc.doc, s.seed, size, threads=s.threads)


def _tick():
    scn = bpy.data.scenes.get(_state["scene"] or "")
    if scn is None:
        _state["pending"] = False
        _state["job"] = None
        return None
    job = _state["job"]
    if job is not None:
        if not job.done:
            return POLL_S
        _state["job"] = None
        s = scn.relief
        if job.error is not None:
            s.status = "Error: %s" % job.error
        elif job.result is not None and not busy():
            t0 = time.perf_counter()
            tm = scene_build.build(scn, job.result, chunk_cells=s.chunk_cells, maps=False, props=s.props)
            _state["last_ms"] = (job.seconds + time.perf_counter() - t0) * 1000
            f = job.result.frame
            s.status = "Preview %dx%d: generate %.0f ms, build %.0f ms" % (
                f["nx"], f["nz"], job.seconds * 1000, tm["build"] * 1000)
            _redraw()
    if _state["pending"] and not busy():
        wait = _state["due"] - time.monotonic()
        if wait > 0:
            return min(wait, DEBOUNCE_S)
        _state["pending"] = False
        _state["job"] = job_for(scn, scn.relief.preview_size).start()
        return POLL_S
    return POLL_S if _state["pending"] else None


def _redraw():
    wm = bpy.context.window_manager
    if wm is None:
        return
    for win in wm.windows:
        for area in win.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()


def cancel():
    job = _state["job"]
    if job is not None:
        job.cancel()
    _state["pending"] = False
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)
