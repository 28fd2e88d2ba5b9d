"""Cancellation: a progress callback that raises, and Ctrl-C (SIGINT), stop a run cleanly."""
import os
import signal
import threading
import time

import pytest

import relief


class Stop(Exception):
    pass


def test_a_raising_progress_callback_cancels_generate():
    calls = []

    def progress(what, f):
        calls.append(what)
        if len(calls) == 2:
            raise Stop("enough")

    with pytest.raises(Stop):
        relief.generate("volcanic-island", seed=1, size=129, progress=progress)
    # The callback is not called again after it raised, and the module still works.
    assert len(calls) == 2
    assert relief.generate("island", seed=1, size=33).size == (33, 33)


def test_a_raising_progress_callback_cancels_write_and_changes_no_file(tmp_path):
    t = relief.generate("island", seed=1, size=65)

    def progress(what, f):
        raise Stop(what)

    out = tmp_path / "out"
    with pytest.raises(Stop):
        t.write(str(out), progress=progress)
    assert not out.exists() or list(out.iterdir()) == []


def sigint_soon(delay):
    timer = threading.Timer(delay, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    return timer


def test_ctrl_c_interrupts_a_long_generation():
    # eroded-mountains at 513² runs stream power and droplet erosion for seconds. Without a callback
    # the interrupt is noticed by the wait loop (PyErr_CheckSignals).
    timer = sigint_soon(0.3)
    try:
        with pytest.raises(KeyboardInterrupt):
            relief.generate("eroded-mountains", seed=1, size=513, threads=1)
    finally:
        timer.cancel()
    # Nothing was left in a bad state: the next run works.
    assert relief.generate("island", seed=1, size=33).size == (33, 33)


def test_ctrl_c_stops_the_run_before_it_ends():
    # With a callback that records progress: the run stops at the next stage, so it never reports
    # "done" (were the interrupt only raised once the call returned, every stage would have run).
    seen = []
    timer = sigint_soon(0.3)
    try:
        with pytest.raises(KeyboardInterrupt):
            relief.generate("eroded-mountains", seed=1, size=513, threads=1, progress=lambda w, f: seen.append((w, f)))
    finally:
        timer.cancel()
    assert seen, "the run reported progress before the interrupt"
    assert all(not w.endswith("done") for w, _ in seen)
    assert max(f for _, f in seen) < 1.0


def test_ctrl_c_during_write_changes_no_file(tmp_path):
    t = relief.generate("island", seed=1, size=1025)
    out = tmp_path / "out"
    timer = sigint_soon(0.05)
    try:
        try:
            t.write(str(out), formats=["obj", "glb", "fbx", "stl"])
            interrupted = False
        except KeyboardInterrupt:
            interrupted = True
    finally:
        timer.cancel()
    if interrupted:
        assert not out.exists() or [p for p in out.iterdir()] == []
    else:
        pytest.skip("the write finished before the signal arrived")
