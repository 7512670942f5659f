"""Catalog values through Python, to the accuracy the C++ suite asks of the same method."""

import numpy as np
import pytest

import formfactor as ff
from catalog_cases import ENCLOSURES, PAIRS, POINTS


def two_surfaces(a1, a2):
    v = np.array(a1 + a2, dtype=float)
    return ff.Scene.from_arrays(v, [list(range(len(a1))), list(range(len(a1), len(a1) + len(a2)))])


@pytest.mark.parametrize("case", PAIRS, ids=[c["name"] for c in PAIRS])
def test_polygon_to_polygon_analytic(case):
    scene = two_surfaces(case["a1"], case["a2"])
    r = scene.form_factors(method="analytic")
    # The contour integral is exact; the bound the method reports is its error model.
    assert r.error_bound is not None
    assert abs(r.matrix[0, 1] - case["exact"]) <= max(1e-12, r.error_bound)
    # Reciprocity through the areas the scene reports.
    A = scene.areas
    assert abs(A[0] * r.matrix[0, 1] - A[1] * r.matrix[1, 0]) <= 1e-12 * A[0]


@pytest.mark.parametrize("case", PAIRS[:6], ids=[c["name"] for c in PAIRS[:6]])
def test_polygon_to_polygon_monte_carlo_within_its_error_bars(case):
    scene = two_surfaces(case["a1"], case["a2"])
    r = scene.form_factors(method="mc-area", samples=20000, seed=3)
    se = r.standard_error[0, 1]
    assert se > 0
    # 16 replicates: a t-quantile with 15 degrees of freedom, two-sided 1e-4.
    assert abs(r.matrix[0, 1] - case["exact"]) <= 5.25 * se


@pytest.mark.parametrize("case", POINTS, ids=[c["name"] for c in POINTS])
def test_point_to_polygon(case):
    poly = case["polygon"]
    scene = ff.Scene.from_arrays(np.array(poly, dtype=float), [list(range(len(poly)))])
    P = ff.point_factors(scene, [case["point"]], [case["normal"]])
    assert P.shape == (1, 1)
    assert abs(P[0, 0] - case["exact"]) <= 1e-14


@pytest.mark.parametrize("case", ENCLOSURES, ids=[c["name"] for c in ENCLOSURES])
def test_enclosure_matrix_and_closure(case):
    surfaces = case["surfaces"]
    v = np.array([p for s in surfaces for p in s], dtype=float)
    faces = np.arange(len(v)).reshape(len(surfaces), 4)
    scene = ff.Scene.from_arrays(v, faces, enclosure=True)
    r = scene.form_factors()
    assert np.abs(r.matrix - np.array(case["exact"])).max() <= 1e-12
    assert np.abs(r.matrix.sum(axis=1) - 1).max() <= 1e-12
    d = r.report["diagnostics"]
    assert d["reciprocity"]["verdict"]["within"] is True
