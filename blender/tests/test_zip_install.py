"""Installs build/relief_blender.zip the way Preferences > Add-ons > Install does (into a scratch
user folder), enables it and builds a small island: the zip is self-contained (the compiled module
inside) and Blender's installer accepts it.

  PATH=/usr/bin:/bin blender -b --factory-startup --python-exit-code 1 \
      --python blender/tests/test_zip_install.py -- --zip build/relief_blender.zip --work DIR
"""
import os
import shutil
import sys

argv = sys.argv[sys.argv.index("--") + 1:]
ZIP = argv[argv.index("--zip") + 1]
WORK = argv[argv.index("--work") + 1]

import addon_utils  # noqa: E402
import bpy  # noqa: E402

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what, flush=True)


# BLENDER_USER_SCRIPTS and BLENDER_USER_CONFIG point at WORK (CTest sets them), so the installer
# writes there, never into a real user's configuration.
check(os.path.realpath(os.environ.get("BLENDER_USER_SCRIPTS", "")) == os.path.realpath(WORK),
      "BLENDER_USER_SCRIPTS is the scratch folder")
shutil.rmtree(os.path.join(WORK, "addons"), ignore_errors=True)
import zipfile  # noqa: E402
with zipfile.ZipFile(ZIP) as z:
    names = z.namelist()
check(all(n.startswith("relief_blender/") for n in names), "every path in the zip starts with relief_blender/")
check("relief_blender/__init__.py" in names, "the zip has the add-on's __init__.py")
check(any(n.startswith("relief_blender/relief/_relief") and n.endswith(".so") for n in names),
      "the zip has the compiled module")
check(not any("__pycache__" in n for n in names), "the zip has no __pycache__")
r = bpy.ops.preferences.addon_install(filepath=ZIP, overwrite=True)
check(r == {"FINISHED"}, "Preferences > Add-ons > Install accepts the zip")
target = os.path.join(WORK, "addons", "relief_blender")
check(os.path.isfile(os.path.join(target, "__init__.py")), "the add-on is installed in the user's add-ons folder")
r = bpy.ops.preferences.addon_enable(module="relief_blender")
check(r == {"FINISHED"}, "the installed add-on enables")
import relief_blender as mod  # noqa: E402
check(os.path.realpath(mod.__file__).startswith(os.path.realpath(target)), "it runs from the install folder")
if mod is not None:
    from relief_blender import core
    check(os.path.realpath(core.relief.__file__).startswith(os.path.realpath(target)),
          "it uses the module from the zip (%s)" % core.relief.__file__)
    s = bpy.context.scene.relief
    s.live = False
    check(bpy.ops.relief.preview(size=65) == {"FINISHED"}, "a 65² preview builds")
    ob = bpy.data.objects.get("Relief Terrain")
    check(ob is not None and len(ob.data.vertices) == 65 * 65, "the terrain has 65² vertices")
print("%d failure(s)" % len(failures))
if failures:
    sys.exit(1)
print("zip install: OK")
