"""relief.noise: the library's noise over grids and point arrays."""

import numpy as np
import pytest

import relief
import relief.noise as rn


def test_grid_equals_points_and_the_terrain_noise_stage():
    g = rn.fbm(grid=(96, 40), spacing=2.5, octaves=6, frequency=1 / 200.0, seed=9)
    assert g.shape == (40, 96) and g.dtype == np.float32
    xs = np.arange(96) * 2.5
    zs = np.arange(40)[:, None] * 2.5
    p = rn.fbm(xs, zs, octaves=6, frequency=1 / 200.0, seed=9)
    assert np.array_equal(g, p)  # the row kernels and Noise::at agree bit for bit
    assert float(np.abs(g).max()) <= 1.0


def test_grid_origin_windows_tile():
    whole = rn.fbm(grid=(64, 64), octaves=5, frequency=1 / 50.0)
    part = rn.fbm(grid={"nx": 32, "nz": 16, "ix0": 20, "iz0": 30}, octaves=5, frequency=1 / 50.0)
    assert np.array_equal(whole[30:46, 20:52], part)


def test_out_and_threads():
    out = np.empty((200, 300), np.float32)
    r = rn.fbm(grid=(300, 200), out=out, threads=1, octaves=6, frequency=0.01)
    assert r is out
    b = rn.fbm(grid=(300, 200), threads=2, octaves=6, frequency=0.01)
    assert np.array_equal(out, b)


@pytest.mark.parametrize("basis", ["gradient", "perlin", "simplex", "value", "cellular"])
def test_every_basis(basis):
    v = rn.fbm(grid=(32, 32), basis=basis, octaves=3, frequency=0.05)
    assert np.isfinite(v).all() and float(np.abs(v).max()) <= 1.0 and float(v.std()) > 0.01


def test_ridged_and_billow():
    a = rn.ridged(grid=(32, 32), octaves=4, frequency=0.05)
    b = rn.billow(grid=(32, 32), octaves=4, frequency=0.05)
    assert not np.array_equal(a, b)
