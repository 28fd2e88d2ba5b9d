"""Shared fixtures: the `relief` package from the build tree and the CLI binary next to it.

Run through CTest (`ctest -L python`), which sets PYTHONPATH to build/python and RELIEF_BINARY, or
by hand: PYTHONPATH=build/python /usr/bin/python3 -m pytest python/tests
"""
import os
import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
if "PYTHONPATH" not in os.environ and (ROOT / "build" / "python").is_dir():
    sys.path.insert(0, str(ROOT / "build" / "python"))


@pytest.fixture(scope="session")
def relief_binary():
    b = os.environ.get("RELIEF_BINARY") or str(ROOT / "build" / "relief")
    if not os.path.exists(b):
        pytest.skip("the relief binary is not built")
    return b
