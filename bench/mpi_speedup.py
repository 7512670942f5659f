#!/usr/bin/python3
"""formfactor on 2 MPI ranks x 1 thread against one process with 1 and 2 threads.

Runs each case as 1 x 1, 1 x 2 (--threads 2) and 2 x 1 (`mpirun --bind-to none -np 2`,
--threads 1), in turn, --runs times (1 x 1 and 2 x 1 alternating, so that a drift of the
machine's speed falls on both), and prints the median wall and CPU seconds of each, the
speed-up of 2 x 1 against 1 x 1 and its parallel efficiency. Every 2 x 1 output is compared with
the 1 x 1 output byte for byte (.npy and .h5 alike).
Run it on a quiet machine: the figures mean nothing when other work shares the cores.

Cases (--cases, default both):
  room-32   `compute room-32 --method analytic -o F.npy` (7,680 patches, a dense 472 MB F,
            767,560 partly hidden pairs);
  city-58   `compute city-58 --method mc-hemisphere --samples 4000 --threshold 1e-4 -o F.h5`
            (97,905 patches, an open city; a dense F would need 77 GB).

Open MPI's transport: on one machine the ranks talk through shared memory, and the benchmark
selects it (OMPI_MCA_pml=ob1, OMPI_MCA_btl=self,vader, unless set already); Open MPI's default
first probes UCX, which adds about 0.2 s to every start here. --default-transport keeps
Open MPI's choice.

Usage: bench/mpi_speedup.py [--formfactor build/bin/formfactor] [--runs 3] [--cases room-32]
       [--workdir DIR] [--mpirun 'mpirun --oversubscribe'] [--default-transport]
"""

import argparse
import os
import resource
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

CASES = {
    "room-32": ["compute", "room-32", "--method", "analytic", "-o", "{out}.npy"],
    "city-58": ["compute", "city-58", "--method", "mc-hemisphere", "--samples", "4000",
                "--threshold", "1e-4", "-o", "{out}.h5"],
}


def timed(cmd):
    """(wall seconds, CPU seconds of the children) of one run; exits on a failure."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit("failed (%d): %s\n%s" % (done.returncode, " ".join(cmd), done.stderr))
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--formfactor", default=str(REPO / "build" / "bin" / "formfactor"))
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--workdir", default=None)
    ap.add_argument("--mpirun", default="mpirun --oversubscribe")
    ap.add_argument("--default-transport", action="store_true",
                    help="keep Open MPI's choice of transport (it probes UCX first)")
    args = ap.parse_args()
    if not args.default_transport:
        os.environ.setdefault("OMPI_MCA_pml", "ob1")
        os.environ.setdefault("OMPI_MCA_btl", "self,vader")
    work = Path(args.workdir or tempfile.mkdtemp(prefix="ff-mpi-"))
    work.mkdir(parents=True, exist_ok=True)
    mpirun = shlex.split(args.mpirun) + ["--bind-to", "none", "-np", "2"]
    print("| case | 1 x 1 | 1 x 2 | 2 x 1 | 2 x 1 against 1 x 1 | same F |")
    print("|---|---|---|---|---|---|")
    for case in args.cases:
        def command(out, threads, ranks):
            cmd = [a.format(out=str(work / out)) for a in CASES[case]]
            cmd = [args.formfactor] + cmd + ["--threads", str(threads)]
            return mpirun + cmd if ranks > 1 else cmd
        one, two = [], []
        for _ in range(args.runs):
            one.append(timed(command(case + "-1x1", 1, 1)))
            two.append(timed(command(case + "-2x1", 1, 2)))
        threads = timed(command(case + "-1x2", 2, 1))
        w1, w2 = statistics.median(w for w, _ in one), statistics.median(w for w, _ in two)
        c1, c2 = statistics.median(c for _, c in one), statistics.median(c for _, c in two)
        ext = Path(CASES[case][-1]).suffix
        same = (work / (case + "-1x1" + ext)).read_bytes() == \
            (work / (case + "-2x1" + ext)).read_bytes()
        print("| %s | %.1f s (CPU %.1f s) | %.1f s | %.1f s (CPU %.1f s) | %.2fx, efficiency %d %% "
              "| %s |" % (case, w1, c1, threads[0], w2, c2, w1 / w2, round(50 * w1 / w2),
                          "yes" if same else "NO"))
        sys.stdout.flush()


if __name__ == "__main__":
    os.environ.setdefault("OMPI_MCA_rmaps_base_oversubscribe", "1")
    main()
