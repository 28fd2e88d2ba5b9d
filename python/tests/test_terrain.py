"""relief.generate → Terrain: zero-copy layers and their lifetime, plain-data points, determinism."""
import gc
import threading

import numpy as np
import pytest

import relief


@pytest.fixture(scope="module")
def island():
    return relief.generate("island", seed=7, size=129, threads=1)


def test_layers_are_views_of_library_memory(island):
    h = island.height
    assert h.dtype == np.float32 and h.shape == (129, 129)
    assert not h.flags.owndata  # a view, not a copy
    # Every access views the same buffer: same address, shared memory.
    h2 = island.layers["height"]
    assert h.__array_interface__["data"][0] == h2.__array_interface__["data"][0]
    assert np.shares_memory(h, h2)
    albedo = island.layers["albedo"]
    assert albedo.shape == (129, 129, 3) and albedo.strides == (129 * 3 * 4, 3 * 4, 4)
    assert not np.shares_memory(h, albedo)


def test_writes_through_a_view_are_seen_by_every_view():
    t = relief.generate("island", seed=7, size=65, threads=1)
    a, b = t.height, t.layers["height"]
    old = float(a[3, 5])
    a[3, 5] = 0.123
    assert b[3, 5] == np.float32(0.123)
    a[3, 5] = old


def test_arrays_outlive_the_terrain():
    t = relief.generate("island", seed=7, size=129, threads=1)
    h = t.height
    albedo = t.layers["albedo"]
    expected_h, expected_a = h.copy(), albedo.copy()
    del t
    gc.collect()
    # Churn the allocator: freed memory would be reused and overwritten.
    junk = [relief.generate("hills", seed=s, size=129, threads=1).height.copy() for s in range(3)]
    assert junk[0].shape == (129, 129)
    assert np.array_equal(h, expected_h)
    assert np.array_equal(albedo, expected_a)


def test_cached_buffers_never_back_a_live_array_and_release_frees_them():
    # Layers of 4 MiB or more go to the process-wide buffer cache when their Terrain is freed; an
    # array still viewing one keeps its Terrain, so its buffer is never handed to the next run.
    relief.release_cached_buffers()
    t = relief.generate("island", seed=7, size=1025)
    h = t.height
    expected = h.copy()
    del t
    gc.collect()
    for seed in (1, 2):
        u = relief.generate("island", seed=seed, size=1025)
        assert not np.shares_memory(u.height, h)
        del u
        gc.collect()
    assert np.array_equal(h, expected)
    # The second run's layers sit in the cache: released, then nothing is left.
    assert relief.release_cached_buffers() >= 1025 * 1025 * 4
    assert relief.release_cached_buffers() == 0


def test_points_rivers_lakes_are_plain_data():
    t = relief.generate("volcanic-island", seed=3, size=129, threads=1)
    props = t.props
    assert props and all(isinstance(p, dict) for p in props)
    p = props[0]
    assert set(p) == {"kind", "type", "x_m", "y_m", "z_m", "rotation_deg", "scale"}
    assert p["kind"] == "prop" and isinstance(p["x_m"], float)
    assert any(f["kind"] != "prop" for f in t.points)  # the volcano's feature point
    assert isinstance(t.rivers, list) and isinstance(t.lakes, list)
    assert t.biomes and t.biomes[0]["name"]


def test_rivers_as_plain_data():
    t = relief.generate("river-island", seed=1, size=129)
    assert t.rivers, "river-island has rivers"
    r = t.rivers[0]
    assert r["end"] in ("sea", "edge", "river") and r["order"] >= 1
    assert {"x_m", "y_m", "z_m", "discharge_m3s", "width_m"} <= set(r["vertices"][0])


def test_threads_do_not_change_the_result():
    a = relief.generate("island", seed=11, size=129, threads=1)
    b = relief.generate("island", seed=11, size=129, threads=2)
    for name in a.layer_names:
        assert np.array_equal(a.layers[name], b.layers[name]), name
    assert a.encode("height.png") == b.encode("height.png")


def test_seed_size_set_and_resolved_recipe():
    t = relief.generate("island", seed=5, size=(65, 33), set={"world.sea_level": 0.3, "stages[0].octaves": 3})
    assert t.size == (65, 33) and t.height.shape == (33, 65)
    assert t.seed == 5
    r = t.recipe
    assert r["seed"] == 5 and r["world"]["sea_level"] == 0.3 and r["stages"][0]["octaves"] == 3
    # The same via CLI-style strings, and a dict recipe (the resolved one) gives the same heights.
    u = relief.generate("island", seed=5, size=(65, 33), set=["world.sea_level=0.3", "stages[0].octaves=3"])
    assert np.array_equal(t.height, u.height)
    v = relief.generate(r)
    assert np.array_equal(t.height, v.height)


def test_no_seed_draws_one():
    t = relief.generate("island", size=33)
    assert 0 <= t.seed < 2**53


def test_presets_and_explain():
    names = [p["name"] for p in relief.presets()]
    assert "island" in names and "volcanic-island" in names
    assert all(p["description"] for p in relief.presets())
    table = relief.explain()
    assert {"world", "stages", "formats"} <= set(table)
    noise = relief.explain("noise")["stages"][0]
    octaves = [p for p in noise["params"] if p["name"] == "octaves"][0]
    assert octaves["type"] == "int" and octaves["min"] == 1 and octaves["max"] == 16 and octaves["description"]


def test_progress_runs_on_the_calling_thread():
    seen = []
    me = threading.get_ident()
    relief.generate("island", seed=1, size=65, progress=lambda what, f: seen.append((what, f, threading.get_ident())))
    assert seen and all(tid == me for _, _, tid in seen)
    assert any(w.startswith("stage ") for w, _, _ in seen)
    fractions = [f for _, f, _ in seen]
    assert all(0.0 <= f <= 1.0 for f in fractions)
