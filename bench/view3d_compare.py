#!/usr/bin/python3
"""formfactor against View3D 3.2, side by side on the same VS3 files.

Writes the obstructed benchmark scenes as View3D 3.2 input (`F 3`, every patch its own surface,
so that both programs report the same matrix):
  room-N-S   the unit room, faces N x N inward, with the floating box [0.3,0.7]^2 x [0.1,0.5] as
             radiating S records (faces (N/2) x (N/2)): the built-in `room-N`;
  room-N-O   the same room with the box as six whole O records: `room-N-obstruction`
             (--o-split: (N/2) x (N/2) O records per face, as tests/data/repro/ has them);
  cornell-M  the Cornell box (formfactor's built-in `cornell`, 20 surfaces) M x M per surface;
  urban-N    N x N box buildings of random heights on a ground, every rectangle two triangles;
  sphere-M, cylinder-M  a faceted sphere or cylinder (triangles) in a closed box room;
  with --triangulate the rooms and the Cornell box have every quad as two triangles (`-tri`).
runs `view3d IN.vs3 OUT` (list=0, out=1: its binary float32 matrix; encl=0: no enclosure
adjustment, the raw matrix) and `formfactor compute IN.vs3 -o F.npy --threads 1` on each, and
prints wall and CPU times, peak memory and the differences between the two matrices (every
surface pair: both programs compute the same rows and columns).

View3D is not part of this project's build: pass its binary with --view3d or $VIEW3D. NREL's
View3D 3.2 (github.com/NREL/View3D-3.2) ships only a Visual Studio project; on Linux the sources
that project lists (src/*.c except readvf.c) build with
  cc -O2 -D_MAX_PATH=260 -Dstrcmpi=strcasecmp -include strings.h -o view3d \
     $(ls src/*.c | grep -v readvf.c) -lm
View3D writes VIEW3D.LOG into its working directory: each case runs in the work folder.

Usage: bench/view3d_compare.py --view3d PATH [--rooms 16 32] [--cornell 12] [--workdir DIR]
Needs numpy (/usr/bin/python3 on Debian).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent


# --- geometry -------------------------------------------------------------------------------


def grid_quads(o, e1, e2, m):
    """The m x m quads of the parallelogram o + [0,1] e1 + [0,1] e2 (front e1 x e2), row-major,
    as formfactor's room_scene() and subdivide() number them."""
    out = []
    for j in range(m):
        for i in range(m):
            def at(a, b):
                return tuple(o[k] + (a * e1[k] + b * e2[k]) / m for k in range(3))
            out.append([at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)])
    return out


def room(n, box, o_split=False):
    """(S polygons, O polygons) of the room n x n with the box as 'S', 'O' or None; O records
    are the six whole faces, or (n/2) x (n/2) pieces each with o_split."""
    faces = [((0, 0, 0), (0, 1, 0), (0, 0, 1)), ((1, 0, 0), (0, 0, 1), (0, 1, 0)),
             ((0, 0, 0), (0, 0, 1), (1, 0, 0)), ((0, 1, 0), (1, 0, 0), (0, 0, 1)),
             ((0, 0, 0), (1, 0, 0), (0, 1, 0)), ((0, 0, 1), (0, 1, 0), (1, 0, 0))]
    s = [q for o, e1, e2 in faces for q in grid_quads(o, e1, e2, n)]
    o = []
    if box:
        lo, e = (0.3, 0.3, 0.1), 0.4

        def add(v, w):
            return tuple(a + b for a, b in zip(v, w))
        bf = [(lo, (0, 0, e), (0, e, 0)), (add(lo, (e, 0, 0)), (0, e, 0), (0, 0, e)),
              (lo, (e, 0, 0), (0, 0, e)), (add(lo, (0, e, 0)), (0, 0, e), (e, 0, 0)),
              (lo, (0, e, 0), (e, 0, 0)), (add(lo, (0, 0, e)), (e, 0, 0), (0, e, 0))]
        m = n // 2 if box == 'S' or o_split else 1
        pieces = [q for p, e1, e2 in bf for q in grid_quads(p, e1, e2, m)]
        (s if box == 'S' else o).extend(pieces)
    return s, o


