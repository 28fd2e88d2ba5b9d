#!/usr/bin/python3
"""Python noise throughput: relief.compat.snoise2 and relief.noise.fbm against Debian's python3-noise.

    PYTHONPATH=build/python /usr/bin/python3 python/bench_noise.py [--size 1024] [--octaves 6] [--runs 5] [--threads 1,2]

Measured in the same run, over an N² grid at the given octaves:
  * the `noise` package the way seed 001's blog post uses it: a Python loop calling noise.snoise2 per
    sample (its cost is measured on a stripe of rows and scaled to the grid; the loop's cost per
    sample does not depend on the grid size);
  * relief.compat.snoise2 on the grid's coordinate arrays (the same values, bit for bit);
  * relief.noise.fbm(grid=…) with the gradient basis (the library's fast noise, not the same values).
Times are medians of --runs runs (wall time, and process CPU time: the work, whatever else the
machine runs; with 2 threads CPU time adds both), per thread count. Prints a table and, with --json,
the figures as JSON. Each target of issue 20 (on 1 thread: compat.snoise2 >= 50x, noise.fbm >= 100x
the loop) gets a line ending OK or MISSED.
"""
import argparse
import json
import os
import platform
import statistics
import sys
import time

import numpy as np

try:
    import relief
    import relief.compat
    import relief.noise
except ImportError:
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "build", "python"))
    import relief
    import relief.compat
    import relief.noise

import noise


CPU = {}  # fn name -> median process CPU time of the last median_time call (the work, whatever the load)


def median_time(fn, runs, key=None):
    times, cpu = [], []
    for _ in range(runs):
        c0, t0 = time.process_time(), time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    if key:
        CPU[key] = statistics.median(cpu)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--octaves", type=int, default=6)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--loop-rows", type=int, default=64, help="rows of the grid the per-sample loop runs over")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    n, octaves = a.size, a.octaves
    scale = 100.0
    xs, ys = np.meshgrid(np.arange(n, dtype=np.float64) / scale, np.arange(n, dtype=np.float64) / scale)

    def loop():
        rows = min(a.loop_rows, n)
        h = np.zeros((rows, n))
        for y in range(rows):
            for x in range(n):
                h[y][x] = noise.snoise2(x / scale, y / scale, octaves=octaves, persistence=0.5, lacunarity=2.0)
        return h

    loop_s = median_time(loop, max(1, a.runs // 2), "loop") * n / min(a.loop_rows, n)
    loop_cpu = CPU["loop"] * n / min(a.loop_rows, n)
    # Same values (a spot check on the first rows).
    rows = loop()
    got = relief.compat.snoise2(xs[: len(rows)], ys[: len(rows)], octaves=octaves)
    assert np.array_equal(got.astype(np.float64), rows), "compat.snoise2 differs from noise.snoise2"

    results = {"machine": {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
                           "simd": relief.noise.simd_target()},
               "grid": n, "octaves": octaves, "runs": a.runs, "noise_loop_s": loop_s, "noise_loop_cpu_s": loop_cpu,
               "load_average": os.getloadavg(), "cases": []}
    out32 = np.empty((n, n), np.float32)
    xs32, ys32 = xs.astype(np.float32), ys.astype(np.float32)
    for th in [int(t) for t in a.threads.split(",")]:
        relief.compat.threads = th
        compat_s = median_time(lambda: relief.compat.snoise2(xs32, ys32, octaves=octaves, out=out32), a.runs, "compat")
        compat64_s = median_time(lambda: relief.compat.snoise2(xs, ys, octaves=octaves, out=out32), a.runs)
        fbm_s = median_time(lambda: relief.noise.fbm(grid=(n, n), spacing=1.0, frequency=1.0 / scale, octaves=octaves,
                                                     basis="gradient", out=out32, threads=th), a.runs, "fbm")
        results["cases"].append({"threads": th, "compat_snoise2_s": compat_s, "compat_snoise2_float64_in_s": compat64_s,
                                 "fbm_gradient_s": fbm_s, "compat_speedup": loop_s / compat_s, "fbm_speedup": loop_s / fbm_s,
                                 "compat_cpu_s": CPU["compat"], "fbm_cpu_s": CPU["fbm"],
                                 "compat_cpu_speedup": loop_cpu / CPU["compat"], "fbm_cpu_speedup": loop_cpu / CPU["fbm"]})
    relief.compat.threads = 0
    # The targets of issue 20, on one thread (wall time; the loop is single-threaded too).
    one = [c for c in results["cases"] if c["threads"] == 1]
    results["targets"] = [{"what": what, "speedup": one[0][key], "goal": goal, "ok": one[0][key] >= goal}
                          for what, key, goal in [("compat.snoise2", "compat_speedup", 50), ("noise.fbm gradient", "fbm_speedup", 100)]
                          ] if one else []
    if a.json:
        print(json.dumps(results, indent=2))
        return
    print("machine: %s, %d hardware threads, SIMD target %s" % (results["machine"]["cpu"], results["machine"]["cores"],
                                                               results["machine"]["simd"]))
    print("%d² grid, %d octaves, medians of %d runs" % (n, octaves, a.runs))
    print("load average %.1f %.1f %.1f" % results["load_average"])
    print("noise.snoise2, Python loop per sample: %.3f s wall, %.3f s CPU (%.2f M samples/s)" % (loop_s, loop_cpu, n * n / loop_s / 1e6))
    print("| threads | compat.snoise2 (float32 in) | (float64 in) | vs noise loop (wall / CPU) | noise.fbm gradient | vs noise loop (wall / CPU) |")
    print("|---|---|---|---|---|---|")
    for c in results["cases"]:
        print("| %d | %.1f ms | %.1f ms | %.0f× / %.0f× | %.1f ms | %.0f× / %.0f× |" % (
            c["threads"], c["compat_snoise2_s"] * 1e3, c["compat_snoise2_float64_in_s"] * 1e3, c["compat_speedup"],
            c["compat_cpu_speedup"], c["fbm_gradient_s"] * 1e3, c["fbm_speedup"], c["fbm_cpu_speedup"]))
    if not results["targets"]:
        print("targets: not checked (run with --threads including 1)")
    for t in results["targets"]:
        print("%s, 1 thread: %.0f× the noise loop (goal >= %d×): %s" % (t["what"], t["speedup"], t["goal"], "OK" if t["ok"] else "MISSED"))
    missed = sum(not t["ok"] for t in results["targets"])
    print("%d target(s) missed" % missed if missed else "all targets met")


if __name__ == "__main__":
    main()
