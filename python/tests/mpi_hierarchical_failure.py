# Run under mpirun by test_mpi.py with FORMFACTOR_TEST_FAIL_SOLVE_RANK=K: rank K fails in every
# product on the operator built over MPI.COMM_WORLD. Every rank raises rank K's error for a
# product, rank 0 for a solve (the other ranks get None), and the ranks go on together.
import os
import sys

import numpy as np
from mpi4py import MPI

import formfactor

comm = MPI.COMM_WORLD
failing = int(os.environ["FORMFACTOR_TEST_FAIL_SOLVE_RANK"])
scene = formfactor.load("cube", subdivide=6)
op = scene.hierarchical(leaf_size=8, threads=1, comm=comm)
expected = f"rank {failing}: a failure injected on rank {failing}"
try:
    op @ np.ones(len(scene))
except formfactor.Error as e:
    assert expected in str(e), str(e)
else:
    raise AssertionError("the product did not fail")
try:
    got = formfactor.solve_radiosity(scene, op, reflectance=0.5, emission=1.0, comm=comm)
except formfactor.Error as e:
    assert comm.rank == 0 and expected in str(e), (comm.rank, str(e))
else:
    assert comm.rank != 0 and got is None, comm.rank
comm.Barrier()
print(f"rank {comm.rank}: the failure of rank {failing} raised")
sys.stdout.flush()
