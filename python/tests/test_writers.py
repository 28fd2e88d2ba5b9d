"""Terrain.write / Terrain.encode go through relief::generate and the CLI's writers: the same bytes
as `relief generate` for the same recipe and seed (report.json apart from its performance block)."""
import json
import pathlib
import subprocess

import pytest

import relief


def cli_files(binary, tmp, *args):
    out = tmp / "cli"
    subprocess.run([binary, "generate", *args, "-o", str(out), "-q"], check=True)
    return {p.name: p.read_bytes() for p in out.iterdir()}


def same_files(cli, py):
    assert sorted(cli) == sorted(py)
    for name in cli:
        if name == "report.json":
            a, b = json.loads(cli[name]), json.loads(py[name])
            a.pop("performance"), b.pop("performance")
            assert a == b
        else:
            assert cli[name] == py[name], name


@pytest.mark.parametrize("preset,size", [("island", 129), ("volcanic-island", 129)])
def test_write_matches_the_cli_byte_for_byte(relief_binary, tmp_path, preset, size):
    cli = cli_files(relief_binary, tmp_path, "--preset", preset, "--seed", "7", "--size", str(size))
    t = relief.generate(preset, seed=7, size=size)
    rep = t.write(str(tmp_path / "py"))
    py = {p.name: p.read_bytes() for p in (tmp_path / "py").iterdir()}
    same_files(cli, py)
    assert sorted(f["name"] for f in rep["files"]) == sorted(py)
    assert rep["seed"] == 7


def test_write_with_formats_and_options_matches_the_cli(relief_binary, tmp_path):
    cli = cli_files(relief_binary, tmp_path, "--preset", "island", "--seed", "3", "--size", "65", "--formats", "heightmap,glb",
                    "--set", "world.sea_level=0.35")
    t = relief.generate("island", seed=3, size=65, set={"world.sea_level": 0.35})
    t.write(str(tmp_path / "py"), formats=["heightmap", "glb"])
    py = {p.name: p.read_bytes() for p in (tmp_path / "py").iterdir()}
    same_files(cli, py)


def test_encode_gives_the_cli_bytes(relief_binary, tmp_path):
    cli = cli_files(relief_binary, tmp_path, "--preset", "island", "--seed", "7", "--size", "129")
    t = relief.generate("island", seed=7, size=129)
    assert t.encode("height.png") == cli["height.png"]
    assert t.encode("albedo") == cli["albedo.png"]
    files = t.encode("heightmap")  # a writer with several files: a dict
    assert isinstance(files, dict) and files["height.r16"] == cli["height.r16"]


def test_unknown_format_names_the_field():
    t = relief.generate("island", seed=1, size=33)
    with pytest.raises(relief.Error) as e:
        t.write("/tmp/never-written-relief", formats=["nosuch"])
    assert e.value.path == "formats"
    assert not pathlib.Path("/tmp/never-written-relief").exists()


def test_recipe_from_a_json_path(relief_binary, tmp_path):
    recipe = tmp_path / "r.json"
    recipe.write_text(json.dumps(relief.preset("hills")))
    a = relief.generate(recipe, seed=4, size=65)
    b = relief.generate(str(recipe), seed=4, size=65)
    c = relief.generate("hills", seed=4, size=65)
    assert (a.height == c.height).all() and (b.height == c.height).all()
