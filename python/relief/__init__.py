"""Relief: procedural terrain from a seed and a recipe (Python front end of the C++ library).

    import relief
    t = relief.generate("island", seed=7, size=1025, threads=0)
    t.height                      # float32 (nz, nx) numpy view of the library's memory (no copy)
    t.layers["albedo"]            # (nz, nx, 3)
    t.props, t.rivers, t.lakes    # plain Python data
    t.write("out/", formats=["heightmap", "obj"])   # the CLI's writers, byte for byte
    png = t.encode("height.png")                 # bytes

Bad input raises relief.Error (a ValueError) whose .path names the field, as the CLI's messages do.
Long calls release the GIL; progress callbacks run on the calling thread; Ctrl-C cancels cleanly.
"""
from . import _relief
from ._relief import Error, Cancelled, Terrain, presets, preset, explain, writers, resolve, release_cached_buffers, __version__
from . import noise, compat

__all__ = ["generate", "Terrain", "Error", "Cancelled", "presets", "preset", "explain", "writers", "resolve",
           "release_cached_buffers", "noise", "compat", "__version__"]


def generate(recipe="island", seed=None, size=None, threads=0, set=None, progress=None):
    """Runs a recipe and returns a Terrain.

    recipe:   a preset name ("island"), a path to a recipe JSON file (str or pathlib.Path), or a dict.
    seed:     int in 0..2**53-1; None: the recipe's seed, else a random one (Terrain.seed tells).
    size:     N or (nx, nz) samples, corners included (as the CLI's --size).
    threads:  0 = all cores; the result is the same for any count.
    set:      overrides as the CLI's --set: {"stages[0].octaves": 8, "world.sea_level": 0.3}
              or ["stages[0].octaves=8", ...].
    progress: callable(what: str, fraction: float), called on this thread while the run goes on.
              Raising from it cancels the run (the exception propagates; nothing is left behind).
    """
    return _relief.generate(recipe, seed=seed, size=size, threads=threads, set=set, progress=progress)


def _layers(self):
    """Every layer as a dict name -> numpy view (see Terrain.layer)."""
    return {name: self.layer(name) for name in self.layer_names}


def _props(self):
    """The placed props: dicts with kind, type, x_m, y_m, z_m, rotation_deg, scale."""
    return [p for p in self.points if p["kind"] == "prop"]


def _features(self):
    """Feature points other than props (volcano, peaks, craters)."""
    return [p for p in self.points if p["kind"] != "prop"]


Terrain.layers = property(_layers)
Terrain.height = property(lambda self: self.layer("height"), doc="The elevation layer (normalised 0..1), shape (nz, nx).")
Terrain.props = property(_props)
Terrain.features = property(_features)
Terrain.__repr__ = lambda self: "<relief.Terrain %dx%d seed=%d layers=%s>" % (self.size + (self.seed, ",".join(self.layer_names)))
