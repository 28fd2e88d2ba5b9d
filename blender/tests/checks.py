"""What the Blender test scripts share: checks that record failures instead of stopping, and the
ending that prints them and exits 1 if any (blender's --python-exit-code turns that into CTest's
failure)."""
import sys

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what, flush=True)
    return cond


def finish(name):
    print("\n%d failure(s)" % len(failures))
    for f in failures:
        print("  -", f)
    if failures:
        sys.exit(1)
    print(name + ": OK")
