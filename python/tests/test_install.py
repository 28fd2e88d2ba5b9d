"""The installed package: `cmake --install build --component python --prefix DIR` puts a working
`relief` under DIR/RELIEF_PYTHON_INSTALL_DIR (python/CMakeLists.txt), importable by /usr/bin/python3
without the build tree."""
import os
import pathlib
import re
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def build_dir():
    d = pathlib.Path(os.environ.get("RELIEF_BUILD_DIR") or ROOT / "build")
    if not (d / "CMakeCache.txt").is_file():
        pytest.skip("no configured build directory at %s" % d)
    return d


def cache_value(build, key):
    m = re.search(r"^%s:[A-Z]+=(.*)$" % re.escape(key), (build / "CMakeCache.txt").read_text(), re.M)
    assert m, "%s is not in %s/CMakeCache.txt" % (key, build)
    return m.group(1)


SCRIPT = r"""
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
import relief, relief.compat, relief.noise
assert relief.__file__.startswith(sys.argv[1]), relief.__file__
t = relief.generate("island", seed=5, size=33, threads=1)
assert t.size == (33, 33) and t.height.shape == (33, 33) and np.isfinite(t.height).all()
assert t.encode("height.png")[:8] == b"\x89PNG\r\n\x1a\n"
assert isinstance(relief.compat.snoise2(0.3, 0.7, octaves=3), float)
print("installed relief OK", relief.__file__)
"""


def test_cmake_install_component_python(tmp_path):
    build = build_dir()
    cmake = shutil.which("cmake")
    assert cmake, "cmake is not on PATH"
    prefix = tmp_path / "prefix"
    r = subprocess.run([cmake, "--install", str(build), "--component", "python", "--prefix", str(prefix)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    site = prefix / cache_value(build, "RELIEF_PYTHON_INSTALL_DIR")
    pkg = site / "relief"
    names = sorted(p.name for p in pkg.iterdir())
    assert "__init__.py" in names and "compat.py" in names and "noise.py" in names, names
    assert any(n.startswith("_relief.") and n.endswith(".so") for n in names), names
    # Only the python component: nothing else lands in the prefix (no CLI, no headers).
    assert sorted(p.name for p in prefix.iterdir()) == ["lib"]
    # A fresh /usr/bin/python3, isolated (-I: no PYTHONPATH, no user site, no current directory), so
    # the build tree cannot be what gets imported.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    r = subprocess.run(["/usr/bin/python3", "-I", "-c", SCRIPT, str(site)], capture_output=True, text=True,
                       cwd=str(tmp_path), env=env, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "installed relief OK " + str(pkg) in r.stdout