# formfactor's built-in Cornell box (src/scene/builtin_scenes.cpp), millimetres.
Y = 548.8
CORNELL = [
    [(552.8, 0, 0), (0, 0, 0), (0, 0, 559.2), (549.6, 0, 559.2)],
    [(556, Y, 0), (556, Y, 227), (0, Y, 227), (0, Y, 0)],
    [(556, Y, 332), (556, Y, 559.2), (0, Y, 559.2), (0, Y, 332)],
    [(556, Y, 227), (556, Y, 332), (343, Y, 332), (343, Y, 227)],
    [(213, Y, 227), (213, Y, 332), (0, Y, 332), (0, Y, 227)],
    [(343, Y, 227), (343, Y, 332), (213, Y, 332), (213, Y, 227)],
    [(549.6, 0, 559.2), (0, 0, 559.2), (0, 548.8, 559.2), (556, 548.8, 559.2)],
    [(0, 0, 559.2), (0, 0, 0), (0, 548.8, 0), (0, 548.8, 559.2)],
    [(552.8, 0, 0), (549.6, 0, 559.2), (556, 548.8, 559.2)],
    [(552.8, 0, 0), (556, 548.8, 559.2), (556, 548.8, 0)],
    [(130, 165, 65), (82, 165, 225), (240, 165, 272), (290, 165, 114)],
    [(290, 0, 114), (290, 165, 114), (240, 165, 272), (240, 0, 272)],
    [(130, 0, 65), (130, 165, 65), (290, 165, 114), (290, 0, 114)],
    [(82, 0, 225), (82, 165, 225), (130, 165, 65), (130, 0, 65)],
    [(240, 0, 272), (240, 165, 272), (82, 165, 225), (82, 0, 225)],
    [(423, 330, 247), (265, 330, 296), (314, 330, 456), (472, 330, 406)],
    [(423, 0, 247), (423, 330, 247), (472, 330, 406), (472, 0, 406)],
    [(472, 0, 406), (472, 330, 406), (314, 330, 456), (314, 0, 456)],
    [(314, 0, 456), (314, 330, 456), (265, 330, 296), (265, 0, 296)],
    [(265, 0, 296), (265, 330, 296), (423, 330, 247), (423, 0, 247)],
]


def split(poly, m):
    """formfactor's subdivide(): a quad into m x m bilinear children (row r along v0->v3,
    column c along v0->v1), a triangle into m^2 on the barycentric grid."""
    def lerp(a, b, t):
        return tuple(a[k] + t * (b[k] - a[k]) for k in range(3))
    if len(poly) == 4:
        v0, v1, v2, v3 = poly

        def P(c, r):
            return lerp(lerp(v0, v1, c / m), lerp(v3, v2, c / m), r / m)
        return [[P(c, r), P(c + 1, r), P(c + 1, r + 1), P(c, r + 1)]
                for r in range(m) for c in range(m)]
    v0, v1, v2 = poly

    def P(i, j):
        return tuple(v0[k] + i / m * (v1[k] - v0[k]) + j / m * (v2[k] - v0[k]) for k in range(3))
    out = []
    for j in range(m):
        for i in range(m - j):
            out.append([P(i, j), P(i + 1, j), P(i, j + 1)])
            if i < m - 1 - j:
                out.append([P(i + 1, j), P(i + 1, j + 1), P(i, j + 1)])
    return out


