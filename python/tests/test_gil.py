"""Every long call releases the GIL while its C++ part runs.

A second Python thread (the spinner) stamps the time every half millisecond while it holds the GIL.
A call that held the GIL through its C++ part would leave no stamps at times when that part is
provably running:
- between two progress callbacks (the library's thread is between two progress reports; the
  calling thread is in C++, outside Python), for generate and write;
- in the middle half of a call with no callback (its C++ part starts within a switch interval,
  5 ms, of the call and ends within one of its return; the calls here last ≥ 150 ms), for noise
  arrays, compat arrays and encode.
Stamps near the ends of such a window may come from GIL hand-overs at the Python/C++ boundary, so
only the middle half of a window counts. Each test fails if the GIL is held there (checked by
removing the gil_scoped_release in python/module.cpp / noise_py.cpp).
"""
import threading
import time

import numpy as np
import pytest

import relief
import relief.compat as rc
import relief.noise as rn

MIN_WINDOW_S = 0.15  # a window shorter than this proves too little
MIN_STAMPS = 5       # stamps the spinner must leave in a window's middle half (it leaves ~1 per 0.5 ms)


class Spinner:
    """A Python thread that records time.perf_counter() every ≥ 0.5 ms while it runs Python code."""

    def __init__(self):
        self.stamps = []
        self._stop = threading.Event()
        self._started = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)

    def _spin(self):
        last = 0.0
        self._started.set()
        while not self._stop.is_set():
            t = time.perf_counter()
            if t - last >= 0.0005:
                self.stamps.append(t)
                last = t

    def __enter__(self):
        self._thread.start()
        self._started.wait()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()

    def stamps_in_middle(self, t0, t1):
        q = (t1 - t0) / 4
        return sum(1 for t in self.stamps if t0 + q < t < t1 - q)


def check_windows(spinner, windows, what):
    """windows: (t0, t1) during which the call's C++ part is provably running. The longest must be
    long enough to prove something, and the spinner must have run in the middle of each long one."""
    long_windows = [(a, b) for a, b in windows if b - a >= MIN_WINDOW_S]
    assert long_windows, "%s: no window of %.0f ms or more (longest %.0f ms); the test proves nothing" % (
        what, MIN_WINDOW_S * 1000, max((b - a for a, b in windows), default=0) * 1000)
    for a, b in long_windows:
        n = spinner.stamps_in_middle(a, b)
        assert n >= MIN_STAMPS, "%s: another Python thread ran only %d times in the middle of a %.0f ms stretch of C++ work " \
                                "(the GIL was held)" % (what, n, (b - a) * 1000)


def call_window(spinner, fn):
    t0 = time.perf_counter()
    r = fn()
    t1 = time.perf_counter()
    return r, [(t0, t1)]


def long_call_window(spinner, make_call):
    """call_window for make_call(k), a call whose work grows with k (1, 2, 4, ...): k doubles until
    the call lasts 2 * MIN_WINDOW_S, so that faster kernels or machines keep the window long."""
    k = 1
    while True:
        r, windows = call_window(spinner, make_call(k))
        if windows[0][1] - windows[0][0] >= 2 * MIN_WINDOW_S or k >= 16:
            return r, windows
        k *= 2


class CallbackTimes:
    """A progress callback recording when each call starts and ends; the windows are the stretches
    between the end of one callback and the start of the next."""

    def __init__(self):
        self.calls = []

    def __call__(self, what, f):
        start = time.perf_counter()
        self.calls.append([start, None, what])
        self.calls[-1][1] = time.perf_counter()

    def windows(self):
        return [(a[1], b[0]) for a, b in zip(self.calls, self.calls[1:])]


# Two fused cellular noise stages of 12 octaves: one stretch of ~0.5 s of C++ between the "stage
# noise" reports and "stage done".
SLOW_RECIPE = {"name": "gil", "world": {"size": 2049},
               "stages": [{"stage": "noise", "basis": "cellular", "octaves": 12},
                          {"stage": "noise", "basis": "cellular", "octaves": 12}]}


def test_generate_releases_the_gil():
    cb = CallbackTimes()
    with Spinner() as s:
        relief.generate(SLOW_RECIPE, seed=2, threads=1, progress=cb)
    check_windows(s, cb.windows(), "generate")


@pytest.fixture(scope="module")
def big_terrain():
    return relief.generate("island", seed=3, size=1025, threads=1)


def test_write_releases_the_gil(big_terrain, tmp_path):
    cb = CallbackTimes()
    with Spinner() as s:
        big_terrain.write(str(tmp_path / "out"), formats=["obj", "glb"], threads=1, progress=cb)
    check_windows(s, cb.windows(), "Terrain.write")


def test_encode_releases_the_gil(big_terrain):
    with Spinner() as s:
        data, windows = call_window(s, lambda: big_terrain.encode("glb", threads=1))
    assert len(data) > 1000
    check_windows(s, windows, "Terrain.encode")


def test_fbm_releases_the_gil():
    with Spinner() as s:
        _, windows = long_call_window(
            s, lambda k: lambda: rn.fbm(grid=(2048 * k, 2048), basis="perlin", octaves=6, frequency=0.01, threads=1))
    check_windows(s, windows, "noise.fbm")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_compat_snoise2_arrays_release_the_gil(dtype):
    n = 2048
    x = np.broadcast_to(np.arange(n, dtype=dtype)[None, :] / 97.0, (n, n)).copy()
    y = np.broadcast_to(np.arange(n, dtype=dtype)[:, None] / 89.0, (n, n)).copy()
    old = rc.threads
    rc.threads = 1
    try:
        with Spinner() as s:
            out, windows = call_window(s, lambda: rc.snoise2(x, y, octaves=32))
    finally:
        rc.threads = old
    assert out.shape == (n, n) and np.isfinite(out).all()
    check_windows(s, windows, "compat.snoise2 (%s)" % np.dtype(dtype).name)
