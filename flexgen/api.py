"""The front door: ``flexgen.solve`` and ``flexgen.Solver``.

``solve(scene, model=None, modes=None, elements=None, *, models=None, settings=None, q0=None,
tolerance=None, **options)``:

- ``scene``: a ``Scene``, a dict (``scene_from_dict``) or a path to a TOML file (``load_scene``);
- ``model`` / ``modes`` / ``elements``: override every flexure's ``kind`` / ``modes`` /
  ``elements`` (they beat the scene's ``[model]`` and per-flexure keys; ``modes``, and a
  ``model`` other than "scm", also clear the scene's ``tolerance``, since the modes, or another
  model, are then given; with the ``tolerance`` argument
  ``modes`` or ``elements`` is a ValueError, as ``--tol`` with ``--modes`` is exit 2; a count
  the ``model`` given does not read, such as ``modes`` with ``"cc"``, is a SceneError);
- ``models``: {flexure: FlexureModel} for some flexures (the others from the scene);
- ``settings``: a ``SolverSettings``; ``options``: any of its fields by name (``tol``,
  ``max_steps``, ...), checked; ignored by the exact solver;
- ``q0``: a warm start ({flexure: coordinates}; checked, and ignored by the exact solver);
- ``tolerance`` (or ``[model] tolerance``): choose the fewest modes per flexure that meet it
  (``flexgen.select``);
- ``estimate`` (default True): give every chain-model answer its error estimate
  (``flexgen.estimate``: Newton on the richer model from the answer); False skips it, for
  speed-critical loops.

Kind ``"exact"`` must apply to every flexure (the elastica solver solves the whole scene at once);
it runs ``models.exact.solve_exact`` and converts its answer (``flexgen.exact_result``). Every
other scene is solved by the compiled core (``flexgen.solver.Solver``); the last prepared solvers
are kept per Scene object, so solving the same scene again costs the core call and the Result.

Every chain-model answer states its estimated error (``Result.error_estimate``, each point's
``error_estimate``; ``flexgen.estimate``) and every converged one is checked for what makes a
model invalid (``flexgen.validity``: prb past its range, a kernel past its certified range, a
load near a critical one); those warnings are appended to ``Result.warnings``.
"""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from collections.abc import Iterable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from .result import Result
from .scene import (
    MAX_ELEMENTS,
    MAX_MODES,
    MODEL_KINDS,
    Scene,
    SceneError,
    _fmt,
    as_scene,
    check_limits,
)
from .settings import DEFAULT, SolverSettings
from .solver import Solver, check_flag, checked_q0, make_settings
from .validity import calm as validity_calm
from .validity import check, loads_scene, units_reason


def _count(value, key: str, maximum: int) -> int | None:
    if value is None:
        return None
    # a NumPy integer too (np.arange, an array element): what with_value and sweep take
    if (
        isinstance(value, bool | np.bool_)
        or not isinstance(value, int | np.integer)
        or not 1 <= value <= maximum
    ):
        raise SceneError(f"{key}: must be an integer in [1, {maximum}], got {_fmt(value)}")
    return int(value)


def _unused_count(
    model: str | None, modes: Any, elements: Any, kinds: Iterable[str] = ()
) -> tuple[str, str] | None:
    """``(option, why)`` when ``modes`` or ``elements`` is given with a ``model`` kind that does
    not read it, or, with no ``model``, when none of the scene's flexure ``kinds`` reads it (it
    would be dropped silently: ``cc`` is scm with one mode), else None. The CLI words it with
    its flags (``--modes``), ``override`` with the keyword."""
    used = {model} if model is not None else set(kinds)
    for option, value, reader in (("modes", modes, "scm"), ("elements", elements, "fem")):
        if value is None or reader in used:
            continue
        if model is None:
            why = f"its flexures are {', '.join(sorted(used))}"
            if option == "modes" and "cc" in used:
                why += "; cc is scm with one mode"
        elif option == "modes" and model == "cc":
            why = "cc is scm with one mode"
        else:
            why = f"only {reader} has {option}"
        return option, why
    return None


def unused_count_message(
    model: str | None, modes: Any, elements: Any, kinds: Iterable[str], flag: str = ""
) -> str | None:
    """``_unused_count`` as the one-line refusal, its options spelled with ``flag`` ("--" on
    the command line: ``--modes: not used with --model cc (...)``), or None."""
    unused = _unused_count(model, modes, elements, kinds)
    if unused is None:
        return None
    option, why = unused
    if model is None:
        with_what = "by this scene"
    else:
        with_what = f"with {flag}model {model}" if flag else f"with model {model!r}"
    return f"{flag}{option}: not used {with_what} ({why})"


