"""The CLI's .vtu outputs read as XML (xml.etree), and its per-surface long table and patch
table row sums, checked against the matrix the CLI writes as CSV."""

import csv
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conftest import DATA_DIR, run_cli


def read_vtu(path):
    """(number of cells, number of points, {name: array (cells × components)}, cell types)."""
    root = ET.parse(path).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "UnstructuredGrid"
    piece = root.find("UnstructuredGrid/Piece")
    cells = int(piece.get("NumberOfCells"))
    points = int(piece.get("NumberOfPoints"))
    def values(array):
        return np.array(array.text.split(), dtype=float)
    xyz = values(piece.find("Points/DataArray")).reshape(-1, 3)
    assert xyz.shape[0] == points
    cell_arrays = {a.get("Name"): values(a) for a in piece.find("Cells")}
    offsets = cell_arrays["offsets"].astype(int)
    assert len(offsets) == cells and offsets[-1] == len(cell_arrays["connectivity"])
    fields = {}
    for a in piece.find("CellData"):
        k = int(a.get("NumberOfComponents", "1"))
        fields[a.get("Name")] = values(a).reshape(cells, k) if k > 1 else values(a)
        assert fields[a.get("Name")].shape[0] == cells
    return cells, xyz, offsets, cell_arrays["connectivity"].astype(int), fields


def read_patches(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_compute_vtu_has_one_cell_per_patch_and_the_row_sums_of_f(tmp_path):
    run_cli("compute", "cornell", "--subdivide", "2", "-o", tmp_path / "F.csv",
            "--patches", tmp_path / "p.csv", "--row-sums")
    run_cli("compute", "cornell", "--subdivide", "2", "-o", tmp_path / "F.vtu", "--row", "3")
    F = np.loadtxt(tmp_path / "F.csv", delimiter=",")
    patches = read_patches(tmp_path / "p.csv")
    cells, xyz, offsets, conn, fields = read_vtu(tmp_path / "F.vtu")
    assert cells == F.shape[0] == len(patches)
    assert {"patch", "surface", "area", "row_sum", "sky_factor", "F_from_3"} <= set(fields)
    np.testing.assert_array_equal(fields["patch"], np.arange(cells))
    np.testing.assert_array_equal(fields["row_sum"], [float(p["row_sum"]) for p in patches])
    np.testing.assert_allclose(fields["row_sum"], F.sum(axis=1), rtol=0, atol=1e-15)
    np.testing.assert_allclose(fields["sky_factor"], 1 - F.sum(axis=1), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(fields["F_from_3"], F[3])
    np.testing.assert_array_equal(fields["area"], [float(p["area"]) for p in patches])
    # Each cell's polygon: its area (Newell) is the patch's, and its centroid the table's.
    start = 0
    for i, end in enumerate(offsets):
        v = xyz[conn[start:end]]
        a = 0.5 * np.linalg.norm(np.cross(v, np.roll(v, -1, axis=0)).sum(axis=0))
        assert a == pytest.approx(fields["area"][i], rel=1e-12)
        start = end


def test_solve_vtu_has_the_radiosity_of_the_table(tmp_path):
    run_cli("solve", "cornell", "-o", tmp_path / "B.csv")
    run_cli("solve", "cornell", "-o", tmp_path / "B.vtu")
    table = np.loadtxt(tmp_path / "B.csv", delimiter=",", skiprows=1)
    cells, _, _, _, fields = read_vtu(tmp_path / "B.vtu")
    assert cells == table.shape[0]
    np.testing.assert_array_equal(fields["radiosity"], table[:, 1:4])
    assert {"area", "row_sum", "sky_factor"} <= set(fields)


def test_solve_thermal_vtu_has_temperature_and_net_flux(tmp_path):
    props = tmp_path / "props.csv"
    props.write_text("surface,emissivity,temperature\nx0,1,300\nx1,1,300\ny0,1,300\n"
                     "y1,1,300\nz0,0.6,1000\nz1,1,300\n")
    for out in ("T.csv", "T.vtu"):
        run_cli("solve", "cube", "--thermal", "--properties", props, "--subdivide", "2",
                "-o", tmp_path / out)
    with open(tmp_path / "T.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    cells, _, _, _, fields = read_vtu(tmp_path / "T.vtu")
    assert cells == len(rows) == 24
    for name in ("temperature", "net_flux", "net_power", "radiosity", "emissivity"):
        np.testing.assert_array_equal(fields[name], [float(r[name]) for r in rows])
    # A closed cube: every row sums to 1 within the analytic method's accuracy.
    np.testing.assert_allclose(fields["sky_factor"], 0, atol=1e-9)


def test_pairs_table_is_the_per_surface_matrix_with_names(tmp_path):
    vs3 = DATA_DIR / "room-windows.vs3"
    run_cli("compute", vs3, "-o", tmp_path / "F.csv", "--per-surface",
            "--pairs", tmp_path / "pairs.csv")
    F = np.loadtxt(tmp_path / "F.csv", delimiter=",")
    with open(tmp_path / "pairs.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == F.size
    names = [r["from"] for r in rows[::F.shape[0]]]
    assert len(set(names)) == F.shape[0]
    got = np.array([float(r["F"]) for r in rows]).reshape(F.shape)
    np.testing.assert_array_equal(got, F)
    assert [r["to"] for r in rows[:F.shape[0]]] == names