def urban(n, seed=1):
    """An urban array as urban-climate preprocessors write it for View3D: n x n box buildings of
    random heights (uniform in [1, 4], seeded) on 2 x 2 footprints with streets 1 wide, on a
    ground of unit squares that tile [0, 3n + 1]^2 minus the footprints; every rectangle (ground
    square, wall, roof) as two triangles. 10 n^2 + 2 ((n + 1)(3n + 1) + 2 n (n + 1)) facets
    (n = 7: 1,066; n = 22: 9,946; n = 38: 29,338), open to the sky. Ground and roofs face +z,
    walls outward."""
    rng = np.random.default_rng(seed)
    heights = rng.uniform(1.0, 4.0, size=(n, n))
    rects = []  # (corner, e1, e2) with front e1 x e2
    L = 3 * n + 1
    for k in range(n + 1):  # streets along x, as unit squares
        for i in range(L):
            rects.append(((float(i), 3.0 * k, 0.0), (1.0, 0, 0), (0, 1.0, 0)))
    for y in range(n):  # street pieces between the buildings of row y
        for k in range(n + 1):
            for d in range(2):
                rects.append(((3.0 * k, 3.0 * y + 1 + d, 0.0), (1.0, 0, 0), (0, 1.0, 0)))
    for y in range(n):
        for x in range(n):
            h = float(heights[y, x])
            x0, y0 = 3.0 * x + 1, 3.0 * y + 1
            rects += [((x0, y0, 0.0), (0, 0, h), (0, 2.0, 0)),         # -x
                      ((x0 + 2, y0, 0.0), (0, 2.0, 0), (0, 0, h)),     # +x
                      ((x0, y0, 0.0), (2.0, 0, 0), (0, 0, h)),         # -y
                      ((x0, y0 + 2, 0.0), (0, 0, h), (2.0, 0, 0)),     # +y
                      ((x0, y0, h), (2.0, 0, 0), (0, 2.0, 0))]         # roof
    tris = []
    for o, e1, e2 in rects:
        a = tuple(o)
        b = tuple(o[k] + e1[k] for k in range(3))
        c = tuple(o[k] + e1[k] + e2[k] for k in range(3))
        d = tuple(o[k] + e2[k] for k in range(3))
        tris += [[a, b, c], [a, c, d]]
    return tris, []


def sphere_in_box(m, seed=0):
    """Curved geometry: a closed box room (each face 4 x 4 quads, as two triangles each) around
    a faceted sphere of radius 0.25 (a UV sphere of m latitude bands and 2m longitudes, caps as
    triangles, every quad as two triangles, facing out). 4 m^2 - 4 m + 192 facets (m = 22: 2,040)."""
    s = []
    faces = [((0, 0, 0), (0, 1, 0), (0, 0, 1)), ((1, 0, 0), (0, 0, 1), (0, 1, 0)),
             ((0, 0, 0), (0, 0, 1), (1, 0, 0)), ((0, 1, 0), (1, 0, 0), (0, 0, 1)),
             ((0, 0, 0), (1, 0, 0), (0, 1, 0)), ((0, 0, 1), (0, 1, 0), (1, 0, 0))]
    for o, e1, e2 in faces:
        for q in grid_quads(o, e1, e2, 4):
            s += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    c, r = (0.5, 0.5, 0.5), 0.25

    def pt(i, j):
        th = np.pi * i / m
        ph = 2 * np.pi * j / (2 * m)
        return (c[0] + r * np.sin(th) * np.cos(ph), c[1] + r * np.sin(th) * np.sin(ph),
                c[2] + r * np.cos(th))
    for i in range(m):
        for j in range(2 * m):
            a, b, cc, d = pt(i, j), pt(i + 1, j), pt(i + 1, j + 1), pt(i, j + 1)
            if i == 0:
                s.append([a, b, cc])
            elif i == m - 1:
                s.append([a, b, d])
            else:
                s += [[a, b, cc], [a, cc, d]]
    return s, []


