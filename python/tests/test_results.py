"""Scene.form_factors(): the matrix (a view, no copy), the same numbers as the CLI, row blocks,
sparse output, the report, memory refusal."""

import json

import numpy as np
import pytest

import formfactor as ff
from conftest import DATA_DIR, run_cli


@pytest.mark.parametrize("scene, cli_args, kwargs", [
    ("cornell", ["--subdivide", "2"], {}),
    (str(DATA_DIR / "room.obj"), ["--subdivide", "2"], {}),
    (str(DATA_DIR / "obstructed.vs3"), ["--per-patch"], {}),
    ("cornell", ["--method", "mc-hemisphere", "--samples", "2000", "--seed", "7"],
     {"method": "mc-hemisphere", "samples": 2000, "seed": 7}),
    ("perpendicular", ["--subdivide", "3", "--method", "hemicube", "--resolution", "64"],
     {"method": "hemicube", "resolution": 64}),
])
def test_the_same_matrix_as_the_cli_bit_for_bit(tmp_path, scene, cli_args, kwargs):
    out = tmp_path / "F.npy"
    run_cli("compute", scene, *cli_args, "-o", out)
    subdivide = int(cli_args[cli_args.index("--subdivide") + 1]) if "--subdivide" in cli_args else None
    r = ff.load(scene, subdivide=subdivide).form_factors(**kwargs)
    assert np.array_equal(np.load(out), r.matrix)


def test_the_matrix_is_a_read_only_view():
    r = ff.load("cornell", subdivide=2).form_factors()
    a, b = r.matrix, r.matrix
    assert np.shares_memory(a, b)
    assert not a.flags.owndata and not a.flags.writeable and a.flags.c_contiguous
    assert a.dtype == np.float64 and a.shape == (80, 80)
    del r
    assert np.isfinite(a).all()  # the view keeps the result alive


@pytest.mark.parametrize("method", ["analytic", "mc-area", "hemicube"])
def test_row_blocks_equal_the_rows_of_the_whole_matrix(method):
    s = ff.load("cornell", subdivide=2)
    kw = {"samples": 200} if method.startswith("mc") else {}
    whole = s.form_factors(method=method, **kw).matrix
    block = s.form_factors(method=method, rows=(30, 47), **kw)
    assert block.rows == (30, 47) and block.matrix.shape == (17, 80)
    assert np.array_equal(block.matrix, whole[30:47])
    tail = s.form_factors(method=method, rows=(75, None), **kw)
    assert np.array_equal(tail.matrix, whole[75:])
    assert block.report["rows"] == [30, 47]


def test_sparse_equals_dense_above_the_threshold():
    r = ff.load("room-4-obstruction").form_factors()
    F = r.matrix
    for t in (0.0, 1e-4, 1e-2):
        S = r.sparse(threshold=t)
        assert S.format == "csr" and S.shape == F.shape
        assert np.array_equal(S.toarray(), np.where(np.abs(F) > t, F, 0.0))
        assert S.nnz == int((np.abs(F) > t).sum())
    with pytest.raises(ff.OptionError) as e:
        r.sparse(threshold=-1)
    assert e.value.option == "threshold"


def test_the_report_has_the_cli_keys(tmp_path):
    report = tmp_path / "r.json"
    run_cli("compute", "cornell", "-o", tmp_path / "F.csv", "--report", report)
    cli = json.loads(report.read_text())
    py = ff.load("cornell").form_factors().report
    assert set(cli) == set(py)
    assert set(cli["diagnostics"]) == set(py["diagnostics"])
    assert set(cli["scene"]) == set(py["scene"])
    assert py["command"] == "python" and py["method"] == "analytic" and py["N"] == 20
    assert py["diagnostics"]["reciprocity"]["verdict"]["within"] is True


def test_standard_errors_and_bounds():
    s = ff.load("plates", subdivide=2)
    a = s.form_factors()
    assert a.standard_error is None and 0 < a.error_bound <= 1e-9
    m = s.form_factors(method="mc-area", samples=500)
    assert m.error_bound is None
    assert m.standard_error.shape == m.matrix.shape and (m.standard_error >= 0).all()
    assert m.report["diagnostics"]["standard_error"]["max"] > 0


def test_repair_and_per_surface():
    s = ff.load("cube", subdivide=2)
    r = s.form_factors(method="mc-area", samples=300, repair="both")
    assert np.abs(r.matrix.sum(axis=1) - 1).max() < 1e-12
    assert r.report["repair"]["mode"] == "both"
    G, names = s.form_factors().per_surface()
    assert G.shape == (6, 6) and len(names) == 6
    assert np.abs(G.sum(axis=1) - 1).max() < 1e-12


def test_bad_options_name_the_keyword():
    s = ff.load("plates")
    for kwargs, option in [({"method": "nope"}, "method"), ({"tolerance": 0}, "tolerance"),
                           ({"threads": -2}, "threads"), ({"sampler": "x"}, "sampler"),
                           ({"rows": (5, 2)}, "rows"), ({"repair": "all"}, "repair"),
                           ({"method": "hemicube", "resolution": 0}, "resolution"),
                           ({"progress": 3}, "progress")]:
        with pytest.raises(ff.OptionError) as e:
            s.form_factors(**kwargs)
        assert e.value.option == option, kwargs
        assert str(e.value).startswith(option + ":")


