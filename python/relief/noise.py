"""Noise as array functions: the library's noise (the `noise` stage's bases and fractals) over numpy.

    import relief.noise as rn
    h = rn.fbm(grid=(1024, 1024), spacing=1.0, octaves=6, frequency=1/256)  # (nz, nx) float32
    v = rn.fbm(xs, zs, basis="gradient", octaves=6)                        # any broadcastable shapes

Coordinates are world metres; `frequency` is in cycles per metre of the first octave. A grid is
(nx, nz) samples at x = (ix0 + i)·spacing, z = (iz0 + j)·spacing, the same positions as a terrain's
samples, evaluated a block of rows at a time by the SIMD row kernels (much faster than points).
The GIL is released during the computation; `threads` (0 = all) never changes the values.
"""
import numpy as _np

from . import _relief

_DEFAULTS = dict(basis="gradient", fractal="fbm", octaves=6, frequency=1.0 / 1000.0, lacunarity=2.0, persistence=0.5,
                 scale_x=1.0, scale_z=1.0, warp_m=0.0, warp_frequency=1.0 / 1000.0, period_x_m=0.0, period_z_m=0.0,
                 cellular="f1", jitter=1.0, seed=0)


def _err(path, message):
    e = _relief.Error("%s: %s" % (path, message))
    e.path, e.message = path, message
    return e


def _out(out, shape):
    if out is None:
        return _np.empty(shape, dtype=_np.float32)
    if not isinstance(out, _np.ndarray) or out.dtype != _np.float32 or not out.flags.c_contiguous or out.shape != tuple(shape):
        raise _err("out", "expected a C-contiguous float32 array of shape %s" % (tuple(shape),))
    if not out.flags.writeable:
        raise _err("out", "the array is read-only")
    return out


def _grid(grid, spacing, origin):
    if isinstance(grid, dict):
        nx, nz = grid["nx"], grid["nz"]
        spacing = grid.get("spacing", spacing)
        origin = (grid.get("ix0", origin[0]), grid.get("iz0", origin[1]))
    elif isinstance(grid, int):
        nx = nz = grid
    else:
        nx, nz = grid
    for name, v in (("grid.nx", nx), ("grid.nz", nz)):
        if not isinstance(v, int) or isinstance(v, bool) or v < 1:
            raise _err(name, "expected a positive integer, got %r" % (v,))
    return int(nx), int(nz), float(spacing), int(origin[0]), int(origin[1])


def noise(x=None, z=None, *, grid=None, spacing=1.0, origin=(0, 0), out=None, threads=0, **settings):
    """Noise of any basis and fractal (see fbm for the settings); fractal="none" gives one octave."""
    s = dict(_DEFAULTS)
    for k in settings:
        if k not in _DEFAULTS:
            raise _err(k, "unknown noise setting (known: %s)" % ", ".join(sorted(_DEFAULTS)))
    s.update(settings)
    if grid is not None:
        if x is not None or z is not None:
            raise _err("grid", "give either x and z arrays or a grid, not both")
        nx, nz, sp, ix0, iz0 = _grid(grid, spacing, origin)
        o = _out(out, (nz, nx))
        _relief.noise_grid(s, nx, nz, sp, ix0, iz0, o, threads)
        return o
    if x is None or z is None:
        raise _err("x", "expected x and z arrays (or grid=…)")
    xb, zb = _np.broadcast_arrays(_np.asarray(x, dtype=_np.float64), _np.asarray(z, dtype=_np.float64))
    xs = _np.ascontiguousarray(xb)
    zs = _np.ascontiguousarray(zb)
    o = _out(out, xs.shape)
    _relief.noise_points(s, xs.reshape(-1), zs.reshape(-1), o.reshape(-1), threads)
    return o


def fbm(x=None, z=None, *, grid=None, spacing=1.0, origin=(0, 0), out=None, threads=0, basis="gradient", octaves=6,
        frequency=1.0 / 1000.0, lacunarity=2.0, persistence=0.5, seed=0, **settings):
    """Fractal Brownian motion in [-1, 1]: Σ aₖ·nₖ / Σ aₖ (aₖ = persistenceᵏ), the `noise` stage's noise.

    x, z:     arrays of world coordinates in metres (broadcast together), or
    grid:     (nx, nz) or N or {"nx", "nz", "spacing", "ix0", "iz0"}: samples at ((ix0+i)·spacing, (iz0+j)·spacing);
              the result has shape (nz, nx).
    basis:    "gradient" (the fast one), "perlin", "simplex", "value", "cellular".
    octaves 1..16, frequency (cycles per metre), lacunarity, persistence, seed; also scale_x, scale_z,
    warp_m, warp_frequency, period_x_m, period_z_m, cellular, jitter (relief explain noise).
    out:      a float32 array of the result's shape to write into (returned).
    threads:  0 = all cores (the values do not depend on it).
    Bad settings raise relief.Error naming the setting (e.g. .path == "octaves").
    """
    return noise(x, z, grid=grid, spacing=spacing, origin=origin, out=out, threads=threads, fractal="fbm", basis=basis,
                 octaves=octaves, frequency=frequency, lacunarity=lacunarity, persistence=persistence, seed=seed, **settings)


def ridged(x=None, z=None, **kw):
    """Ridged multifractal (same arguments as fbm)."""
    return noise(x, z, fractal="ridged", **kw)


def billow(x=None, z=None, **kw):
    """Billow (same arguments as fbm)."""
    return noise(x, z, fractal="billow", **kw)


simd_target = _relief.noise_simd_target
