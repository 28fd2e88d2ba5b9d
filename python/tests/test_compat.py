"""relief.compat against Debian's python3-noise (the `noise` package 1.2.3): the same values, bit for
bit, for scalars and arrays; statistics and tiling as documented in README.md (Python, `relief.compat`).

python3-noise is the reference and scripts/setup.sh installs it: without it these tests fail (they
are not skipped)."""
import numpy as np
import noise  # Debian python3-noise (scripts/setup.sh); a missing reference is a failure, not a skip
import pytest

import relief.compat as rc

rng = np.random.default_rng(20)
PTS = rng.uniform(-300.0, 300.0, size=(400, 3))


def both(fn_ours, fn_theirs, args_list, **kw):
    ours = [fn_ours(*a, **kw) for a in args_list]
    theirs = [fn_theirs(*a, **kw) for a in args_list]
    return np.array(ours), np.array(theirs)


@pytest.mark.parametrize("kw", [{}, {"octaves": 6}, {"octaves": 4, "persistence": 0.7, "lacunarity": 2.3},
                                {"octaves": 3, "base": 17.0}, {"octaves": 2, "base": -3.25}])
def test_snoise2_is_the_package_value(kw):
    pts = [tuple(p[:2] / 37.0) for p in PTS]
    ours, theirs = both(rc.snoise2, noise.snoise2, pts, **kw)
    assert np.array_equal(ours, theirs)


@pytest.mark.parametrize("kw", [{"repeatx": 64.0}, {"repeaty": 48.0}, {"repeatx": 64.0, "repeaty": 32.0, "octaves": 5},
                                {"repeatx": 100.0, "repeaty": 100.0, "base": 7.0, "octaves": 2}])
def test_tiled_snoise2_is_the_package_value(kw):
    pts = [tuple(p[:2] / 3.0) for p in PTS]
    ours, theirs = both(rc.snoise2, noise.snoise2, pts, **kw)
    assert np.array_equal(ours, theirs)


@pytest.mark.parametrize("kw", [{}, {"octaves": 6}, {"octaves": 3, "persistence": 0.3, "lacunarity": 1.9}])
def test_snoise3_is_the_package_value(kw):
    pts = [tuple(p / 41.0) for p in PTS]
    ours, theirs = both(rc.snoise3, noise.snoise3, pts, **kw)
    assert np.array_equal(ours, theirs)


@pytest.mark.parametrize("kw", [{}, {"octaves": 6}, {"repeatx": 16, "repeaty": 8, "octaves": 3}, {"base": 1, "octaves": 2}])
def test_pnoise2_is_the_package_value(kw):
    pts = [tuple(p[:2] / 13.0) for p in PTS]
    ours, theirs = both(rc.pnoise2, noise.pnoise2, pts, **kw)
    assert np.array_equal(ours, theirs)


@pytest.mark.parametrize("kw", [{}, {"octaves": 5}, {"repeatx": 8, "repeaty": 16, "repeatz": 4, "octaves": 2}, {"base": 1}])
def test_pnoise3_is_the_package_value(kw):
    pts = [tuple(p / 13.0) for p in PTS]
    ours, theirs = both(rc.pnoise3, noise.pnoise3, pts, **kw)
    assert np.array_equal(ours, theirs)


def test_pnoise_with_a_large_base_differs_only_where_the_package_leaves_its_table():
    pts = [tuple(p[:2] / 13.0) for p in PTS]
    ours, theirs = both(rc.pnoise2, noise.pnoise2, pts, base=5)
    assert np.mean(ours == theirs) > 0.9


@pytest.mark.parametrize("fn,dims,kw", [("snoise2", 2, {"octaves": 6}), ("snoise2", 2, {"octaves": 2, "repeatx": 50.0, "repeaty": 70.0}),
                                        ("snoise2", 2, {"octaves": 3, "repeatx": 50.0}), ("snoise2", 2, {"octaves": 4, "repeaty": 40.0, "base": 2.0}),
                                        ("snoise3", 3, {"octaves": 6}), ("pnoise2", 2, {"octaves": 6}),
                                        ("pnoise3", 3, {"octaves": 3})])
