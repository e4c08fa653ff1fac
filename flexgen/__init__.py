"""flexgen: the smooth curvature model of planar flexures, as generated NumPy and C99 kernels.

Public API::

    flexgen.load_scene(path) -> Scene
    flexgen.solve(scene_or_path, model=None, modes=None, elements=None, **options) -> Result
    flexgen.Solver(scene_or_path, ...) -> a prepared solver: .solve(loads=..., tensions=...)
    flexgen.SolverSettings(...)       every solver default and tuning constant (frozen)
    flexgen.sweep(scene_or_path, vary={...}, samples=None, seed=None, workers=None, client=None)
                                      -> a pandas DataFrame, one row per case (docs/sweep.md)
    Scene.with_value(path, value) -> Scene   one value changed by its dotted path
    flexgen.generate(modes, kernel="poly", ...) -> {relative path: text}   (needs SymPy)
    flexgen.plot(scene_or_path, result=None, ax=None) -> matplotlib Axes  (needs matplotlib)

See docs/solve.md, docs/scene.md and docs/sweep.md.
"""

from __future__ import annotations

import re
from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING, Any

from .codegen.spec import DEFAULT_TOL
from .result import PointResult, Result
from .scene import SceneError, load_scene, scene_from_dict
from .settings import SolverSettings

try:  # what needs the compiled core
    from .api import PreparedSolver as Solver
    from .api import solve
    from .sweep import sweep
except ImportError as _exc:  # the core missing or stale: the rest of the package still loads
    if type(_exc).__name__ != "CoreUnavailable":  # (flexgen generate, the CLI's one line)
        raise
    _core_error = _exc

    def __getattr__(name: str) -> Any:
        if name in ("Solver", "solve", "sweep"):
            raise _core_error
        raise AttributeError(f"module 'flexgen' has no attribute {name!r}")


if TYPE_CHECKING:  # the annotations' names only: not the package's namespace
    import os
    from collections.abc import Mapping, Sequence

    from .scene import Scene

try:
    __version__ = version("flexgen")
except PackageNotFoundError:  # pragma: no cover - imported from a tree not installed
    __version__ = "0+unknown"


def generate(
    modes: int,
    kernel: str = "poly",
    range_deg: float | None = None,
    degree: int | None = None,
    nodes: int | None = None,
    tol: float = DEFAULT_TOL,
    langs: Sequence[str] = ("numpy", "c"),
) -> dict[str, str]:
    """Generate one flexure kernel: {relative path: source text} (nothing is written).

    Same arguments as ``flexgen generate`` (``kernel`` "poly", "gauss" or "local"; ``langs`` from
    "numpy", "c"). Imports SymPy, so only when called. A request that cannot be generated is a
    ``ValueError`` naming the argument."""
    from .codegen.generate import generate_files
    from .codegen.spec import BACKENDS, KernelSpec

    unknown = [lang for lang in langs if lang not in BACKENDS]
    if isinstance(langs, str) or unknown or not langs:
        raise ValueError(f"langs: a sequence of {', '.join(map(repr, BACKENDS))}, got {langs!r}")
    try:
        spec = KernelSpec(modes, kernel, range_deg, degree, nodes, tol)
        return generate_files(spec, tuple(langs))
    except ValueError as exc:  # the messages name the CLI's options: here, the arguments
        raise type(exc)(_ARGUMENT_OF_OPTION.sub(lambda m: _ARGUMENTS[m[1]], str(exc))) from None


# flexgen generate's option -> flexgen.generate's argument, for the shared messages
_ARGUMENTS = {
    "modes": "modes",
    "kernel": "kernel",
    "range": "range_deg",
    "degree": "degree",
    "nodes": "nodes",
    "tol": "tol",
}
_ARGUMENT_OF_OPTION = re.compile(r"--(" + "|".join(_ARGUMENTS) + r")\b")


def plot(
    scene: Scene | Mapping[str, Any] | str | os.PathLike[str],
    result: Result | None = None,
    ax: Any = None,
    *,
    title: str | None = None,
) -> Any:
    """Draw a scene on a matplotlib Axes and return it: the mechanism unloaded (links as bodies,
    base, flexures, tendons, loads), or at ``result``'s equilibrium (``flexgen.solve(scene)``)
    with stress colouring and compliance ellipses. ``ax``: draw there (its figure is used);
    None: a new pyplot figure. Writes and shows nothing (a notebook displays the figure;
    ``flexgen plot SCENE -o FILE`` writes one). See ``flexgen.drawing``."""
    from .drawing import plot as _plot

    return _plot(scene, result, ax, title=title)


__all__ = [
    "load_scene",
    "scene_from_dict",
    "solve",
    "Solver",
    "SolverSettings",
    "sweep",
    "generate",
    "plot",
    "SceneError",
    "Result",
    "PointResult",
    "__version__",
]
