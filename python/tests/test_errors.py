"""Bad input raises relief.Error (a ValueError) whose .path names the field, as the CLI's messages."""
import numpy as np
import pytest

import relief
import relief.compat
import relief.noise


def error_of(fn, *a, **kw):
    with pytest.raises(relief.Error) as e:
        fn(*a, **kw)
    assert isinstance(e.value, ValueError)
    assert str(e.value).startswith(e.value.path + ": ") if e.value.path else True
    return e.value


def test_out_of_range_parameter():
    e = error_of(relief.generate, "island", set={"stages[0].octaves": 40})
    assert e.path == "stages[0].octaves"
    assert "1..16" in e.message and "40" in e.message


def test_unknown_preset_names_the_nearest():
    e = error_of(relief.generate, "islnd")
    assert e.path == "preset" and "island" in e.message


def test_seed_and_size():
    assert error_of(relief.generate, "island", seed=-1).path == "seed"
    assert error_of(relief.generate, "island", seed=2**53).path == "seed"
    assert error_of(relief.generate, "island", seed=1.5).path == "seed"
    assert error_of(relief.generate, "island", size=1).path == "size"
    assert error_of(relief.generate, "island", size=(65, "x")).path == "size[1]"


def test_dict_recipes():
    doc = relief.preset("island")
    doc["stages"][0]["octaves"] = "six"
    assert error_of(relief.generate, doc).path == "stages[0].octaves"
    doc = relief.preset("island")
    doc["stages"][1]["stage"] = "nosuch"
    assert error_of(relief.generate, doc).path.startswith("stages[1]")
    assert error_of(relief.generate, {"world": {"size": 0}, "stages": []}).path.startswith("world.size")


def test_bad_override_path():
    assert error_of(relief.generate, "island", set={"stages[99].octaves": 3}).path.startswith("stages[99]")


def test_missing_recipe_file():
    assert error_of(relief.generate, "/nonexistent/recipe.json").path == "recipe"


def test_noise_settings():
    assert error_of(relief.noise.fbm, grid=(8, 8), octaves=40).path == "octaves"
    assert error_of(relief.noise.fbm, grid=(8, 8), basis="nosuch").path == "basis"
    assert error_of(relief.noise.fbm, grid=(8, 8), lacunarity=-1.0).path == "lacunarity"
    assert error_of(relief.noise.fbm, grid=(8, 8), out=np.zeros((4, 4), np.float32)).path == "out"
    assert error_of(relief.noise.fbm, grid=(8, 8), bogus=1).path == "bogus"


def test_compat_octaves():
    assert error_of(relief.compat.snoise2, 0.5, 0.5, octaves=0).path == "octaves"
    assert error_of(relief.compat.pnoise3, 0.5, 0.5, 0.5, octaves=-1).path == "octaves"


def test_writer_options_name_the_option(tmp_path):
    t = relief.generate("island", seed=1, size=33)
    out = tmp_path / "out"
    assert error_of(t.write, str(out), options={"engine": "bogus"}).path == "options.engine"
    assert error_of(t.write, str(out), options={"nosuch": 1}).path == "options.nosuch"
    assert not out.exists()
