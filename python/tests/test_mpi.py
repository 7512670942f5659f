"""formfactor under mpirun with mpi4py (comm=): the same F, solutions and hierarchical operator's
products on 1, 2 and 3 ranks."""
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import formfactor

HERE = os.path.dirname(os.path.abspath(__file__))


def _mpirun():
    launcher = shutil.which("mpirun")
    if launcher is None:
        pytest.skip("no mpirun")
    try:
        import mpi4py  # noqa: F401
    except ImportError:
        pytest.skip("no mpi4py")
    if not formfactor._core.built_with_mpi:
        pytest.skip("formfactor built without MPI")
    command = [launcher, "--oversubscribe", "--bind-to", "none"]
    if os.geteuid() == 0:
        command.append("--allow-run-as-root")
    return command


def _run_script(script, ranks, env=None):
    """`script` (in this folder) under mpirun with `ranks` ranks; fails the test unless it
    exits 0. Returns what it printed. `env`: variables exported to every rank."""
    extra = []
    for name in env or {}:
        extra += ["-x", name]
    done = subprocess.run(_mpirun() + extra + ["-np", str(ranks), sys.executable,
                                                os.path.join(HERE, script)],
                          capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, **(env or {})))
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


@pytest.mark.parametrize("ranks", [2, 3])
def test_form_factors_over_a_communicator_equal_one_process(ranks):
    assert f"same on {ranks} ranks" in _run_script("mpi_compute.py", ranks)


@pytest.mark.parametrize("ranks", [2, 3])
def test_solves_over_a_communicator_equal_one_process(ranks):
    out = _run_script("mpi_solve.py", ranks)
    assert f"solved the same on {ranks} ranks" in out
    # Every case ran: thermal and radiosity, dense and sparse, each iterative solver, direct.
    assert out.count("gmres") == 4 and out.count("jacobi") == 4
    assert "thermal sparse gauss-seidel" in out
    assert "thermal dense direct" in out


@pytest.mark.parametrize("ranks", [2, 3])
def test_hierarchical_operator_over_a_communicator_equals_one_process(ranks):
    out = _run_script("mpi_hierarchical.py", ranks)
    assert f"hierarchical the same on {ranks} ranks" in out
    # Every rank checked its products (every rank gets them), the solves and the errors.
    for rank in range(ranks):
        assert (f"rank {rank}: products, scipy gmres, radiosity gmres, radiosity jacobi, "
                "thermal gmres, errors") in out, out


@pytest.mark.parametrize("ranks", [2, 3])
def test_a_rank_failing_in_a_product_on_the_operator_raises_on_every_rank(ranks):
    failing = ranks - 1
    out = _run_script("mpi_hierarchical_failure.py", ranks,
                      env={"FORMFACTOR_TEST_FAIL_SOLVE_RANK": str(failing)})
    for rank in range(ranks):
        assert f"rank {rank}: the failure of rank {failing} raised" in out, out


def test_hierarchical_over_one_rank_equals_the_operator_alone():
    pytest.importorskip("mpi4py")
    if not formfactor._core.built_with_mpi:
        pytest.skip("formfactor built without MPI")
    from mpi4py import MPI
    scene = formfactor.load("cube", subdivide=4)
    op = scene.hierarchical(leaf_size=8, threads=1, comm=MPI.COMM_SELF)
    one = scene.hierarchical(leaf_size=8, threads=1)
    x = np.linspace(0.0, 1.0, len(scene))
    assert op.comm is MPI.COMM_SELF and op.stats["ranks"] == 1
    assert np.array_equal(op @ x, one @ x)
    got = formfactor.solve_radiosity(scene, op, reflectance=0.5, emission=x, comm=MPI.COMM_SELF)
    alone = formfactor.solve_radiosity(scene, one, reflectance=0.5, emission=x)
    assert np.array_equal(got.radiosity, alone.radiosity)
    # The operator over a communicator is solved over it: not without, nor over another.
    with pytest.raises(formfactor.OptionError, match="pass that communicator as comm="):
        formfactor.solve_radiosity(scene, op, reflectance=0.5, emission=x)
    with pytest.raises(formfactor.OptionError, match="not the communicator F was built over"):
        formfactor.solve_radiosity(scene, op, reflectance=0.5, emission=x, comm=MPI.COMM_WORLD)


def test_hierarchical_with_a_comm_that_is_no_communicator_is_refused():
    scene = formfactor.load("room-2")
    with pytest.raises(formfactor.OptionError, match="comm: must be an mpi4py communicator"):
        scene.hierarchical(comm="world")


def test_solve_with_a_comm_that_is_no_communicator_is_refused():
    scene = formfactor.load("room-2")
    r = scene.form_factors("hemicube", resolution=64)
    with pytest.raises(formfactor.OptionError, match="comm"):
        formfactor.solve_thermal(scene, r, solver="gmres", comm="world")


def test_comm_with_rows_is_refused():
    pytest.importorskip("mpi4py")
    from mpi4py import MPI
    scene = formfactor.load("room-2")
    with pytest.raises(formfactor.OptionError, match="rows"):
        scene.form_factors("hemicube", rows=(0, 2), comm=MPI.COMM_SELF)
