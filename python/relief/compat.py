"""Drop-in for the `noise` package (Casey Duncan's noise 1.2.3, Debian python3-noise):

    import relief.compat as noise
    noise.snoise2(x / SCALE, y / SCALE, octaves=6, persistence=0.5, lacunarity=2, repeatx=1024, repeaty=1024, base=seed)

snoise2, snoise3, pnoise2, pnoise3 take the package's arguments with its defaults and return the
package's values bit for bit (float32 arithmetic in the package's order; relief/noise_classic.hpp
in the C++ library says how, and where pnoise with base >= 2 may differ: a few cells where the
package reads past its permutation table). With Python numbers they return a float, as the
package does; with numpy arrays (or anything array-like, broadcast together) they return a float32
array of the broadcast shape, computed in C++ without the GIL, vectorised (AVX-512/AVX2 where
available) and spread over `relief.compat.threads` threads (0 = all cores; the values never depend
on it). `out=` (keyword only, a C-contiguous float32 array of that shape) receives the result.

Differences from the package: octaves <= 0 raises relief.Error (a ValueError, as the package's) with
.path "octaves"; repeatx=None / repeaty=None (snoise2's defaults) may also be passed explicitly.
"""
import numbers as _numbers

import numpy as _np

from . import _relief

threads = 0  # threads for array calls: 0 = all cores

_NO_REPEAT = 3.4028234663852886e38  # FLT_MAX: the package's "no repeat"


def _err(path, message):
    e = _relief.Error("%s: %s" % (path, message))
    e.path, e.message = path, message
    return e


def _octaves(octaves):
    if isinstance(octaves, bool) or not isinstance(octaves, _numbers.Integral):
        raise TypeError("octaves: expected an integer, got %r" % (octaves,))
    if octaves <= 0:
        raise _err("octaves", "Expected octaves value > 0, got %d" % octaves)
    return int(octaves)


def _is_scalar(*values):
    return all(isinstance(v, _numbers.Real) and not isinstance(v, _np.ndarray) for v in values)


def _arrays(out, *values, dtype=_np.float32):
    arrays = _np.broadcast_arrays(*[_np.asarray(v, dtype=dtype) for v in values])
    shape = arrays[0].shape
    flat = [_np.ascontiguousarray(a).reshape(-1) for a in arrays]
    if out is None:
        out = _np.empty(shape, dtype=_np.float32)
    elif not isinstance(out, _np.ndarray) or out.dtype != _np.float32 or out.shape != shape or not out.flags.c_contiguous:
        raise _err("out", "expected a C-contiguous float32 array of shape %s" % (shape,))
    return flat, out


def _repeat(r):
    return _NO_REPEAT if r is None else float(r)


def snoise2(x, y, octaves=1, persistence=0.5, lacunarity=2.0, repeatx=None, repeaty=None, base=0.0, *, out=None):
    """Simplex noise 2D, as noise.snoise2: fractal sum of `octaves` octaves (amplitude persistence**k,
    frequency lacunarity**k) divided by the amplitude sum; `base` offsets x and y; repeatx/repeaty make
    the noise tile with that period (sampled on a circle in 3D/4D noise, as the package does)."""
    octaves = _octaves(octaves)
    if _is_scalar(x, y):
        return _relief.snoise2(x, y, octaves, persistence, lacunarity, _repeat(repeatx), _repeat(repeaty), base)
    if all(isinstance(v, _np.ndarray) and v.dtype == _np.float64 for v in (x, y)):
        # numpy's default dtype: rounded to float32 in C++ chunk by chunk (no full-size copies).
        (xs, ys), o = _arrays(out, x, y, dtype=_np.float64)
        _relief.snoise2_array64(xs, ys, octaves, persistence, lacunarity, _repeat(repeatx), _repeat(repeaty), base, o.reshape(-1),
                                threads)
        return o
    (xs, ys), o = _arrays(out, x, y)
    _relief.snoise2_array(xs, ys, octaves, persistence, lacunarity, _repeat(repeatx), _repeat(repeaty), base, o.reshape(-1), threads)
    return o


def snoise3(x, y, z, octaves=1, persistence=0.5, lacunarity=2.0, *, out=None):
    """Simplex noise 3D, as noise.snoise3."""
    octaves = _octaves(octaves)
    if _is_scalar(x, y, z):
        return _relief.snoise3(x, y, z, octaves, persistence, lacunarity)
    (xs, ys, zs), o = _arrays(out, x, y, z)
    _relief.snoise3_array(xs, ys, zs, octaves, persistence, lacunarity, o.reshape(-1), threads)
    return o


def _int(name, v):
    if isinstance(v, bool) or not isinstance(v, _numbers.Integral):
        raise TypeError("%s: expected an integer, got %r" % (name, v))
    return int(v)


def pnoise2(x, y, octaves=1, persistence=0.5, lacunarity=2.0, repeatx=1024, repeaty=1024, base=0, *, out=None):
    """Perlin "improved" noise 2D, as noise.pnoise2: tiles every repeatx/repeaty (default 1024); `base`
    (an int) picks another stretch of the permutation table."""
    octaves = _octaves(octaves)
    base = _int("base", base)
    if _is_scalar(x, y):
        return _relief.pnoise2(x, y, octaves, persistence, lacunarity, float(repeatx), float(repeaty), base)
    (xs, ys), o = _arrays(out, x, y)
    _relief.pnoise2_array(xs, ys, octaves, persistence, lacunarity, float(repeatx), float(repeaty), base, o.reshape(-1), threads)
    return o


def pnoise3(x, y, z, octaves=1, persistence=0.5, lacunarity=2.0, repeatx=1024, repeaty=1024, repeatz=1024, base=0, *, out=None):
    """Perlin "improved" noise 3D, as noise.pnoise3 (integer repeats, default 1024; integer base)."""
    octaves = _octaves(octaves)
    rx, ry, rz, base = (_int("repeatx", repeatx), _int("repeaty", repeaty), _int("repeatz", repeatz), _int("base", base))
    if _is_scalar(x, y, z):
        return _relief.pnoise3(x, y, z, octaves, persistence, lacunarity, rx, ry, rz, base)
    (xs, ys, zs), o = _arrays(out, x, y, z)
    _relief.pnoise3_array(xs, ys, zs, octaves, persistence, lacunarity, rx, ry, rz, base, o.reshape(-1), threads)
    return o


__all__ = ["snoise2", "snoise3", "pnoise2", "pnoise3", "threads"]