def replaced_tolerance_note(
    scene: Scene, overridden: Scene, model: str | None, modes: int | None
) -> str | None:
    """The note an answer gets when an override replaced the scene's tolerance (``override``:
    modes, or a model kind other than scm, given): a fact about the answer, not a fault in it
    (its error estimate still says how accurate it is; review: --model fem on a scene asking
    for 1e-7 answered at 1.4e-3 with nothing saying the tolerance was not applied)."""
    from .select import scene_tolerance

    tol = scene_tolerance(scene)
    if tol is None or scene_tolerance(overridden) is not None or model == "exact":
        return None  # (the exact elastica: the reference every tolerance is measured against)
    given = f"modes = {modes}" if modes is not None else f"model {model!r}"
    return (
        f"the scene's tolerance {tol:g} is not applied: {given} was given (a tolerance chooses "
        "the smooth curvature modes); error_estimate says how accurate this answer is"
    )


def override(
    scene: Scene, model: str | None = None, modes: int | None = None, elements: int | None = None
) -> Scene:
    """``scene`` with every flexure's model kind, modes and elements replaced where given; a
    count the model kind does not read is a SceneError (``_unused_count``)."""
    if model is not None and (not isinstance(model, str) or model not in MODEL_KINDS):
        raise SceneError(
            f"model: unknown kind {_fmt(model)} (choose from {', '.join(MODEL_KINDS)})"
        )
    modes = _count(modes, "modes", MAX_MODES)
    elements = _count(elements, "elements", MAX_ELEMENTS)
    refusal = unused_count_message(model, modes, elements, (f.model.kind for f in scene.flexures))
    if refusal is not None:
        raise SceneError(refusal)
    changes: dict[str, Any] = {}
    if model is not None:
        changes["kind"] = model
        if model != "scm":  # a tolerance chooses scm modes: another kind given replaces it
            changes["tolerance"] = None
    if modes is not None:
        changes.update(modes=modes, tolerance=None)
    if elements is not None:
        changes["elements"] = elements
    if not changes:
        return scene
    flexures = tuple(replace(f, model=replace(f.model, **changes)) for f in scene.flexures)
    scene = replace(scene, model=replace(scene.model, **changes), flexures=flexures)
    check_limits(scene)
    return scene


def uses_exact(scene: Scene) -> bool:
    """True if the scene asks for the exact solver (every flexure kind "exact"); SceneError if
    only some flexures do."""
    exact = [f.model.kind == "exact" for f in scene.flexures]
    if any(exact) and not all(exact):
        i = exact.index(True)
        raise SceneError(
            f"flexure[{i}].kind: 'exact' solves the whole scene; give it to every "
            f'flexure ([model].kind = "exact" or --model exact), got it for '
            f"{scene.flexures[i].name!r} only"
        )
    return bool(exact) and all(exact)


# the prepared solvers of the last scenes solved through ``solve`` (keyed by the Scene object,
# which is immutable, and the settings); one solve at a time through them
CACHE_SIZE = 64
_solvers: OrderedDict[tuple, Solver] = OrderedDict()
_lock = threading.Lock()


def _key(scene: Scene, settings: SolverSettings) -> tuple:
    # the defaults by identity (no hash of 35 fields on the loop path), other settings by value
    return (id(scene), None if settings is DEFAULT else settings)


def _same(a: SolverSettings, b: SolverSettings) -> bool:
    return a is b or a == b


class CheckedSolver(Solver):
    """``flexgen.Solver``'s solver: its answers warn as ``flexgen.solve``'s do. ``solve`` runs
    the validity check, only where the core's screen (``validity.calm``: ``fg_answer.calm``)
    finds that a warning may apply (the usual answer: one flag read). The internal solvers of
    selection, studies and benchmarks are plain ``Solver``s."""

    def _check(self, result: Result) -> None:
        # in Solver.solve, while the workspace holds this answer (validity.calm reads it)
        scene = loads_scene(self)
        if result.converged:
            if scene is not self.scene or not validity_calm(self):
                check(scene, result, self.models)
        else:
            _units_hint(scene, result)


def _cached_solver(scene: Scene, settings: SolverSettings) -> Solver:
    key = _key(scene, settings)
    solver = _solvers.get(key)
    if solver is None or solver.scene is not scene or not _same(solver.settings, settings):
        solver = CheckedSolver(scene, settings=settings)
        _solvers[key] = solver
        if len(_solvers) > CACHE_SIZE:
            _solvers.popitem(last=False)
    return solver


