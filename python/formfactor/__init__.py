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
energyplus_zones = _core.energyplus_zones
point_factors = _core.point_factors
solve_radiosity = _core.solve_radiosity
solve_thermal = _core.solve_thermal
repair = _core.repair
exchange_factors = _core.exchange_factors
render = _core.render


def builtin_scenes():
    """Names of the built-in scenes."""
    return list(_core.builtin_scenes())


def methods():
    """Names of the methods that ``Scene.form_factors(method=...)`` accepts."""
    return list(_core.method_names())


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
