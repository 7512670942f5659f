"""formfactor: radiative form factors (view factors) between the surfaces of 3D scenes, exact
where it matters, and the radiosity and grey-body heat-exchange solves built on them.

Quick start::

    import formfactor as ff
    scene = ff.load("cornell", subdivide=4)      # a built-in scene, or a .obj / .vs3 file
    r = scene.form_factors()                     # analytic (exact) by default
    F = r.matrix                                 # F[i, j]: from patch i (row) to patch j (column)
    A = scene.areas
    assert abs(A[:, None] * F - (A[:, None] * F).T).max() < 1e-9   # reciprocity

Direction: everywhere in formfactor, ``F[i, j]`` is the fraction of the power leaving patch i
that arrives at patch j (from i to j). Rows sum to 1 in a closed enclosure.

The computations run in C++ with the GIL released (other Python threads run meanwhile), stop
on Ctrl-C (KeyboardInterrupt), and report progress to a callback when asked
(``progress=callable`` or ``progress=True`` for a bar on stderr). Errors are
:class:`formfactor.Error` subclasses: :class:`InputError` (also a ValueError) names the file and
line, :class:`OptionError` (also a ValueError) the keyword argument.

See docs/python.md for a worked example.
"""

import json as _json
import os as _os
from dataclasses import dataclass as _dataclass

import numpy as _np

from . import _core
from ._errors import Cancelled, Error, GeometryError, InputError, OptionError, ResourceError
from ._progress import TextProgress

__version__ = _core.__version__

Scene = _core.Scene
Result = _core.Result
HierarchicalOperator = _core.HierarchicalOperator

__all__ = [
    "Scene", "Result", "HierarchicalOperator", "load", "energyplus_zones", "builtin_scenes", "methods", "point_factors", "solve_radiosity",
    "solve_thermal", "RadiosityResult", "ThermalResult", "repair", "exchange_factors", "render",
    "Error", "InputError", "OptionError", "GeometryError", "ResourceError", "Cancelled",
    "TextProgress", "__version__",
]


# Bound in C++ from their keyword tables (python/src/keywords.h): signature, docstring, checks.
load = _core.load
point_factors = _core.point_factors


def energyplus_zones(path):
    """The zone names of an EnergyPlus model (``.idf`` or ``.epJSON``), in file order: the
    names load(path, zone=NAME) takes. Raises InputError for a bad file."""
    return list(_core.energyplus_zones(_os.fspath(path)))


def builtin_scenes():
    """Names of the built-in scenes."""
    return list(_core.builtin_scenes())


def methods():
    """Names of the methods that ``Scene.form_factors(method=...)`` accepts."""
    return list(_core.method_names())


def _is_scipy_sparse(F):
    return type(F).__module__.startswith("scipy.sparse")


def _core_matrix(F):
    """F as _core takes it: a scipy.sparse matrix becomes ("csr", indptr, indices, data) with
    sorted, summed entries; anything else is passed as it is."""
    if not _is_scipy_sparse(F):
        return F
    import scipy.sparse as sp
    if not sp.issparse(F):
        return F
    if F.shape[0] != F.shape[1]:
        raise OptionError("F: a sparse F must be square, got %dx%d" % F.shape, "F")
    c = sp.csr_matrix(F, dtype=float, copy=True)
    c.sum_duplicates()
    c.sort_indices()
    return ("csr", _np.asarray(c.indptr, dtype=_np.int64), _np.asarray(c.indices, dtype=_np.int32),
            _np.asarray(c.data, dtype=float))


def _default_solver(F, dense_default):
    if isinstance(F, HierarchicalOperator):
        return "gmres"
    if _is_scipy_sparse(F):
        return "gmres" if dense_default == "direct" else "gauss-seidel"
    return dense_default


@_dataclass
class RadiosityResult:
    """The solution of B = E + ρ F B per colour channel."""
    radiosity: _np.ndarray  #: (N, 3) radiosity B per patch, in the units of the emission
    stats: dict             #: solver, iterations, residual, tolerance, converged, seconds
    balance: dict           #: emitted, absorbed, escaped (3,) powers and relative_defect


@_dataclass
class ThermalResult:
    """Grey-body radiative exchange (net-radiation method), per patch, SI units."""
    area: _np.ndarray
    emissivity: _np.ndarray
    temperature: _np.ndarray             #: K (prescribed or solved)
    temperature_prescribed: _np.ndarray  #: bool per patch
    radiosity: _np.ndarray               #: J, W/m²
    net_flux: _np.ndarray                #: q = J − H, W/m², positive = the patch loses heat
    net_power: _np.ndarray               #: q·A, W
    total_net_power: float
    escaped_power: float                 #: to the environment (0 in a closed enclosure)
    relative_balance_defect: float
    ambient_temperature: float
    stats: dict
    warnings: list


