#!/usr/bin/env python3
"""What calling formfactor through Python costs (docs/benchmarks.md).

Runs the same computation through the CLI and through the Python module, interleaved, and
prints medians:
  - the CLI's own "compute" step (from its --report) and its whole process wall time;
  - the Python call `scene.form_factors()` (wall, from the call to the returned Result) and the
    compute step the library timed inside it: the difference is the binding's cost (GIL
    release, the waiting thread, the report);
  - the cost of `result.matrix` (a view) against `np.array(result.matrix)` (a copy).

usage: PYTHONPATH=build/python python3 bench/python_overhead.py [--cli build/bin/formfactor]
       [--scene cube] [--subdivide 13] [--method analytic] [--threads 2] [--repeats 5]
"""

import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time

import numpy as np

import formfactor as ff


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", default="build/bin/formfactor")
    ap.add_argument("--scene", default="cube")
    ap.add_argument("--subdivide", type=int, default=13)  # 6·13² = 1,014 patches
    ap.add_argument("--method", default="analytic")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()

    scene = ff.load(a.scene, subdivide=a.subdivide)
    cli_compute, cli_wall, py_wall, py_compute = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        out, rep = os.path.join(tmp, "F.npy"), os.path.join(tmp, "r.json")
        for k in range(a.repeats):
            t = time.perf_counter()
            subprocess.run([a.cli, "compute", a.scene, "--subdivide", str(a.subdivide),
                            "--method", a.method, "--threads", str(a.threads), "-o", out,
                            "--report", rep], check=True, capture_output=True)
            cli_wall.append(time.perf_counter() - t)
            cli_compute.append(json.load(open(rep))["timings"]["compute"])
            t = time.perf_counter()
            r = scene.form_factors(method=a.method, threads=a.threads)
            py_wall.append(time.perf_counter() - t)
            py_compute.append(r.report["timings"]["compute"])
            if k == 0:
                same = np.array_equal(np.load(out), r.matrix)
    t = time.perf_counter()
    for _ in range(1000):
        m = r.matrix
    view = (time.perf_counter() - t) / 1000
    t = time.perf_counter()
    c = np.array(r.matrix)
    copy = time.perf_counter() - t
    med = statistics.median
    n = len(scene)
    print("scene %s, %d patches, %s, %d threads, %d repeats (medians)"
          % (a.scene, n, a.method, a.threads, a.repeats))
    print("CLI    compute step %.3f s   whole process %.3f s" % (med(cli_compute), med(cli_wall)))
    print("Python compute step %.3f s   form_factors() call %.3f s" % (med(py_compute), med(py_wall)))
    print("ratio Python call / CLI compute step: %.3f" % (med(py_wall) / med(cli_compute)))
    print("call − its compute step (the pipeline's diagnostics, O(N²), and the binding): %.1f ms"
          % (1e3 * med(w - c for w, c in zip(py_wall, py_compute))))
    print("result.matrix: %.2f µs (a view of %.1f MB, shares memory: %s); np.array copy: %.2f ms"
          % (1e6 * view, m.nbytes / 1e6, np.shares_memory(m, r.matrix), 1e3 * copy))
    print("same matrix as the CLI, bit for bit: %s" % same)
    del c


if __name__ == "__main__":
    main()
