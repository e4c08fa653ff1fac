"""Solve a scene with the compiled core: the prepared ``Solver`` and the Result it builds.

The algorithm is written once, in C (``flexgen/compiled/chain_solver.c``; read its header
comment for the method: the direct full-load Newton solve, the load continuation with its
bifurcations and snap-throughs, kernel switches, the warm start, polishing, compliance). This
module turns a scene into the core's ``Problem`` (``flexgen.problem``), calls the core, and turns
its answer into a ``Result``: the warnings for critical load factors and kernel switches, the
reason when no equilibrium was found. When the core cannot finish it says why; nothing is solved
twice.

    s = flexgen.Solver("examples/two_link_finger.toml")      # prepared once
    for f in forces:
        r = s.solve(loads=[[0.0, -f, 0.0]])                   # one row per [[load]], scene order

``flexgen.solve`` (``flexgen.api``) keeps the last prepared solvers, so solving the same Scene
object again costs the core call and the Result.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Container, Mapping
from dataclasses import dataclass, fields, replace
from functools import partial
from typing import Any

import numpy as np

from . import core
from .estimate import estimate_answer
from .models.base import FlexureModel
from .models.registry import build_models, model_info
from .problem import Problem, Workspace, answer_views
from .result import UNSTABLE, LazyResult, Result, point_result
from .scene import MAX_MAGNITUDE, Scene, _fmt, _number
from .scene_checks import scene_notes, scene_warnings
from .settings import DEFAULT, SolverSettings
from .statics import chain_statics, end_curvatures, scene_loads
from .stress import flexure_stresses, has_area, has_strengths, safety_warnings
from .units import result_units

# Why the solve took the side it did past a bifurcation (the core reports the index plus one:
# chain_solver.h's FG_BUCKLING_*).
BUCKLING_SIDES = (
    "the only stable side found",
    "the side of lower potential energy",
    "symmetric: the side of larger world y, by convention",
    "symmetric: the counter-clockwise side, by convention",
)


# fg_answer.kernel (FG_KERNEL_*): the kernel evaluating a smooth curvature flexure at equilibrium
KERNEL_STATES = {
    core.lib.FG_KERNEL_LOCAL: "local",
    core.lib.FG_KERNEL_POLY: "poly",
    core.lib.FG_KERNEL_POLY_PAST: "poly past its range",
    core.lib.FG_KERNEL_GAUSS: "gauss",
    core.lib.FG_KERNEL_GAUSS_PAST: "gauss past its certified range",
}


def kernel_state(model: Any, kernel: int) -> str:
    """``KERNEL_STATES[kernel]``, "poly past its range" read as "local past its range" where the
    model's only first kernel is the local one (kernel "local" with no Gauss kernel)."""
    state = KERNEL_STATES[kernel]
    if state == "poly past its range" and getattr(model, "poly", None) is None:
        return "local past its range"
    return state


_SOLVED, _MODEL_ERROR = core.SOLVED, core.MODEL_ERROR
_fg_solve = core.lib.fg_solve


def buckling_note(lam_c: float, why: str) -> str:
    """The warning of a bifurcation crossed at critical load factor ``lam_c``."""
    return (
        f"buckling: bifurcation at critical load factor {lam_c:.10g} (the stiffness "
        f"matrix lost positive definiteness); continued on the stable post-buckled "
        f"branch ({why})"
    )


def snap_note(lam: float) -> str:
    """The warning of a path that ends at a limit point near load factor ``lam``."""
    return (
        f"snap-through: the equilibrium path ends at a limit point near load factor "
        f"{lam:.6g}; the solve continued from the stable equilibrium it jumps to"
    )


