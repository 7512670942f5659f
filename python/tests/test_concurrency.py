"""The GIL is released while C++ computes; Ctrl-C interrupts a long computation promptly; a
progress callback sees the phases, and an exception it raises stops the computation."""

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import formfactor as ff


def test_other_python_threads_run_while_it_computes():
    scene = ff.load("cornell", subdivide=2)  # about a second on one thread
    started = threading.Event()
    done = threading.Event()
    count = [0]
    seen = {}

    def progress(phase, done_units, total, elapsed):
        started.set()

    def work():
        r = scene.form_factors(threads=1, progress=progress)
        seen["count_at_end"] = count[0]
        seen["matrix"] = r.matrix
        done.set()

    t = threading.Thread(target=work)
    t.start()
    assert started.wait(60)
    while not done.is_set():
        count[0] += 1  # Python bytecode in this thread, while the other is inside C++
        time.sleep(0.001)
    t.join()
    # With the GIL held through the computation this loop could not have run before it ended.
    assert seen["count_at_end"] > 20
    assert np.array_equal(seen["matrix"], scene.form_factors(threads=1).matrix)


def test_two_threads_compute_at_once_and_agree():
    scenes = [ff.load("cornell", subdivide=2), ff.load("room-4-obstruction")]
    expected = [s.form_factors(threads=1).matrix for s in scenes]
    out = [None, None]

    def work(k):
        out[k] = scenes[k].form_factors(threads=1).matrix

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in range(2):
        assert np.array_equal(out[k], expected[k])


def test_ctrl_c_interrupts_a_long_computation():
    script = textwrap.dedent("""
        import sys, time
        import formfactor as ff
        scene = ff.load("cornell", subdivide=12)     # minutes of work on one thread
        print("ready", flush=True)
        try:
            scene.form_factors(threads=1)
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(0)
        print("finished", flush=True)
        sys.exit(1)
    """)
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=os.environ)
    assert p.stdout.readline().strip() == "ready"
    time.sleep(1.0)
    sent = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    waited = time.monotonic() - sent
    assert p.returncode == 0, err
    assert out.strip() == "interrupted"
    assert waited < 10, "took %.1f s to stop" % waited


def test_progress_callback_and_its_exceptions():
    scene = ff.load("cornell", subdivide=2)
    calls = []
    scene.form_factors(progress=lambda *a: calls.append(a))
    assert calls and all(len(c) == 4 for c in calls)
    phase, done, total, elapsed = calls[-1]
    assert isinstance(phase, str) and done == total and elapsed >= 0

    class Stop(Exception):
        pass

    def stop(*a):
        raise Stop()

    with pytest.raises(Stop):
        ff.load("cornell", subdivide=3).form_factors(threads=1, progress=stop)


def _last_phase(calls):
    assert calls and all(len(c) == 4 for c in calls)
    phase, done, total, elapsed = calls[-1]
    assert done == total and elapsed >= 0
    return phase


@pytest.mark.parametrize("solver", ["gauss-seidel", "jacobi", "shooting", "direct", "gmres"])
def test_solvers_report_progress_to_the_callback(solver):
    scene = ff.load("cornell", subdivide=2)
    r = scene.form_factors()
    calls = []
    ff.solve_radiosity(scene, r, solver=solver, progress=lambda *a: calls.append(a))
    assert _last_phase(calls).startswith("solve (")
    calls.clear()
    ff.solve_thermal(scene, r, emissivity=0.5, temperature=300.0, solver=solver,
                     progress=lambda *a: calls.append(a))
    assert _last_phase(calls).startswith("solve")


def test_solvers_on_an_operator_or_a_sparse_matrix_report_progress():
    scene = ff.load("cube", subdivide=3)
    for F in (scene.hierarchical(1e-6), scene.form_factors().sparse()):
        calls = []
        ff.solve_radiosity(scene, F, reflectance=0.5, emission=1.0,
                           progress=lambda *a: calls.append(a))
        assert _last_phase(calls).startswith("solve")


def test_point_factors_report_progress_to_the_callback():
    scene = ff.load("cornell", subdivide=2)
    calls = []
    pts = np.array([[0.5, 0.5, 0.01], [0.2, 0.3, 0.01]]) * np.ptp(scene.centroids, axis=0).max()
    ff.point_factors(scene, pts, [0, 0, 1.0], progress=lambda *a: calls.append(a))
    assert _last_phase(calls) == "point factors"
    _, _, total, _ = calls[-1]
    assert total == 2 * len(scene)


def test_an_exception_in_a_solve_progress_callback_reaches_the_caller():
    scene = ff.load("cornell", subdivide=2)
    r = scene.form_factors()

    class Stop(Exception):
        pass

    def stop(*a):
        raise Stop()

    with pytest.raises(Stop):
        ff.solve_radiosity(scene, r, solver="shooting", residual=1e-14, progress=stop)