def test_arrays_give_the_scalar_values(fn, dims, kw):
    coords = [PTS[:, k] / 29.0 for k in range(dims)]
    arr = getattr(rc, fn)(*coords, **kw)
    assert arr.dtype == np.float32 and arr.shape == (len(PTS),)
    theirs = np.array([getattr(noise, fn)(*[float(c[i]) for c in coords], **kw) for i in range(len(PTS))])
    assert np.array_equal(arr.astype(np.float64), theirs)


def test_arrays_broadcast_and_fill_out():
    xs = np.linspace(0, 10, 300, dtype=np.float64)
    ys = np.linspace(0, 5, 200, dtype=np.float64)[:, None]
    out = np.empty((200, 300), np.float32)
    r = rc.snoise2(xs, ys, octaves=6, out=out)
    assert r is out
    assert out[17, 123] == np.float32(noise.snoise2(float(xs[123]), float(ys[17, 0]), octaves=6))


def test_threads_do_not_change_array_values():
    xs, ys = np.meshgrid(np.arange(512) / 50.0, np.arange(300) / 50.0)
    rc.threads = 1
    a = rc.snoise2(xs, ys, octaves=6)
    rc.threads = 2
    b = rc.snoise2(xs, ys, octaves=6)
    rc.threads = 0
    assert np.array_equal(a, b)


def test_statistics_and_range_over_a_grid():
    # A 256² grid at 6 octaves: the documented figures (mean ≈ 0, |v| < 1).
    xs, ys = np.meshgrid(np.arange(256) / 32.0, np.arange(256) / 32.0)
    v = rc.snoise2(xs, ys, octaves=6)
    assert abs(float(v.mean())) < 0.05 and 0.15 < float(v.std()) < 0.4
    assert float(np.abs(v).max()) < 1.0
    p = rc.pnoise2(xs, ys, octaves=6)
    assert abs(float(p.mean())) < 0.05 and float(np.abs(p).max()) < 1.0


def test_tiling_with_repeat():
    r = 40.0
    xs = np.linspace(0, r, 81)
    a = rc.snoise2(xs, 3.3, repeatx=r, repeaty=r)
    b = rc.snoise2(xs + r, 3.3 + r, repeatx=r, repeaty=r)
    # The package's fast sine makes the period exact only up to float rounding of x·2/r.
    assert np.max(np.abs(a - b)) < 1e-4
    p = rc.pnoise2(xs, 1.7, repeatx=16, repeaty=16)
    q = rc.pnoise2(xs + 16, 1.7 + 16, repeatx=16, repeaty=16)
    assert np.max(np.abs(p - q)) < 1e-5


def test_seed_001_blog_code_runs_unchanged():
    # The heightmap blog post (seed 001), written against `noise`, with `import relief.compat as noise`.
    noise_mod = rc
    SCALE, MAP_SIZE, seed = 50.0, (64, 64), 123

    def update_point(coords, seed):
        return noise_mod.snoise2(coords[0] / SCALE, coords[1] / SCALE, octaves=6, persistence=0.5, lacunarity=2,
                                 repeatx=MAP_SIZE[0], repeaty=MAP_SIZE[1], base=seed)

    hm = np.zeros(MAP_SIZE)
    for x in range(MAP_SIZE[0]):
        for y in range(MAP_SIZE[1]):
            hm[x][y] = update_point((x, y), seed)
    ref = np.array([[noise.snoise2(x / SCALE, y / SCALE, octaves=6, persistence=0.5, lacunarity=2, repeatx=64, repeaty=64, base=seed)
                     for y in range(64)] for x in range(64)])
    assert np.array_equal(hm, ref)


@pytest.mark.parametrize("kw", [{"octaves": 6}, {"octaves": 3, "repeatx": 64.0, "repeaty": 64.0}])
def test_float32_and_float64_inputs_agree(kw):
    xs = (PTS[:, 0] / 7.0).astype(np.float32)
    ys = (PTS[:, 1] / 7.0).astype(np.float32)
    a = rc.snoise2(xs, ys, **kw)                                       # float32 path
    b = rc.snoise2(xs.astype(np.float64), ys.astype(np.float64), **kw)  # float64 path, same values
    assert np.array_equal(a, b)
    theirs = np.array([noise.snoise2(float(x), float(y), **kw) for x, y in zip(xs, ys)])
    assert np.array_equal(a.astype(np.float64), theirs)