def make_settings(settings: SolverSettings | None = None, **options: Any) -> SolverSettings:
    """``settings`` (default: the defaults) with ``options`` replacing fields of the same name;
    an unknown name is a TypeError naming it, a bad value a ValueError naming it."""
    base = DEFAULT if settings is None else settings
    if not isinstance(base, SolverSettings):
        raise TypeError(f"settings: expected a flexgen.SolverSettings, got {type(base).__name__}")
    if not options:
        return base
    names = {f.name for f in fields(SolverSettings)}
    unknown = sorted(set(options) - names)
    if unknown:
        raise TypeError(
            f"unknown solver setting {unknown[0]!r} (the settings: {', '.join(sorted(names))})"
        )
    return replace(base, **options)


def check_flag(value: Any, key: str) -> None:
    """TypeError naming ``key`` unless ``value`` is a bool (a string such as "no" is truthy)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{key}: must be True or False, got {_fmt(value)}")


def checked_q0(q0: Any, flexures: Container[str]) -> dict[str, np.ndarray]:
    """A warm start ``{flexure: coordinates}`` as ``{flexure: 1-D float array}``: a TypeError if
    it is not a mapping, a ValueError naming the key for a flexure not in ``flexures`` or
    coordinates that are not a list of finite numbers. ``flexgen.solve`` and ``Solver.solve``
    check q0 with it (on the loop path of a warm start: written for speed)."""
    if type(q0) is not dict and not isinstance(q0, Mapping):  # a dict: no ABC check
        raise TypeError(f"q0: expected a dict {{flexure: ...}}, got {type(q0).__name__}")
    out = {}
    for name, value in q0.items():
        if name not in flexures:
            raise ValueError(f"q0: unknown flexure {_fmt(name)}")
        try:  # booleans are not coordinates (as loads and tensions: review)
            v = None if _has_bool(value) else np.asarray(value, dtype=float)
        except (TypeError, ValueError, OverflowError):
            v = None
        if v is not None and v.ndim <= 1 and getattr(value, "dtype", None) != np.bool_:
            if not v.ndim:
                v = v.reshape(1)
            # all(map(isfinite)) on the list: a fraction of np.isfinite's cost on a few values
            if all(map(math.isfinite, v.tolist())):
                out[name] = v
                continue
        raise ValueError(f"q0[{name!r}]: must be a list of finite numbers, got {_fmt(value)}")
    return out


def _has_bool(values: Any) -> bool:
    """Whether nested lists or tuples hold a bool, Python's or NumPy's (which NumPy reads as
    an integer)."""
    if isinstance(values, (bool, np.bool_)):
        return True
    if isinstance(values, (list, tuple)):
        return any(_has_bool(v) for v in values)
    return False


CONCURRENT = (
    "flexgen.Solver: called while this Solver is solving in another thread; use one Solver "
    "per thread (each has its own workspace)"
)


class Solver:
    """A scene prepared for repeated solves: its ``Problem`` and a ``Workspace``.

    ``models`` gives the FlexureModel of some or all flexures (the others are built from the
    scene's model keys); ``settings`` a ``SolverSettings``. ``solve`` may change the loads and
    tendon tensions (not the geometry). One solve at a time per Solver (the workspace is shared
    by its solves): use one Solver per thread.
    """

    def __init__(
        self,
        scene: Scene,
        models: Mapping[str, FlexureModel] | None = None,
        settings: SolverSettings | None = None,
    ):
        self.scene = scene
        self.settings = make_settings(settings)
        self.models = build_models(scene, models)
        self.problem = Problem(scene, self.models, self.settings)
        self.workspace = Workspace(self.problem)
        self._info = {name: model_info(m) for name, m in self.models.items()}
        self._units = result_units(scene)  # the JSON "units" object (None: plain numbers)
        self._scene_notes = scene_notes(scene)  # likely mistakes in the scene: on every Result
        self._scene_warnings = scene_warnings(scene)
        self._scene_loads = self.problem.loads.copy()
        self._scene_tensions = self.problem.tensions.copy()
        self._changed_loads = self._changed_tensions = False
        self._slices = list(self.problem.chain.slices.items())
        # what the answers' lazy fields need, without the workspace (AnswerFields)
        self._fields = AnswerFields(
            scene, self.models, self.problem, self._slices, self._info, self.workspace.shape
        )
        ws = self.workspace
        # fg_solve's arguments, made once (the loop path reads no attribute for them)
        self._core_args = (self.problem.struct, ws.work_ptr, ws.iwork_ptr, ws.answer)
        self._warm = False  # problem.struct.q0 points at ws.q0 (a warm start was asked)
        # any smooth curvature flexure (the core reports the kernel at equilibrium for those)
        self._kernel_models = any(model_info(m)["kind"] == "scm" for m in self.models.values())
        # any flexure whose model may switch kernels (no other sets the core's switch flag)
        self._switchable = any(
            getattr(m, "gauss", None) is not None
            and (getattr(m, "poly", None) is not None or getattr(m, "local", None) is not None)
            for m in self.models.values()
        )
        # with a strength given, every answer computes its stresses at once (its safety-factor
        # warnings belong to the answer); else only when Result.flexures is read
        self._strengths = has_strengths(scene)
        # made on first use and kept, from the scene and models only (no answer's state):
        self._validity_screen: Any = None  # validity.calm's bend limits, given to the core
        self._estimator: Any = None  # the richer model's prepared solver (estimate.estimator_of)
        # one solve at a time: a second thread's call is refused, not interleaved (a shared
        # Solver gave 28 wrong poses in 6000 from 4 threads, silently: review)
        self._in_use = threading.Lock()
        self._solved = False  # the workspace holds an answer (margin, margin_above read it)

    @property
    def outputs(self) -> list[str]:
        """The output points, in the order of ``Result.points``."""
        return list(self.problem.outputs)

    def solve(
        self,
        loads: Any = None,
        tensions: Any = None,
        q0: Mapping[str, Any] | None = None,
        estimate: bool = False,
    ) -> Result:
        """Equilibrium, stability and compliance under ``loads`` (one (fx, fy, moment) row per
        ``[[load]]`` of the scene, in its order, world frame; None: the scene's) and
        ``tensions`` (one per ``[[tendon]]``; None: the scene's). ``q0`` ({flexure:
        coordinates}, e.g. the previous answer's ``q``) is a warm start: Newton at the full load
        from q0, accepted if it converges to a stable equilibrium within ``max_dq`` of it that
        is on the load path from the unloaded state (``settings.warm_on_path``), else
        the solve starts from the unloaded state (a flexure's coordinates are padded with zeros
        or cut to its model's count, so an answer of another mode count also serves; a flexure
        left out starts at zero; an unknown flexure is a ValueError). ``estimate=True`` adds the error estimate
        (``flexgen.estimate``: Newton on the richer model from this answer; ``flexgen.solve`` asks
        for it by default): ``Result.error_estimate`` and each point's ``error_estimate``."""
        if estimate is not False and estimate is not True:  # the usual bools cost nothing more
            check_flag(estimate, "estimate")
        if not self._in_use.acquire(blocking=False):
            raise RuntimeError(CONCURRENT)
        try:  # the answer read from the workspace before another solve may overwrite it
            status = self._run(loads, tensions, q0)
            result = self._result(status, estimate_answer(self, status) if estimate else None)
            self._check(result)
            return result
        finally:
            self._in_use.release()

    @property
    def loads_changed(self) -> bool:
        """Whether the last solve was given loads or tensions other than the scene's own
        (``validity.loads_scene`` then checks the answer against them)."""
        return self._changed_loads or self._changed_tensions

    def _check(self, result: Result) -> None:
        """What a solve adds to its Result while the workspace still holds its answer (nothing
        here; ``flexgen.api.CheckedSolver``: the validity check)."""

    def run(
        self, loads: Any = None, tensions: Any = None, q0: Mapping[str, Any] | None = None
    ) -> int:
        """``solve`` without building a Result, for the tightest loops: the core's status
        (``flexgen.core.SOLVED`` when an equilibrium was found), the answer left in
        ``self.workspace`` (``q``, ``pose`` (noutputs x 3), ``compliance`` (noutputs x 3 x 3),
        ``ellipse``, ``K``; ``answer.stable``, ``answer.iterations``), overwritten by the next
        call. Outputs in the order of ``self.outputs``, q packed in the scene's flexure order."""
        if not self._in_use.acquire(blocking=False):
            raise RuntimeError(CONCURRENT)
        try:
            return self._run(loads, tensions, q0)
        finally:
            self._in_use.release()

    def _run(self, loads: Any, tensions: Any, q0: Mapping[str, Any] | None) -> int:
        p = self.problem
        if loads is not None or self._changed_loads:  # None: the scene's own
            self._changed_loads = loads is not None
            self._set(p.loads, self._scene_loads if loads is None else loads, "loads")
        if tensions is not None or self._changed_tensions:
            self._changed_tensions = tensions is not None
            self._set(
                p.tensions, self._scene_tensions if tensions is None else tensions, "tensions"
            )
        ws = self.workspace
        if q0 is not None:
            start = checked_q0(q0, p.chain.slices)  # flexgen.solve's check of q0
            ws.q0[:] = 0.0
            for name, v in start.items():
                sl = p.chain.slices[name]
                v = v[: sl.stop - sl.start]
                ws.q0[sl.start : sl.start + v.size] = v
            p.struct.q0 = ws.q0_ptr
            self._warm = True
        elif self._warm:
            p.struct.q0 = core.ffi.NULL
            self._warm = False
        self._solved = False  # (a ValueError below leaves no answer either)
        status: int = _fg_solve(*self._core_args)
        self._solved = status == _SOLVED
        if status == _MODEL_ERROR:  # the core checks the loads are finite, off Python's path
            for what, given in (("loads", p.loads), ("tensions", p.tensions)):
                if not np.all(np.isfinite(given)):
                    raise ValueError(f"{what}: every value must be finite")
        return status

    @staticmethod
    def _set(target: np.ndarray, values: Any, what: str) -> None:
        if values is target:
            return
        if not isinstance(values, np.ndarray) and hasattr(values, "magnitude"):
            # a pint Quantity: np.asarray keeps its magnitude and drops its unit (a load in
            # mN solved as N, review); the scene's own units are the only ones read here
            raise ValueError(
                f"{what}: give plain numbers in the scene's units, not a quantity with units "
                f"({_fmt(values)})"
            )
        try:  # no dtype: strings, booleans and ragged rows stay what they are, and are refused
            a = None if isinstance(values, (str, bytes)) else np.asarray(values)
        except (TypeError, ValueError, OverflowError):
            a = None
        if a is not None and a.size == 0 and target.size == 0 and a.dtype.kind in "iuf":
            return  # loads=[] for a scene without loads (NumPy reads it as shape (0,))
        if a is not None and (
            a.dtype.kind == "b" or (not isinstance(values, np.ndarray) and _has_bool(values))
        ):  # NumPy reads [True, 0.5, 0] as numbers; booleans are none (review)
            raise ValueError(f"{what}: every value must be a number, got {_fmt(values)}")
        # the exact shape: a (3, 2) array for (2, 3) loads, reshaped, would be other loads
        if a is None or a.dtype.kind not in "iuf" or a.shape != target.shape:
            got = f"shape {a.shape}" if a is not None and a.dtype.kind in "iuf" else _fmt(values)
            raise ValueError(
                f"{what}: expected {target.shape} numbers (the scene's "
                f"{'[[load]]' if what == 'loads' else '[[tendon]]'} entries), got {got}"
            )
        a = a.astype(float, copy=False)
        # the scene's rule for these values (scene._number: every value finite and within
        # MAX_MAGNITUDE, a tension zero or positive: a tendon cannot push, and the core would
        # solve a negative tension silently). The validator names the value it refuses but costs
        # microseconds a value; these sums (NaN and inf fail them; a false alarm only costs the
        # validator's pass) decide whether to ask it
        flat = a.ravel().tolist()
        if what == "tensions":
            sign = "0+"
            suspect = not (0.0 <= min(flat, default=0.0) and sum(flat) <= MAX_MAGNITUDE)
        else:
            sign = ""
            suspect = not sum(map(abs, flat)) <= MAX_MAGNITUDE
        if suspect:
            for index, x in zip(np.ndindex(a.shape), flat):
                _number(x, what + "".join(f"[{i}]" for i in index), sign)
        target[...] = a

    # ---- the answer -------------------------------------------------------------------------

    def _failed(
        self,
        status: int,
        iterations: int,
        notes: list[str],
        critical: list[float],
        lam: float,
        est: Any = None,
    ) -> Result:
        """The Result of a solve without an equilibrium: the reason, and what was met on the way
        (an error estimate asked for is inf: there is no answer to estimate)."""
        return Result(
            scene=self.scene.name,
            converged=False,
            stable=False,
            iterations=iterations,
            model={name: dict(v) for name, v in self._info.items()},
            q={},
            points={},
            # the scene's own warnings (a unit slip, a flexure too thick) may be why it failed
            # (review: the mixed-units warning was dropped with the answer)
            warnings=list(self._scene_warnings),
            notes=notes,
            reason=self._reason(status),
            critical_load_factors=critical,
            load_factor=lam,
            error_estimate=None if est is None else math.inf,
            units=None if self._units is None else dict(self._units),
        )

    def quiet(self, est: Any = None) -> bool:
        """True when the solved answer now in the workspace (with ``est``, its estimate or None)
        gets no warning and no note from ``_result`` but the safety factors' (``stress=False``)
        and the validity check's (``validity.calm`` screens those): read from the core's flags
        without building the Result. Every source of a message in ``_result`` is asked here, so
        a study's rows (``sweep_chunk``) skip the Result only where it would say nothing."""
        a = self.workspace.answer
        return bool(
            a.stable
            and not a.ncritical
            and not a.undefined_compliance
            and (est is None or not est.warning)
            and not self._scene_warnings
            and not self._scene_notes
            and not (self._switchable and 1 in self.workspace.switched.tolist())
        )

    def _result(self, status: int, est: Any = None, stress: bool = True) -> Result:
        # on every solve (flexgen.solve's loop): written for speed, every field as before;
        # stress=False: no flexures built, so no safety-factor warnings (a study's rows).
        # A new warning or note here is asked in ``quiet`` too.
        ws = self.workspace
        a = ws.answer
        if status == _MODEL_ERROR:  # the core refused the problem: the answer is not filled
            return self._failed(status, 0, [], [], 1.0, est)
        # the critical events and kernel switches are notes (facts of the path that do not
        # make the answer wrong); what may make it wrong is a warning
        notes: list[str] = list(self._scene_notes)
        critical: list[float] = []
        ncritical = a.ncritical
        if ncritical:
            stored = min(ncritical, a.max_critical)
            for lam, kind in zip(ws.critical[:stored].tolist(), ws.critical_kind[:stored].tolist()):
                critical.append(lam)
                notes.append(
                    snap_note(lam)
                    if kind == core.SNAP_THROUGH
                    else buckling_note(lam, BUCKLING_SIDES[kind - 1])
                )
            if ncritical > stored:
                notes.append(
                    f"{ncritical - stored} more critical events on the load path are not listed"
                )
        solved = status == _SOLVED
        if self._switchable:
            switched = ws.switched.tolist()
            if any(switched):
                self._switch_notes(switched, solved, notes, bool(a.warm))
        if not solved:
            return self._failed(status, a.iterations, notes, critical, a.failure_load_factor, est)
        stable = bool(a.stable)
        warnings: list[str] = list(self._scene_warnings) + ([] if stable else [UNSTABLE])
        # the core counts the points whose compliance has a non-finite entry (the points are
        # built on access, so the warning is given now)
        if a.undefined_compliance:
            p = self.problem
            for ref, c3 in zip(p.outputs, ws.compliance[: len(p.outputs)]):
                if not np.isfinite(c3).all():
                    warnings.append(
                        f"compliance of {ref!r} is undefined: the stiffness matrix is singular"
                    )
        r = LazyResult.__new__(LazyResult)  # no __init__: every slot is filled below
        r.scene, r.converged, r.stable, r.iterations = self.scene.name, True, stable, a.iterations
        r.warnings, r.reason, r.critical_load_factors, r.load_factor = warnings, None, critical, 1.0
        r.notes = notes
        r.energy, r.residual, r.tolerance = a.energy, a.residual, None
        if est is None:
            r.error_estimate = None
        else:
            r.error_estimate = est.total
            if est.warning:
                warnings.append(est.warning)
        r.solver = "core"
        # a copy of what the lazy fields are built from (the next solve overwrites the
        # workspace): the answer buffer in one copy, the kernels as a list, and the loads
        # and tensions where they are not the scene's (the axial stress reads them)
        p = self.problem
        snapshot = (
            ws.answer_data.copy(),
            ws.kernel.tolist() if self._kernel_models else (),
            est,
            None if est is None else self._estimator.curvature,  # no workspace held
            (p.loads.tolist(), p.tensions.tolist()) if self.loads_changed else None,
        )
        r._build = partial(self._fields.build, snapshot)
        r.units = None if self._units is None else dict(self._units)
        if self._strengths and stress:
            r.flexures = self._fields.build(snapshot, "flexures")
            warnings.extend(safety_warnings(self.scene, r.flexures))
        return r

    def _switch_notes(
        self, switched: list[int], solved: bool, notes: list[str], warm: bool = False
    ) -> None:
        """The notes of the flexures whose kernel the core switched (``fg_answer.switched``).
        A warm answer followed no load path, only Newton from the previous answer: a switch
        there and back is no fact of its answer (review: the same answer, warm, had a note the
        cold solve had not), so it notes only a flexure still past its first kernels."""
        p, q = self.problem, self.workspace.q
        for name, flag in zip(p.flexure_order, switched):
            if flag:
                sl = p.chain.slices[name]
                # only models with both kernels switch (SCMModel); the FlexureModel
                # protocol does not declare switch_note
                model: Any = self.models[name]
                if warm and solved and model.in_range(q[sl]):
                    continue
                msg = model.switch_note(q[sl] if solved else None)
                if msg:
                    notes.append(msg)

    def estimator(self):
        """The ``flexgen.estimate.Estimator`` of this solver's scene and models (the richer
        model's prepared solver; a ``SplitEstimator`` of two where scm7 or scm8 stand beside
        other models: ``estimate.estimate_groups``), built on first use and kept."""
        from .estimate import estimator_of

        return estimator_of(self)

    def margin_above(self, margin: float) -> bool:
        """Whether the last solve's answer's margin to a critical load (``margin()``) exceeds
        ``margin``: one Cholesky factorization (``fg_margin_above``), not the eigenvalue. False
        when the last solve found no equilibrium, or before any solve (no answer is safe)."""
        if not self._solved:
            return False
        ws = self.workspace
        return bool(
            core.lib.fg_margin_above(
                self.problem.struct, ws.K_ptr, margin, ws.work_ptr, ws.iwork_ptr
            )
        )

    def margin(self) -> float:
        """The margin to a critical load of the last solve's answer (``fg_margin``: the
        smallest eigenvalue of the stiffness scaled by the elastic energy's Hessian; 1 unloaded,
        1 - P/P_cr on an axial load, < 0 unstable). Eigenvalues, O(n^3): not part of ``solve``;
        each Result computes its own ``stability_margin`` the same way on first access. NaN when
        the last solve found no equilibrium, or before any solve (review: the workspace's stale
        stiffness gave the previous answer's margin after a failed solve, 0 before any)."""
        if not self._solved:
            return math.nan
        ws = self.workspace
        return float(core.lib.fg_margin(self.problem.struct, ws.K_ptr, ws.work_ptr, ws.iwork_ptr))

    def _reason(self, status: int) -> str:
        from .reasons import failure_reason

        return failure_reason(self, status)


@dataclass(frozen=True, eq=False)
class AnswerFields:
    """What a Result's lazy fields are built from besides the answer's own arrays: the scene,
    models and Problem, never the Workspace (a Result kept outlives its solver's scratch
    memory: model selection keeps one per mode choice, each solver's workspace freed)."""

    scene: Scene
    models: Mapping[str, FlexureModel]
    problem: Problem
    slices: list
    info: dict
    shape: tuple

    def build(self, snapshot: tuple, name: str) -> Any:
        """One of a LazyResult's fields (``LAZY_FIELDS``) from the answer's arrays."""
        data, kernel, est, estimator, loads = snapshot
        q, pose, compliance, ellipse, K, bend = answer_views(data, *self.shape)
        p = self.problem
        if name == "q":
            qs = q.tolist()
            return {n: qs[sl] for n, sl in self.slices}
        if name == "points":
            ests: list = [None] * len(p.outputs)
            if est is not None:
                ests = [{"pose": pe, "compliance": ce} for pe, ce in zip(est.pose, est.compliance)]
            return {
                ref: point_result(pose_i, c3, ell, e)
                for ref, pose_i, c3, ell, e in zip(
                    p.outputs, pose.tolist(), compliance.tolist(), ellipse.tolist(), ests
                )
            }
        if name == "model":
            return {n: dict(v) for n, v in self.info.items()}
        if name == "stiffness":
            return K
        if name == "bend":
            return dict(zip(p.flexure_order, bend.tolist()))
        if name == "stability_margin":
            return margin_of(p, K)
        if name == "kernel":
            return {
                n: kernel_state(self.models[n], k) for n, k in zip(p.flexure_order, kernel) if k
            }
        if name == "flexures":
            qs = {n: q[sl] for n, sl in self.slices}
            estimated = est is not None and estimator is not None
            statics = ends = None
            if has_area(self.scene) or estimated:
                poses = p.chain.frame_poses(q)  # once, for the axial stress and the end floor
                loads, tensions = loads or scene_loads(self.scene)
                if has_area(self.scene):
                    statics = chain_statics(p.statics, poses, loads, tensions)
                if estimated:
                    ends = end_curvatures(p.statics, poses, loads, tensions)
            stresses = flexure_stresses(self.scene, self.models, qs, statics=statics)
            if not estimated:
                return stresses
            errors = estimator.of(est, stresses, ends)
            return {n: replace(st, error_estimate=errors.get(n)) for n, st in stresses.items()}
        raise AttributeError(name)


def solve_models(
    scene: Scene,
    models: Mapping[str, FlexureModel] | None = None,
    *,
    q0: Mapping[str, Any] | None = None,
    settings: SolverSettings | None = None,
    **options: Any,
) -> Result:
    """One solve of ``scene`` with these flexure models (the others from the scene), no
    validity check and no cache: what model selection and the benchmarks call."""
    return Solver(scene, models, make_settings(settings, **options)).solve(q0=q0)


def margin_of(problem: Problem, K: np.ndarray) -> float:
    """``fg_margin`` of the stiffness K (an answer's copy) in a workspace of its own (a Result
    computes its stability margin on first access, whichever solve its solver is in)."""
    work = np.empty(max(int(core.lib.fg_work_size(problem.struct)), 1))
    iwork = np.empty(max(int(core.lib.fg_iwork_size(problem.struct)), 1), dtype=np.intc)
    K = np.ascontiguousarray(K)
    cast = core.ffi.cast
    return float(
        core.lib.fg_margin(
            problem.struct,
            cast("double *", K.ctypes.data),
            cast("double *", work.ctypes.data),
            cast("int *", iwork.ctypes.data),
        )
    )