def _check_inputs(scene: Scene, models: Any, q0: Any) -> None:
    """TypeError/ValueError naming the key for a ``models`` or ``q0`` that is not a mapping of
    the scene's flexures to models / finite coordinates (q0: ``solver.checked_q0``, the check
    ``Solver.solve`` makes)."""
    names = {f.name for f in scene.flexures}
    if models is not None:
        if not isinstance(models, Mapping):
            raise TypeError(
                f"models: expected a dict {{flexure: ...}}, got {type(models).__name__}"
            )
        for name, value in models.items():
            if name not in names:
                raise ValueError(f"models: unknown flexure {_fmt(name)}")
            if not hasattr(value, "n_dof"):  # the registry refuses a kind it does not know
                raise TypeError(
                    f"models[{name!r}]: expected a flexure model (flexgen.models), "
                    f"got {type(value).__name__}"
                )
    if q0 is not None:
        checked_q0(q0, names)


def solve_scene(
    scene: Scene,
    models: Mapping[str, Any] | None = None,
    settings: SolverSettings | None = None,
    q0: Mapping[str, Any] | None = None,
    tolerance: float | None = None,
    estimate: bool = True,
    **options: Any,
):
    """``(Result, exact SceneSolution or None)`` for an already overridden scene; see ``solve``.

    A chain-model result carries its error estimate (``estimate=True``; with a tolerance, the
    selection's) and, when converged, the validity warnings of its models
    (``flexgen.validity.check``: appended to ``warnings``). A failed solve at a load level that
    suggests the wrong units says so at the end of its reason (``validity.units_reason``)."""
    check_flag(estimate, "estimate")  # "no" would be truthy
    result, solution = _solve_scene(scene, models, settings, q0, tolerance, estimate, **options)
    if not result.converged:
        _units_hint(scene, result)
    return result, solution


def _units_hint(scene: Scene, result: Result) -> None:
    """End a failed solve's reason with ``validity.units_reason`` when its load level suggests
    the wrong units (once)."""
    hint = units_reason(scene)
    if hint and hint not in (result.reason or ""):
        result.reason = f"{result.reason or 'not converged'}; {hint}"


def _solve_prepared(solver: Solver, q0: Mapping[str, Any] | None, estimate: bool) -> Result:
    """A solve by a cached prepared solver (a ``CheckedSolver``), assessed and checked, in the
    lock: ``validity.calm`` reads the answer's bends and kernels in the shared workspace."""
    with _lock:
        return solver.solve(q0=q0, estimate=estimate)


def _solve_scene(
    scene: Scene,
    models: Mapping[str, Any] | None,
    settings: SolverSettings | None,
    q0: Mapping[str, Any] | None,
    tolerance: float | None,
    estimate: bool,
    **options: Any,
):
    if q0 is not None or models is not None:
        _check_inputs(scene, models, q0)
    if (
        models is None
        and tolerance is None
        and not options
        and (settings is None or isinstance(settings, SolverSettings))
    ):
        # the same Scene object again (a loop): its prepared solver, if one is kept, says the
        # scene is neither exact nor asking for a tolerance
        settings = DEFAULT if settings is None else settings
        solver = _solvers.get(_key(scene, settings))
        if solver is not None and solver.scene is scene and _same(solver.settings, settings):
            return _solve_prepared(solver, q0, estimate), None
    settings = make_settings(settings, **options)  # checked also where exact ignores them
    if uses_exact(scene):
        from .select import check_choosable, check_tolerance, scene_tolerance

        if tolerance is not None or scene_tolerance(scene) is not None:
            # refused as for cc, prb and fem (review: the exact solver dropped it silently)
            if tolerance is not None:
                check_tolerance(tolerance)
            check_choosable(scene)
        if models is not None:  # they would be dropped: every flexure is the elastica
            raise ValueError(
                "models: the exact model solves every flexure as the elastica; give models or "
                "model='exact', not both"
            )
        from . import exact_result

        return exact_result.solve(scene)
    if tolerance is None and models is None:
        from .select import scene_tolerance

        tolerance = scene_tolerance(scene)
    if tolerance is not None:
        if models is not None:
            raise ValueError("solve: tolerance chooses the models; do not also pass models")
        from .select import solve_to_tolerance

        return solve_to_tolerance(scene, tolerance, settings=settings), None  # checked there
    if models is not None:
        result = CheckedSolver(scene, models, settings).solve(q0=q0, estimate=estimate)
    else:
        with _lock:
            result = _cached_solver(scene, settings).solve(q0=q0, estimate=estimate)
    return result, None