def cylinder_in_box(m):
    """Curved geometry: the closed box room of sphere_in_box() around a faceted cylinder of
    radius 0.2 and height 0.5 about the room's vertical axis (m facets around, m / 2 bands along
    the axis, every quad as two triangles, each cap a fan of m triangles; facing out).
    m^2 + 2 m + 192 facets (m = 44: 2,216)."""
    s = sphere_in_box(0)[0]
    c, r, z0, z1 = (0.5, 0.5), 0.2, 0.25, 0.75
    bands = max(1, m // 2)

    def pt(j, z):
        ph = 2 * np.pi * j / m
        return (c[0] + r * np.cos(ph), c[1] + r * np.sin(ph), z)
    for k in range(bands):
        za, zb = z0 + (z1 - z0) * k / bands, z0 + (z1 - z0) * (k + 1) / bands
        for j in range(m):
            a, b, cc, d = pt(j, za), pt(j + 1, za), pt(j + 1, zb), pt(j, zb)
            s += [[a, b, cc], [a, cc, d]]
    for j in range(m):
        s.append([(c[0], c[1], z1), pt(j, z1), pt(j + 1, z1)])  # top, +z
        s.append([(c[0], c[1], z0), pt(j + 1, z0), pt(j, z0)])  # bottom, -z
    return s, []


def triangulated(polys):
    """Every quad as two triangles (0, 1, 2) and (0, 2, 3), as meshing tools write them."""
    out = []
    for p in polys:
        out += [[p[0], p[1], p[2]], [p[0], p[2], p[3]]] if len(p) == 4 else [p]
    return out


def cornell(m):
    return [q for p in CORNELL for q in split(p, m)], []


def write_vs3(path, title, s_polys, o_polys):
    """View3D 3.2 input: shared vertices, S records then O records (View3D's order)."""
    index, verts = {}, []

    def vid(v):
        key = tuple(float(x) for x in v)
        if key not in index:
            verts.append(key)
            index[key] = len(verts)
        return index[key]
    recs = [('S', [vid(v) for v in p]) for p in s_polys] + \
           [('O', [vid(v) for v in p]) for p in o_polys]
    lines = [f"T {title}", "C encl=0 list=0 eps=1e-4 out=1", "F 3"]
    lines += [f"V {k + 1} {v[0]!r} {v[1]!r} {v[2]!r}" for k, v in enumerate(verts)]
    for k, (kind, vs) in enumerate(recs):
        vs = vs + [0] * (4 - len(vs))
        tail = f" 0 0 0.9 s{k + 1}" if kind == 'S' else ""
        lines.append(f"{kind} {k + 1} " + " ".join(map(str, vs)) + tail)
    lines.append("End of data")
    Path(path).write_text("\n".join(lines) + "\n")


# --- running --------------------------------------------------------------------------------


def run(cmd, cwd, timeout=None):
    """Runs cmd; returns (wall s, user+sys s, peak RSS MB, returncode, stderr tail)."""
    log = Path(cwd) / (Path(cmd[0]).name + ".stderr")
    with open(log, "wb") as err_file:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                             stderr=err_file)
        # Peak memory: the program's VmHWM, sampled until it exits (wait4's ru_maxrss would
        # include the memory of this Python process, which the child inherits at fork).
        hwm_kb = 0
        try:
            while True:
                pid, status, ru = os.wait4(p.pid, os.WNOHANG)
                if pid == p.pid:
                    break
                try:
                    for line in Path(f"/proc/{p.pid}/status").read_text().splitlines():
                        if line.startswith("VmHWM:"):
                            hwm_kb = max(hwm_kb, int(line.split()[1]))
                except (OSError, ValueError):
                    pass
                time.sleep(0.02)
        except KeyboardInterrupt:
            p.kill()
            raise
        wall = time.perf_counter() - t0
    p.returncode = rc = os.waitstatus_to_exitcode(status)
    err = log.read_text(errors="replace")
    return wall, ru.ru_utime + ru.ru_stime, hwm_kb / 1024.0, rc, err[-400:]


def read_view3d_binary(path, n):
    """View3D 3.2's out=1 file (savevf.c SaveF1): 32-byte header, areas, n rows, emissivities,
    all float32."""
    raw = Path(path).read_bytes()
    header = raw[:32].decode(errors="replace").split()
    if int(header[5]) != n:
        raise RuntimeError(f"View3D wrote {header[5]} surfaces, expected {n}")
    data = np.frombuffer(raw[32:], dtype="<f4")
    return data[n:n + n * n].reshape(n, n).astype(np.float64)


def run_view3d(name, vs3, n, args, work):
    """View3D's {wall, cpu, peak_mb, rc} and its matrix (None when it failed or was skipped)."""
    if args.view3d == "none":
        return {"wall": float("nan"), "cpu": float("nan"), "peak_mb": float("nan"), "rc": 0}, None
    v3_out = work / f"{name}.view3d.bin"
    wall, cpu, mem, rc, err = run([args.view3d, vs3.name, v3_out.name], work)
    if rc != 0 or not v3_out.exists():
        print(f"{name}: View3D failed (exit {rc}): {err.strip()}", file=sys.stderr)
        return {"wall": wall, "cpu": cpu, "peak_mb": mem, "rc": rc}, None
    return {"wall": wall, "cpu": cpu, "peak_mb": mem, "rc": rc}, read_view3d_binary(v3_out, n)


