# Run under mpirun by test_mpi.py: every rank computes F over MPI.COMM_WORLD; rank 0 checks that
# the result is bit for bit the one process's, the other ranks that they got None.
import sys

import numpy as np
from mpi4py import MPI

import formfactor

comm = MPI.COMM_WORLD
cases = [("room-4", "mc-hemisphere", {"samples": 500}),
         ("room-4", "hemicube", {"resolution": 64}),
         ("room-4-obstruction", "analytic", {})]
for name, method, options in cases:
    scene = formfactor.load(name)
    r = scene.form_factors(method, threads=1, comm=comm, **options)
    if comm.rank == 0:
        one = scene.form_factors(method, threads=1, **options)
        assert np.array_equal(r.matrix, one.matrix), (name, method)
        if one.standard_error is not None:
            assert np.array_equal(r.standard_error, one.standard_error), (name, method)
    else:
        assert r is None, (name, method)
# A call without comm under mpirun: each rank alone, as without mpirun.
alone = formfactor.load("room-2").form_factors("hemicube", resolution=64, threads=1)
assert alone.matrix.shape[0] == alone.matrix.shape[1] > 0
if comm.rank == 0:
    print(f"same on {comm.size} ranks")
sys.stdout.flush()