def solve(
    scene: Scene | Mapping[str, Any] | str | os.PathLike,
    model: str | None = None,
    modes: int | None = None,
    elements: int | None = None,
    *,
    models: Mapping[str, Any] | None = None,
    settings: SolverSettings | None = None,
    q0: Mapping[str, Any] | None = None,
    tolerance: float | None = None,
    estimate: bool = True,
    **options: Any,
) -> Result:
    """Solve a scene: its equilibrium under the scene's loads and tendons, the output points'
    poses and compliances, each flexure's stresses, warnings and notes, in the scene's units.

    - ``scene``: a ``Scene``, a dict (``scene_from_dict``) or a path to a TOML file;
    - ``model`` / ``modes`` / ``elements``: override every flexure's ``kind`` / ``modes`` /
      ``elements`` (a count no flexure reads, such as ``modes`` with ``"cc"``, is a SceneError);
    - keyword ``models``: {flexure: FlexureModel} for some flexures; ``settings``: a
      ``SolverSettings``, or any of its fields by name (``tol``, ``max_steps``, ...); ``q0``: a
      warm start {flexure: coordinates}; ``tolerance``: choose the fewest modes per flexure
      that meet it (``flexgen.select``); ``estimate`` (default True): the answer's error
      estimate (False skips it).

    Returns a ``Result`` (``converged`` False with a ``reason`` when there is no equilibrium).
    Bad input raises a one-line SceneError or ValueError naming the argument. More in the
    module docstring and docs/solve.md."""
    plain = (
        models is None
        and settings is None
        and q0 is None
        and tolerance is None
        and estimate is True
    )  # (estimate "no" is truthy: only True takes the loop path, which does not check it)
    if plain and not options and model is None and modes is None and elements is None:
        # the loop path (the same Scene object, nothing overridden): its cached solver, if one
        # is kept, without the generic argument handling below (what it would do, in short)
        solver = _solvers.get((id(scene), None))  # _key(scene, DEFAULT)
        if (
            solver is not None
            and solver.scene is scene  # so scene is that Scene (as_scene and override: itself)
            and _same(solver.settings, DEFAULT)
        ):
            result = _solve_prepared(solver, None, True)
            if not result.converged:
                _units_hint(scene, result)
            return result
    if tolerance is not None and (modes is not None or elements is not None):
        # the tolerance would choose the modes and drop these silently (as --tol with --modes)
        given = "modes" if modes is not None else "elements"
        raise ValueError(
            f"tolerance: chooses the modes itself: give either tolerance or {given}, not both"
        )
    as_given = as_scene(scene)
    sc = override(as_given, model, modes, elements)
    result = solve_scene(
        sc, models, settings, q0=q0, tolerance=tolerance, estimate=estimate, **options
    )[0]
    note = replaced_tolerance_note(as_given, sc, model, modes) if tolerance is None else None
    if note is not None:
        result.notes.append(note)
    return result


class PreparedSolver(CheckedSolver):
    """``flexgen.Solver``: a solver for repeated solves of one scene, with the same scene
    arguments and overrides as ``flexgen.solve``. ``solve(loads=..., tensions=...)`` skips the
    scene handling: the core call, the Result and, where the core's screen finds a warning may
    apply, ``flexgen.solve``'s validity check (``CheckedSolver``). A class, so that
    ``isinstance(s, flexgen.Solver)`` and annotations ``s: flexgen.Solver`` work (it was a
    function: review)."""

    def __init__(
        self,
        scene: Scene | Mapping[str, Any] | str | os.PathLike,
        model: str | None = None,
        modes: int | None = None,
        elements: int | None = None,
        models: Mapping[str, Any] | None = None,
        settings: SolverSettings | None = None,
        **options: Any,
    ) -> None:
        given = as_scene(scene)
        sc = override(given, model, modes, elements)
        if uses_exact(sc):
            raise SceneError("Solver: the exact model is a reference solver; use flexgen.solve")
        from .select import scene_tolerance

        if models is None and scene_tolerance(sc) is not None:
            # its modes would be the defaults, not the tolerance's: a silently other model
            raise SceneError(
                "Solver: the scene asks for a tolerance, which chooses the modes per solve; give "
                "modes instead (flexgen select SCENE --tol T says which), or use flexgen.solve"
            )
        if models is not None:  # flexgen.solve's check: a bad model would fail deep in the build
            _check_inputs(sc, models, None)
        super().__init__(sc, models, make_settings(settings, **options))
        note = replaced_tolerance_note(given, sc, model, modes)
        if note is not None:  # on every Result, as the scene's own notes (solver.py)
            self._scene_notes.append(note)