def test_a_run_that_cannot_fit_is_refused_before_it_starts():
    s = ff.load("cube", subdivide=150)  # 135,000 patches: F alone needs 146 GB
    with pytest.raises(ff.ResourceError) as e:
        s.form_factors()
    assert isinstance(e.value, MemoryError)
    assert "GB" in str(e.value) or "GiB" in str(e.value)


def test_arguments_of_the_wrong_type_name_the_keyword():
    s = ff.load("plates")
    for kwargs, option in [({"samples": "many"}, "samples"), ({"tolerance": "1e-3"}, "tolerance"),
                           ({"threads": 1.5}, "threads"), ({"method": 3}, "method"),
                           ({"seed": -1}, "seed"), ({"rows": 7}, "rows"),
                           ({"rows": (0, "end")}, "rows"), ({"samples": 2 ** 70}, "samples")]:
        with pytest.raises(ff.OptionError) as e:
            s.form_factors(**kwargs)
        assert e.value.option == option, kwargs


def test_methods_lists_what_form_factors_accepts():
    names = ff.methods()
    assert names[0] == "analytic" and "mc-target" in names
    s = ff.load("plates")
    for name in names:
        kwargs = {"samples": 64} if name.startswith("mc-") else {}
        assert s.form_factors(name, **kwargs).method == name


def test_every_function_rejects_a_bool_for_a_number_with_an_option_error(tmp_path):
    s = ff.load("plates")
    r = s.form_factors()
    pts, up = [[0.0, 0.0, 0.5]], [0.0, 0.0, 1.0]
    calls = [
        ("threads", lambda: ff.solve_radiosity(s, r, threads=True)),
        ("max_iterations", lambda: ff.solve_radiosity(s, r, max_iterations=False)),
        ("residual", lambda: ff.solve_radiosity(s, r, residual=True)),
        ("threads", lambda: ff.solve_thermal(s, r, temperature=300.0, threads=True)),
        ("ambient_temperature",
         lambda: ff.solve_thermal(s, r, temperature=300.0, ambient_temperature=True)),
        ("threads", lambda: ff.point_factors(s, pts, up, threads=True)),
        ("leaf_size", lambda: ff.load("cube", subdivide=2).hierarchical(leaf_size=True)),
        ("width", lambda: ff.render(s, width=True)),
        ("threads", lambda: s.form_factors(threads=True)),
        ("threshold", lambda: r.sparse(threshold=True)),
        ("max_entries", lambda: r.to_html(tmp_path / "x.html", max_entries=True)),
        ("threads", lambda: ff.load("cube", subdivide=2).hierarchical().row_sums(threads=True)),
        ("threads", lambda: ff.load("cube", subdivide=2).hierarchical().to_dense(threads=True)),
        ("threads", lambda: ff.load("cube", subdivide=2).hierarchical().per_surface(True)),
        ("threads", lambda: ff.load("cube", subdivide=2).hierarchical().matvec(
            np.ones(24), threads=True)),
    ]
    for option, call in calls:
        with pytest.raises(ff.OptionError) as e:
            call()
        assert e.value.option == option
        assert str(e.value).startswith(option + ":")
    assert not (tmp_path / "x.html").exists()


def test_arguments_of_the_wrong_type_are_option_errors_everywhere(tmp_path):
    s = ff.load("plates")
    r = s.form_factors()
    calls = [
        ("residual", lambda: ff.solve_radiosity(s, r, residual="small")),
        ("threads", lambda: ff.solve_radiosity(s, r, threads=1.5)),
        ("solver", lambda: ff.solve_thermal(s, r, temperature=300.0, solver=3)),
        ("merge_coplanar", lambda: ff.load("plates", merge_coplanar="yes")),
        ("force_closure", lambda: s.form_factors(force_closure=1)),
        ("enclosure", lambda: ff.repair(r.matrix, r.areas, enclosure=None)),
        ("label", lambda: ff.render(s, np.ones(len(s)), label=3)),
        ("camera", lambda: ff.render(s, camera=[0, 0, 1])),
        ("patches", lambda: s.to_arrays(patches=1)),
        ("enclosure", lambda: ff.Scene.from_arrays(*s.to_arrays()[:2], enclosure="yes")),
        ("name", lambda: ff.Scene.from_arrays(*s.to_arrays()[:2], name=3)),
        ("path", lambda: r.to_html(3)),
        ("title", lambda: r.to_html(tmp_path / "x.html", title=3)),
    ]
    for option, call in calls:
        with pytest.raises(ff.OptionError) as e:
            call()
        assert e.value.option == option
    assert not (tmp_path / "x.html").exists()


def test_numpy_scalars_are_numbers():
    s = ff.load("plates")
    r = s.form_factors(threads=np.int64(1), tolerance=np.float32(1e-6))
    out = ff.solve_radiosity(s, r, threads=np.int32(1), residual=np.float64(1e-9),
                             reflectance=0.5, emission=1.0)
    assert out.stats["converged"]
