# Run under mpirun by test_mpi.py: radiosity and thermal solves over MPI.COMM_WORLD (comm=), with
# F on rank 0 only; rank 0 checks the results against the one process's solve of the same F,
# the other ranks that they got None.
import sys

import numpy as np
from mpi4py import MPI

import formfactor

comm = MPI.COMM_WORLD
scene = formfactor.load("cube", subdivide=3)
n = len(scene)
# F over the communicator: rank 0 has it, the others None (and pass that on).
r = scene.form_factors("hemicube", resolution=64, threads=1, comm=comm)
eps = np.full(n, 0.8)
eps[:9] = 0.5
T = np.full(n, 300.0)
T[:9] = 1000.0
q = np.full(n, np.nan)
T[-3:] = np.nan
q[-3:] = 0.0  # adiabatic patches
thermal = dict(emissivity=eps, temperature=T, net_flux=q, threads=1)
radiosity = dict(reflectance=0.6, emission=np.linspace(0.0, 1.0, n), threads=1)
sparse = r.sparse() if comm.rank == 0 else None
checked = []


def over_ranks_and_alone(solve, F, **options):
    """The solve over the communicator and, on rank 0, the same solve on this process alone."""
    got = solve(scene, F, comm=comm, **options)
    if comm.rank != 0:
        assert got is None, (solve.__name__, options)
        return None, None
    return got, solve(scene, F, **options)


for F, kind in [(r, "dense"), (sparse, "sparse")]:
    for solver in ["gmres", "jacobi"]:
        got, one = over_ranks_and_alone(formfactor.solve_thermal, F, solver=solver, **thermal)
        if got is not None:
            for field in ["radiosity", "temperature", "net_flux", "net_power"]:
                assert np.array_equal(getattr(got, field), getattr(one, field)), (kind, solver,
                                                                                   field)
            assert got.stats["iterations"] == one.stats["iterations"], (kind, solver)
            checked.append(f"thermal {kind} {solver}")
        got, one = over_ranks_and_alone(formfactor.solve_radiosity, F, solver=solver, **radiosity)
        if got is not None:
            assert np.array_equal(got.radiosity, one.radiosity), (kind, solver)
            checked.append(f"radiosity {kind} {solver}")
    # Gauss-Seidel: block Jacobi between the ranks' blocks, so the same to the tolerance.
    got, one = over_ranks_and_alone(formfactor.solve_thermal, F, solver="gauss-seidel",
                                    residual=1e-12, **thermal)
    if got is not None:
        assert got.stats["converged"], got.stats
        scale = np.abs(one.radiosity).max()
        assert np.abs(got.radiosity - one.radiosity).max() <= 1e-9 * scale, kind
        # Block Jacobi between the ranks needs more sweeps: the rows were spread.
        assert got.stats["iterations"] > one.stats["iterations"], (got.stats, one.stats)
        checked.append(f"thermal {kind} gauss-seidel")
# The direct solve needs the whole F: rank 0 alone, the same result.
got, one = over_ranks_and_alone(formfactor.solve_thermal, r, solver="direct", **thermal)
if got is not None:
    assert np.array_equal(got.radiosity, one.radiosity)
    checked.append("thermal dense direct")
if comm.rank == 0:
    print(f"solved the same on {comm.size} ranks: {', '.join(checked)}")
sys.stdout.flush()
