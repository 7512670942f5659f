# Run under mpirun by test_mpi.py: Scene.hierarchical(comm=...) builds the operator over
# MPI.COMM_WORLD. Every rank also builds it alone and checks that the products over the ranks are
# the one process's bit for bit (every rank gets them); rank 0 checks the solves over the ranks
# against the one process's solves, the other ranks that they got None.
import sys

import numpy as np
import scipy.sparse.linalg
from mpi4py import MPI

import formfactor

comm = MPI.COMM_WORLD
scene = formfactor.load("cube", subdivide=12)  # a closed room without obstructions, 864 patches
n = len(scene)
options = dict(tolerance=1e-6, eta=3.0, leaf_size=8, threads=1)
op = scene.hierarchical(comm=comm, **options)
one = scene.hierarchical(**options)  # this process alone
checked = []

assert op.comm is comm and one.comm is None
assert op.shape == one.shape == (n, n)
assert np.array_equal(op.areas, one.areas)
assert op.stats["ranks"] == comm.size
# Spread: every rank computed blocks and holds a run of them (the same counts on every rank).
held, computed = op.stats["blocks_held_per_rank"], op.stats["blocks_computed_per_rank"]
assert len(held) == len(computed) == comm.size and min(held) > 0 and min(computed) > 0, op.stats
assert sum(held) == sum(computed), op.stats
assert comm.allgather(held) == [held] * comm.size
for key in ["clusters", "leaves", "zero_blocks", "dense_blocks", "low_rank_blocks",
            "dense_values", "low_rank_values", "max_rank", "entries_computed"]:
    assert op.stats[key] == one.stats[key], (key, op.stats[key], one.stats[key])
# Compressed blocks with values, and many blocks, so that the ranks hold different parts.
assert one.stats["low_rank_values"] > 0 and one.stats["dense_blocks"] > 100, one.stats
assert np.array_equal(op.row_sums(), one.row_sums())

rng = np.random.default_rng(7)  # the same x on every rank
x = rng.random(n)
X = rng.random((n, 3))
assert np.array_equal(op @ x, one @ x)
assert np.array_equal(op.matvec(X, threads=1), one.matvec(X, threads=1))
assert np.abs(one @ x).max() > 0.1  # not a product of zeros
L, L1 = op.as_linear_operator(), one.as_linear_operator()
assert np.array_equal(L.matvec(x), L1.matvec(x))
assert np.array_equal(L.rmatvec(x), L1.rmatvec(x))
assert np.array_equal(op.per_surface(threads=1), one.per_surface(threads=1))
assert np.array_equal(op.to_dense(threads=1), one.to_dense(threads=1))
checked.append("products")

# SciPy's GMRES on every rank at once: each product over the ranks, the same on every rank.
emission = np.linspace(0.0, 1.0, n)


def radiosity_system(linear):
    return scipy.sparse.linalg.LinearOperator(
        (n, n), matvec=lambda b: b - 0.5 * linear.matvec(b), dtype=float)


b, info = scipy.sparse.linalg.gmres(radiosity_system(L), emission, atol=1e-12)
b1, info1 = scipy.sparse.linalg.gmres(radiosity_system(L1), emission, atol=1e-12)
assert info == info1 == 0 and np.array_equal(b, b1)
checked.append("scipy gmres")

# The library's solves over the ranks: rank 0 gets the result, the one process's bit for bit.
for solver in ["gmres", "jacobi"]:
    got = formfactor.solve_radiosity(scene, op, reflectance=0.6, emission=emission,
                                     solver=solver, threads=1, comm=comm)
    if comm.rank == 0:
        alone = formfactor.solve_radiosity(scene, one, reflectance=0.6, emission=emission,
                                           solver=solver, threads=1)
        assert np.array_equal(got.radiosity, alone.radiosity), solver
        assert got.stats["iterations"] == alone.stats["iterations"], solver
    else:
        assert got is None, solver
    checked.append(f"radiosity {solver}")
T = np.full(n, 300.0)
T[:n // 6] = 1000.0
got = formfactor.solve_thermal(scene, op, emissivity=0.8, temperature=T, threads=1, comm=comm)
if comm.rank == 0:
    alone = formfactor.solve_thermal(scene, one, emissivity=0.8, temperature=T, threads=1)
    for field in ["radiosity", "net_flux", "net_power"]:
        assert np.array_equal(getattr(got, field), getattr(alone, field)), field
else:
    assert got is None
checked.append("thermal gmres")

# Bad use: every rank raises the same error, and none waits for the others.
for comm_arg, message in [(None, "pass that communicator"), (comm.Dup(), "not the communicator")]:
    try:
        formfactor.solve_radiosity(scene, op, reflectance=0.6, emission=emission, comm=comm_arg)
    except formfactor.OptionError as e:
        assert message in str(e), str(e)
    else:
        raise AssertionError(f"solve with comm={comm_arg!r} was not refused")
    if comm_arg is not None:
        comm_arg.Free()
try:
    scene.hierarchical(0.0, comm=comm)
except formfactor.OptionError as e:
    assert str(e).startswith("tolerance: "), str(e)
else:
    raise AssertionError("tolerance 0 was accepted")
try:
    formfactor.load("room-2-obstruction").hierarchical(comm=comm)
except formfactor.Error as e:
    assert "obstruction" in str(e), str(e)
else:
    raise AssertionError("an obstructed scene was built over the ranks")
# A later build over the ranks replaces the operator: the older one's products are refused.
newer = scene.hierarchical(comm=comm, tolerance=1e-4, threads=1)
assert np.array_equal(newer.row_sums(), scene.hierarchical(tolerance=1e-4, threads=1).row_sums())
try:
    op @ x
except formfactor.Error as e:
    assert "replaced by a later build" in str(e), str(e)
else:
    raise AssertionError("the replaced operator's product ran")
checked.append("errors")

print(f"rank {comm.rank}: {', '.join(checked)}")
sys.stdout.flush()
comm.Barrier()
if comm.rank == 0:
    print(f"hierarchical the same on {comm.size} ranks")
sys.stdout.flush()