def compare(name, vs3, n, args, work, view3d, V, tolerance=None):
    out = {"case": name, "surfaces": n, "tolerance": tolerance, "view3d": view3d}
    tag = f"{name}.tol{tolerance:g}" if tolerance else name
    F_path = work / f"{tag}.formfactor.npy"
    rep = work / f"{tag}.report.json"
    cmd = [args.formfactor, "compute", vs3.name, "-o", F_path.name, "--threads",
           str(args.threads), "--report", rep.name] + args.formfactor_args
    if tolerance:
        cmd += ["--tolerance", f"{tolerance:g}"]
    wall, cpu, mem, rc, err = run(cmd, work)
    out["formfactor"] = {"wall": wall, "cpu": cpu, "peak_mb": mem, "rc": rc}
    if rc != 0:
        print(f"{name}: formfactor failed (exit {rc}): {err.strip()}", file=sys.stderr)
        return out
    F = np.load(F_path)
    out["F_path"] = str(F_path)
    try:
        details = json.loads(rep.read_text()).get("details", {})
        ob = details.get("obstructions", {})
        out["formfactor"]["error_bound"] = details.get("error_bound_per_entry")
        out["formfactor"]["partly_hidden_pairs"] = ob.get("patch_pairs_partly_hidden")
        out["formfactor"]["point_evaluations"] = ob.get("point_evaluations")
    except (OSError, ValueError):
        pass
    if V is not None:
        D = np.abs(F - V)
        i, j = np.unravel_index(np.argmax(D), D.shape)
        out["diff"] = {"max": float(D.max()), "at": [int(i), int(j)], "ff": float(F[i, j]),
                       "view3d": float(V[i, j]), "mean": float(D.mean()),
                       "above_1e-4": int((D > 1e-4).sum()), "above_1e-6": int((D > 1e-6).sum()),
                       "rows_ff": [float(F.sum(1).min()), float(F.sum(1).max())],
                       "rows_view3d": [float(V.sum(1).min()), float(V.sum(1).max())]}
    return out