def solve_radiosity(scene, F, reflectance=None, emission=None, *, solver=None,
                    residual=1e-8, max_iterations=0, threads=0, progress=None, comm=None):
    """Solves the radiosity equation B = E + diag(ρ) F B for each of R, G, B.

    F: a :class:`Result` of this scene (used without a copy), an (N, N) array, F[i, j] from
    patch i to patch j, a scipy.sparse matrix (N, N) (``Result.sparse()``, a Matrix Market or
    HDF5 file read with SciPy/h5py; solved by ``gauss-seidel``, ``gmres`` or ``jacobi`` on its
    stored entries, never densified), or the scene's :class:`HierarchicalOperator`. reflectance ρ and
    emission E: per patch, (N, 3), (N,) (grey) or a scalar; by default the scene's materials
    (MTL Kd and Ke). solver: ``gauss-seidel`` (default for a matrix), ``jacobi``, ``shooting``
    (progressive refinement), ``direct`` (LU) or ``gmres`` (default for an operator, which
    takes gmres or jacobi). Returns a :class:`RadiosityResult`.

    comm: an mpi4py communicator (``MPI.COMM_WORLD``) to solve over its ranks under mpirun.
    Every rank calls with the same arguments; only rank 0's F is read (the others may pass
    None). With ``gauss-seidel``, ``gmres`` or ``jacobi`` on a matrix, rank 0 sends each rank a
    block of rows of F and every rank iterates on its own rows: jacobi and gmres give the one
    process's result bit for bit, gauss-seidel one within ``residual`` of it. Other solvers and
    the operator run on rank 0 alone. Rank 0 gets the result, the others None
    (docs/cluster.md).
    """
    solver = _default_solver(F, "gauss-seidel") if solver is None else solver
    d = _core.radiosity(scene, _core_matrix(F), reflectance, emission, solver, residual,
                        max_iterations, threads, progress, comm)
    return None if d is None else RadiosityResult(**d)


def solve_thermal(scene, F, emissivity=None, temperature=None, net_flux=None, *,
                  ambient_temperature=0.0, solver=None, residual=1e-8, max_iterations=0,
                  threads=0, progress=None, comm=None):
    """Radiative heat exchange between grey diffuse patches (net-radiation method).

    Each patch has an emissivity ε and either a temperature T (K) or a net flux q (W/m²,
    leaving the patch); a patch with neither is adiabatic (q = 0). emissivity, temperature,
    net_flux: per patch (N,) or a scalar; NaN in temperature / net_flux means "not given" for
    that patch. Defaults come from the scene's materials. ambient_temperature: the black
    environment that the open part of each row sees (K). F as in solve_radiosity. solver:
    ``direct`` by default for a matrix, ``gmres`` for an operator or a sparse F. Returns a
    :class:`ThermalResult` (temperature, radiosity, net_flux, net_power, total_net_power, ...).

    comm: an mpi4py communicator to solve over its ranks, as in solve_radiosity (pass
    ``solver="gmres"``: the default ``direct`` solve of a matrix runs on rank 0 alone).
    """
    solver = _default_solver(F, "direct") if solver is None else solver
    d = _core.thermal(scene, _core_matrix(F), emissivity, temperature, net_flux,
                      ambient_temperature, solver, residual, max_iterations, threads,
                      progress, comm)
    return None if d is None else ThermalResult(**d)


def repair(F, areas, mode="both", *, enclosure=False, force_closure=False):
    """Repairs a form-factor matrix: ``reciprocity`` (symmetrises A_i F_ij), ``closure``
    (scales rows to sum to 1, keeping reciprocity; closed scenes: enclosure=True, or
    force_closure) or ``both``. F is not changed: returns (repaired copy, report dict).
    """
    F2, text = _core.repair(F, areas, mode, enclosure, force_closure)
    return F2, _json.loads(text)


def exchange_factors(F, emissivity):
    """Hottel's total exchange factors 𝓕 = diag(ε) F (I − diag(1−ε) F)⁻¹ diag(ε): 𝓕[i, j] is
    the fraction of the power a black body at i's temperature would emit over A_i that j
    absorbs after any number of diffuse reflections (F[i, j] from i to j; Σ_j 𝓕_ij = ε_i in a
    closed enclosure). emissivity: (N,) in (0, 1], or a scalar. O(N³)."""
    eps = _np.broadcast_to(_np.asarray(emissivity, dtype=float), (_np.shape(F)[0],))
    if not _np.all((eps > 0) & (eps <= 1)):
        raise OptionError("emissivity: every value must be in (0, 1]", "emissivity")
    return _core.exchange_factors(F, _np.ascontiguousarray(eps))


def render(scene, values=None, *, width=640, height=640, path=None, flat=False, exposure=0.0,
           label="", unit="", vmin=None, vmax=None, camera=None, supersample=2,
           back_faces=False):
    """A picture of the scene: an (height, width, 3) uint8 sRGB array, also written as a PNG
    to ``path`` when given (atomically).

    values: None (each patch in its material's colour), an (N, 3) radiosity (linear RGB,
    exposed automatically unless exposure > 0), or an (N,) value per patch shown in false
    colour (inferno) with a colour bar labelled ``label`` [``unit``] over [vmin, vmax] (default:
    the values' range). camera: {"eye": (x, y, z), "target": ..., "up": ..., "fov": degrees};
    default: the scene's camera or one that sees everything.
    """
    return _core.render(scene, values, width, height, "" if path is None else _os.fspath(path),
                        flat, exposure, label, unit, vmin, vmax, camera, supersample, back_faces)
