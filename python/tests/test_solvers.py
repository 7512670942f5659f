"""Radiosity and thermal solves, repair and Hottel's exchange factors, against NumPy."""

import numpy as np
import pytest

import formfactor as ff

SIGMA = 5.670374419e-8


def test_radiosity_matches_a_numpy_solve():
    s = ff.load("cornell", subdivide=2)
    r = s.form_factors()
    props = s.properties()
    out = ff.solve_radiosity(s, r, residual=1e-13)
    F = r.matrix
    for c in range(3):
        A = np.eye(len(s)) - props["reflectance"][:, c, None] * F
        B = np.linalg.solve(A, props["emission"][:, c])
        assert np.abs(out.radiosity[:, c] - B).max() <= 1e-10 * np.abs(B).max()
    assert out.stats["converged"]
    # The same with the matrix given as an array, with explicit grey properties.
    grey = ff.solve_radiosity(s, np.array(F), reflectance=0.5, emission=props["emission"][:, 0],
                              solver="direct")
    B = np.linalg.solve(np.eye(len(s)) - 0.5 * F, props["emission"][:, 0])
    assert np.abs(grey.radiosity[:, 1] - B).max() <= 1e-12 * np.abs(B).max()


def test_thermal_matches_the_net_radiation_equations():
    s = ff.load("cube", subdivide=2)
    r = s.form_factors()
    F = r.matrix
    n = len(s)
    eps = np.full(n, 0.8)
    eps[:4] = 0.5
    T = np.full(n, 300.0)
    T[:4] = 1000.0
    q_given = np.full(n, np.nan)
    T[-1] = np.nan
    q_given[-1] = 0.0  # one adiabatic patch, with a prescribed flux of zero
    out = ff.solve_thermal(s, r, emissivity=eps, temperature=T, net_flux=q_given)
    # J_i − (1−ε_i) Σ F_ij J_j = ε_i σ T_i⁴ (known T);  J_i − Σ F_ij J_j = q_i (known q)
    M = np.eye(n) - np.where(np.isnan(T), 1.0, 1 - eps)[:, None] * F
    rhs = np.where(np.isnan(T), q_given, eps * SIGMA * np.nan_to_num(T) ** 4)
    J = np.linalg.solve(M, rhs)
    assert np.abs(out.radiosity - J).max() <= 1e-9 * J.max()
    q = J - F @ J
    assert np.abs(out.net_flux - q).max() <= 1e-9 * np.abs(q).max()
    assert np.allclose(out.net_power, q * s.areas, rtol=1e-9, atol=1e-9 * np.abs(q).max())
    assert abs(out.total_net_power) <= 1e-9 * np.abs(out.net_power).sum()  # closed box
    assert out.temperature_prescribed[:-1].all() and not out.temperature_prescribed[-1]
    assert 300 < out.temperature[-1] < 1000
    with pytest.raises(ff.OptionError) as e:
        ff.solve_thermal(s, r, temperature=300.0, net_flux=0.0)
    assert e.value.option == "net_flux"


def test_exchange_factors_and_repair():
    s = ff.load("cube", subdivide=2)
    F = np.array(s.form_factors().matrix)
    eps = np.linspace(0.3, 0.9, len(s))
    X = ff.exchange_factors(F, eps)
    assert np.abs(X.sum(axis=1) - eps).max() < 1e-12  # closed: Σ_j 𝓕_ij = ε_i
    AX = s.areas[:, None] * X
    assert np.abs(AX - AX.T).max() < 1e-12
    assert np.abs(ff.exchange_factors(F, 1.0) - F).max() < 1e-14
    with pytest.raises(ff.OptionError):
        ff.exchange_factors(F, 0.0)

    noisy = np.array(s.form_factors(method="mc-area", samples=200).matrix)
    before = noisy.copy()
    fixed, report = ff.repair(noisy, s.areas, "both", enclosure=True)
    assert np.array_equal(noisy, before)  # the input is not changed
    assert np.abs(fixed.sum(axis=1) - 1).max() < 1e-12
    AF = s.areas[:, None] * fixed
    assert np.abs(AF - AF.T).max() < 1e-12
    assert report["mode"] == "both" and "before" in report and "after" in report


def test_solver_arguments_are_checked():
    s = ff.load("plates")
    r = s.form_factors()
    with pytest.raises(ff.OptionError) as e:
        ff.solve_radiosity(s, np.zeros((3, 3)))
    assert e.value.option == "F"
    with pytest.raises(ff.OptionError) as e:
        ff.solve_radiosity(s, r, reflectance=np.zeros(5))
    assert e.value.option == "reflectance"
    with pytest.raises(ff.OptionError) as e:
        ff.solve_radiosity(s, r, solver="magic")
    assert e.value.option == "solver"
    block = s.form_factors(rows=(0, 1))
    with pytest.raises(ff.OptionError):
        ff.solve_radiosity(s, block)