def print_line(name, tol, n, r):
    v, f = r["view3d"], r["formfactor"]
    # No ratio to a run that failed: its time is how long it took to give up.
    ratio = v["cpu"] / f["cpu"] if f.get("cpu") and v.get("rc", 0) == 0 else float("nan")
    ratio_text = f"{ratio:>8.1f}x" if ratio == ratio else f"{'fails' if v.get('rc') else '-':>9}"
    line = (f"{name:<14} {tol or 0:>6.0e} {n:>5} | {v['wall']:>10.2f}s {v['cpu']:>7.2f}s "
            f"{v['peak_mb']:>6.0f} | {f['wall']:>14.2f}s {f.get('cpu', float('nan')):>7.2f}s "
            f"{f.get('peak_mb', float('nan')):>6.0f} | {ratio_text} |")
    d = r.get("diff")
    if d:
        line += (f" {d['max']:>9.2e} {str(tuple(d['at'])):>11} {d['mean']:>9.2e}"
                 f" {d['above_1e-4']:>6}")
    if "error_vs_tightest" in r:
        line += f" | {r['error_vs_tightest']:>15.2e}"
    print(line, flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--view3d", default=os.environ.get("VIEW3D"),
                    help="View3D 3.2 binary (default $VIEW3D)")
    ap.add_argument("--formfactor", default=str(REPO / "build" / "bin" / "formfactor"))
    ap.add_argument("--rooms", type=int, nargs="*", default=[16, 32], help="room sizes n")
    ap.add_argument("--cornell", type=int, default=12, help="Cornell box M x M (0: skip)")
    ap.add_argument("--urban", type=int, nargs="*", default=[],
                    help="urban arrays n x n of triangulated buildings (9: 1,010 facets)")
    ap.add_argument("--sphere", type=int, default=0,
                    help="faceted sphere of m bands in a box (22: 2,040 facets; 0: skip)")
    ap.add_argument("--cylinder", type=int, default=0,
                    help="faceted cylinder of m facets around in a box (44: 2,216 facets; 0: skip)")
    ap.add_argument("--triangulate", action="store_true",
                    help="the rooms and the Cornell box with every quad as two triangles")
    ap.add_argument("--tolerances", type=float, nargs="*", default=[],
                    help="run formfactor at each --tolerance; the tightest is the reference "
                    "for the measured error of the others")
    ap.add_argument("--box", choices=["S", "O", "both"], default="both")
    ap.add_argument("--o-split", action="store_true",
                    help="O records split (n/2) x (n/2) per box face (as tests/data/repro/ has them)"
                    " instead of six whole faces")
    ap.add_argument("--threads", type=int, default=1, help="formfactor --threads")
    ap.add_argument("--workdir", help="keep the files here (default: a temporary folder)")
    ap.add_argument("--json", help="also write the results as JSON to this file")
    ap.add_argument("formfactor_args", nargs="*",
                    help="more formfactor compute options (after --)")
    args = ap.parse_args()
    if not args.view3d:
        ap.error("give the View3D binary with --view3d or $VIEW3D")
    if args.view3d != "none":
        args.view3d = str(Path(args.view3d).resolve())
    args.formfactor = str(Path(args.formfactor).resolve())
    for exe in ([args.view3d] if args.view3d != "none" else []) + [args.formfactor]:
        if not os.access(exe, os.X_OK):
            ap.error(f"not executable: {exe}")

    def tri(make):
        if not args.triangulate:
            return make
        return lambda: tuple(triangulated(p) for p in make())
    t = "-tri" if args.triangulate else ""
    cases = []
    for n in args.rooms:
        for box in (["S", "O"] if args.box == "both" else [args.box]):
            cases.append((f"room-{n}-{box}{t}", tri(lambda n=n, box=box: room(n, box, args.o_split)),
                          f"room n={n} box={box}"))
    if args.cornell > 0:
        m = args.cornell
        cases.append((f"cornell-{m}{t}", tri(lambda m=m: cornell(m)), f"Cornell box {m}x{m}"))
    for n in args.urban:
        cases.append((f"urban-{n}", lambda n=n: urban(n), f"urban array {n}x{n}"))
    if args.sphere > 0:
        m = args.sphere
        cases.append((f"sphere-{m}", lambda m=m: sphere_in_box(m), f"sphere {m} in a box"))
    if args.cylinder > 0:
        m = args.cylinder
        cases.append((f"cylinder-{m}", lambda m=m: cylinder_in_box(m), f"cylinder {m} in a box"))
    tolerances = sorted(args.tolerances) or [None]

    tmp = None
    if args.workdir:
        work = Path(args.workdir)
        work.mkdir(parents=True, exist_ok=True)
    else:
        tmp = tempfile.TemporaryDirectory(prefix="view3d_compare_")
        work = Path(tmp.name)

    print(f"View3D: {args.view3d}\nformfactor: {args.formfactor} --threads {args.threads}"
          f" {' '.join(args.formfactor_args)}\nfiles: {work}\n")
    hdr = (f"{'case':<14} {'tol':>6} {'N':>5} | {'View3D wall':>11} {'cpu':>8} {'MB':>6} | "
           f"{'formfactor wall':>15} {'cpu':>8} {'MB':>6} | {'cpu ratio':>9} | "
           f"{'max |dF|':>9} {'at':>11} {'mean |dF|':>9} {'>1e-4':>6} | {'err vs tightest':>15}")
    print(hdr)
    print("-" * len(hdr))
    results = []
    for name, make, title in cases:
        s, o = make()
        vs3 = work / f"{name}.vs3"
        write_vs3(vs3, title, s, o)
        view3d, V = run_view3d(name, vs3, len(s), args, work)
        reference = None
        for tol in tolerances:
            r = compare(name, vs3, len(s), args, work, view3d, V, tol)
            results.append(r)
            if "F_path" in r:
                F = np.load(r["F_path"])
                if reference is None:
                    reference = F
                else:
                    r["error_vs_tightest"] = float(np.abs(F - reference).max())
            print_line(name, tol, len(s), r)
    print()
    for r in results:
        d = r.get("diff")
        if d:
            print(f"{r['case']}: at {tuple(d['at'])} formfactor {d['ff']:.7g}, View3D "
                  f"{d['view3d']:.7g}; entries differing > 1e-6: {d['above_1e-6']}; row sums "
                  f"formfactor [{d['rows_ff'][0]:.6f}, {d['rows_ff'][1]:.6f}], View3D "
                  f"[{d['rows_view3d'][0]:.6f}, {d['rows_view3d'][1]:.6f}]; formfactor's "
                  f"bound {r['formfactor'].get('error_bound')}, partly hidden pairs "
                  f"{r['formfactor'].get('partly_hidden_pairs')}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n")
    if tmp:
        tmp.cleanup()


if __name__ == "__main__":
    main()