def test_hierarchical_operator_products_solves_and_scipy():
    scene = ff.load("cube", subdivide=10)  # 600 patches, a closed room without blockers
    F = scene.form_factors().matrix
    op = scene.hierarchical(1e-6)
    n = len(scene.areas)
    assert op.shape == (n, n)
    assert op.stats["low_rank_blocks"] > 0
    x = np.random.default_rng(3).random((n, 2))
    assert np.linalg.norm(op @ x - F @ x) <= 1e-5 * np.linalg.norm(F @ x)
    assert np.abs(op.matvec(x[:, 0]) - F @ x[:, 0]).max() <= 1e-5 * np.abs(F @ x[:, 0]).max()
    np.testing.assert_allclose(op.row_sums(), 1.0, atol=1e-5)
    # Per-surface factors (6 faces) as from the dense matrix.
    S = op.per_surface()
    face = scene.surface_index
    A = scene.areas
    E = np.zeros((6, 6))
    for s in range(6):
        for t in range(6):
            E[s, t] = (A[face == s] @ F[np.ix_(face == s, face == t)].sum(axis=1)) / A[face == s].sum()
    np.testing.assert_allclose(S, E, atol=1e-6)
    # Solves take the operator as F (gmres by default) and agree with the dense ones.
    T = np.where(face == 4, 1000.0, 300.0)
    dense = ff.solve_thermal(scene, F, emissivity=0.3, temperature=T)
    hier = ff.solve_thermal(scene, op, emissivity=0.3, temperature=T)
    assert hier.stats["solver"] == "gmres"
    np.testing.assert_allclose(hier.radiosity, dense.radiosity, rtol=1e-5)
    rad = ff.solve_radiosity(scene, op, emission=np.where(face == 5, 1.0, 0.0))
    ref = ff.solve_radiosity(scene, F, emission=np.where(face == 5, 1.0, 0.0), solver="direct")
    np.testing.assert_allclose(rad.radiosity, ref.radiosity, rtol=1e-5, atol=1e-12)
    with pytest.raises(ff.OptionError):
        ff.solve_radiosity(scene, op, solver="gauss-seidel")
    # SciPy: the LinearOperator solves the radiosity system with scipy's own GMRES.
    scipy_linalg = pytest.importorskip("scipy.sparse.linalg")
    L = op.as_linear_operator()
    np.testing.assert_allclose(L.rmatvec(x[:, 0]), F.T @ x[:, 0], rtol=1e-5, atol=1e-12)
    rho = 0.5
    E0 = np.where(face == 5, 1.0, 0.0)
    system = scipy_linalg.LinearOperator((n, n), matvec=lambda b: b - rho * (L @ b))
    import inspect
    rtol = "rtol" if "rtol" in inspect.signature(scipy_linalg.gmres).parameters else "tol"
    B, info = scipy_linalg.gmres(system, E0, atol=1e-14, **{rtol: 1e-12})
    assert info == 0
    B_ref = np.linalg.solve(np.eye(n) - rho * F, E0)
    np.testing.assert_allclose(B, B_ref, rtol=1e-5, atol=1e-10)


def test_hierarchical_refuses_obstructed_scenes_and_bad_options():
    with pytest.raises(ff.Error, match="obstructions"):
        ff.load("cornell").hierarchical()
    with pytest.raises(ff.OptionError):
        ff.load("cube", subdivide=4).hierarchical(0.0)
    other = ff.load("cube", subdivide=3).hierarchical()
    with pytest.raises(ff.OptionError):
        ff.solve_thermal(ff.load("cube", subdivide=4), other, temperature=300.0)


def test_sparse_F_from_scipy_is_solved_on_its_stored_entries():
    sp = pytest.importorskip("scipy.sparse")
    scene = ff.load("cornell", subdivide=2)  # 80 patches, obstructed, open
    r = scene.form_factors()
    S = r.sparse()  # every positive entry: the dense matrix's entries
    ref = ff.solve_radiosity(scene, r, solver="direct", residual=1e-13)
    for kind in (None, "gmres", "jacobi", "gauss-seidel"):
        b = ff.solve_radiosity(scene, S, solver=kind, residual=1e-11)
        assert b.stats["converged"]
        assert b.stats["solver"] == (kind or "gauss-seidel")
        # ‖ΔB‖∞ ≤ residual ‖B‖∞ / (1 − ρ_max), ρ ≤ 0.78 in the box, + the direct solve's 1e-13
        assert np.max(np.abs(b.radiosity - ref.radiosity)) <= 6e-11 * np.max(ref.radiosity)
    T = np.full(80, np.nan)
    T[:8] = 600.0
    T[8:16] = 300.0
    t_ref = ff.solve_thermal(scene, r, emissivity=0.7, temperature=T, solver="direct",
                             residual=1e-13)
    for M in (S, S.tocoo(), sp.csc_matrix(S)):  # any scipy format
        t = ff.solve_thermal(scene, M, emissivity=0.7, temperature=T, residual=1e-12)
        assert t.stats["solver"] == "gmres"
        np.testing.assert_allclose(t.temperature, t_ref.temperature, rtol=1e-9)
    with pytest.raises(ff.OptionError) as e:
        ff.solve_thermal(scene, S, temperature=T, solver="direct")
    assert e.value.option == "solver"
    with pytest.raises(ff.OptionError) as e:
        ff.solve_radiosity(scene, sp.csr_matrix((79, 79)))
    assert e.value.option == "F"
    bad = S.copy()
    bad.data[0] = np.nan
    with pytest.raises(ff.OptionError):
        ff.solve_radiosity(scene, bad)
