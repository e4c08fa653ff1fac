"""One chunk of a study, solved where it is sent: in this process, a worker process or a Dask
worker. Top-level and picklable (spawn-safe); imports neither pandas nor Dask.

A chunk prepares its scene once, and its Solver once per design (a load key changes only the
Solver's loads and tensions). Each case is warm-started from its nearest solved neighbour in the
chunk (``Solver.run(q0=...)``; the core falls back to the full load path when Newton from there
does not land on a stable equilibrium close by):

- the chunk's first case: cold (so a chunk's numbers depend on nothing outside it);
- within a row (the fastest-varying key): the case before it;
- a row's first case: the previous row's first case (one step along the next-slower key),
  else the case before it.

A neighbour is used only when flexgen/warm.py allows it: its answer is a stable equilibrium
whose load path crossed no critical load, and the loads and tensions changed little from it
(``WARM_CHANGE`` per group), and so did each varied design value. Where no neighbour qualifies,
the case solves cold, as ``flexgen.solve`` does. The answer is read from the Solver's
workspace, exactly the numbers ``Solver.solve`` puts in a Result (the same arrays; no Result is
built).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import core
from .estimate import estimate_answer
from .scene import Scene, SceneError, scene_from_dict
from .settings import SolverSettings
from .solver import Solver
from .statics import chain_statics
from .stress import has_area, peak_stress, peak_stresses, safety_factor, section_area
from .validity import calm as validity_calm
from .validity import check as validity_check
from .validity import loads_scene as validity_loads_scene
from .warm import inputs_close, values_close

POINT_FIELDS = ("x", "y", "angle", "major", "minor", "ellipse_angle", "error_estimate")
FLEXURE_FIELDS = ("max_stress", "safety_factor")
CASE_FIELDS = ("converged", "stable", "iterations")
TEXT_FIELDS = ("reason", "warnings", "notes")
# the warnings (notes) of one case in one cell: a message may hold "; " but not a newline
TEXT_SEPARATOR = "\n"

# Prepared Solvers kept per process, by (study, design): the chunks of a load study that land in
# one process prepare its Solver and error estimator (~2 ms) once. A Solver keeps nothing
# between solves but its buffers (docs/architecture.md, "Model, data, algorithm"), so a reused
# one gives the same numbers as a fresh one.
KEEP = 8
_prepared: OrderedDict[tuple, Solver | str] = OrderedDict()
_scenes: OrderedDict[str, Scene] = OrderedDict()


@dataclass(frozen=True)
class Chunk:
    study: str  # a token naming the study (the key of what a process keeps prepared)
    source: dict[str, Any]  # the scene's source mapping (plain dicts and lists: picklable)
    order: list[str] | None  # scene_from_dict's order=
    name: str
    settings: SolverSettings | None
    keys: tuple[str, ...]
    targets: tuple[tuple[str, int, int] | None, ...]
    values: np.ndarray  # cases x keys, in solve order
    first: int  # solve index of the first case (rows start at multiples of row_length)
    row_length: int
    estimate: bool
    stress: bool


def columns(points: list[str], flexures: list[str]) -> int:
    return len(CASE_FIELDS) + len(POINT_FIELDS) * len(points) + len(FLEXURE_FIELDS) * len(flexures)


def run_chunk(
    chunk: Chunk, report: Callable[[int], Any] | None = None
) -> tuple[np.ndarray, list[tuple[str, str, str]]]:
    """(cases x columns floats, texts) for the chunk's cases, in its order. Columns: converged,
    stable, iterations, then POINT_FIELDS per output point, FLEXURE_FIELDS per flexure. Texts:
    per case (reason, warnings, notes), the Result's, each list joined by TEXT_SEPARATOR ("" for
    none). ``report(1)`` after each case, when given (progress of a chunk solved in this
    process)."""
    base = _scenes.get(chunk.study)
    if base is None:
        base = scene_from_dict(chunk.source, order=chunk.order, default_name=chunk.name)
        _keep(_scenes, chunk.study, base)
    points = list(base.output_points())
    flexures = [f.name for f in base.flexures]
    width = columns(points, flexures)
    failed_design = [0.0, 0.0, 0.0] + [math.nan] * (width - 3)
    rows = chunk.values.tolist()  # plain floats: cheaper than NumPy scalars at this size
    out: list[list[float]] = []
    reasons: list[tuple[str, str, str]] = [("", "", "")] * len(rows)
    design_cols = [k for k, t in enumerate(chunk.targets) if t is None]
    load_cols = [(k, t) for k, t in enumerate(chunk.targets) if t is not None]
    solver: Solver | str | None = None
    design: tuple[float, ...] | None = None
    loads = tensions = None
    answers: list[_Answer | None] = [None] * len(rows)  # the answers a warm start may use
    # the cases whose stress columns take the statics (a flexure with an area), per design:
    # filled after the chunk's solves, many answers per vectorised call
    deferred: dict[int, tuple[Solver, list]] = {}
    for c, row in enumerate(rows):
        here = tuple(row[k] for k in design_cols)
        if here != design:
            design = here
            solver = prepared(chunk, base, {chunk.keys[k]: row[k] for k in design_cols})
            if isinstance(solver, Solver):
                loads = solver.problem.loads.copy()
                tensions = solver.problem.tensions.copy()
                slices = list(solver.problem.chain.slices.items())
        if not isinstance(solver, Solver):  # this combination of values is not a valid scene
            out.append(failed_design)
            reasons[c] = (str(solver), "", "")
        else:
            assert loads is not None and tensions is not None
            _set_loads(row, load_cols, loads, tensions)
            inputs = _Inputs(loads.ravel().tolist(), tensions.tolist(), here)
            status = solver.run(loads, tensions, _warm_start(chunk, c, answers, inputs))
            out.append(_record(solver, status, chunk, width, reasons, c, deferred))
            if _reusable(status, solver.workspace.answer):
                q = solver.workspace.q.copy()
                answers[c] = _Answer({name: q[sl] for name, sl in slices}, inputs)
        if report is not None:
            report(1)
    table = np.array(out, dtype=float).reshape(len(rows), width)
    for solver_, cases in deferred.values():
        _fill_stresses(solver_, cases, table)
    return table, reasons


@dataclass(frozen=True)
class _Inputs:
    """What a case solves for: its loads, tensions and varied design values."""

    loads: list[float]  # (fx, fy, moment) per load, flat
    tensions: list[float]
    design: tuple[float, ...]  # the values of the chunk's design keys

    def close_to(self, other: _Inputs) -> bool:
        """Whether an answer to ``other`` may start a solve of these (flexgen/warm.py)."""
        return inputs_close(other.loads, other.tensions, self.loads, self.tensions) and (
            values_close(other.design, self.design)
        )


@dataclass(frozen=True)
class _Answer:
    """A solved case a later case may start from: its q and the inputs it answers."""

    q: dict[str, np.ndarray]
    inputs: _Inputs


def _set_loads(row: list[float], load_cols: list, loads: np.ndarray, tensions: np.ndarray) -> None:
    """The case's values of the load keys into the Solver's loads and tensions."""
    for k, (what, i, j) in load_cols:
        if what == "load":
            loads[i, j] = row[k]
        else:
            tensions[i] = row[k]


def _reusable(status: int, answer: Any) -> bool:
    """Whether a later case may start from this answer: a stable equilibrium whose load path
    crossed no critical load (flexgen/warm.py). A warm answer only ever starts from such an
    answer and follows no load path, so it is one too."""
    return status == core.SOLVED and bool(answer.stable) and (answer.warm or not answer.ncritical)


def prepared(chunk: Chunk, base: Scene, design: dict[str, Any]) -> Solver | str:
    """The Solver of one design (it keeps its error estimator once used), or the
    SceneError's text when the design's values do not make a valid scene."""
    key = (chunk.study, tuple(design.values()))
    solver = _prepared.get(key)
    if solver is None:
        try:
            scene = base.with_values(design) if design else base
            solver = Solver(scene, settings=chunk.settings)
        except SceneError as exc:
            solver = str(exc)
        _keep(_prepared, key, solver)
    return solver


def _keep(cache: OrderedDict, key: Any, value: Any) -> None:
    cache[key] = value
    while len(cache) > KEEP:
        cache.popitem(last=False)


def _warm_start(
    chunk: Chunk, c: int, answers: list[_Answer | None], inputs: _Inputs
) -> dict[str, np.ndarray] | None:
    """The warm start of case ``c`` of the chunk: the first of its neighbours (see the module
    docstring) with a reusable answer to inputs close to its own (flexgen/warm.py); else None,
    a cold solve."""
    if c == 0:
        return None
    candidates = [c - 1]
    if (chunk.first + c) % chunk.row_length == 0 and c >= chunk.row_length:
        candidates.insert(0, c - chunk.row_length)
    for n in candidates:
        answer = answers[n]
        if answer is not None and inputs.close_to(answer.inputs):
            return answer.q
    return None


def _record(
    solver: Solver, status: int, chunk: Chunk, width: int, reasons, c, deferred: dict
) -> list[float]:
    """One case's row from the answer in ``solver.workspace`` (see ``run_chunk``); its stress
    columns NaN and the case in ``deferred`` where they take the statics (``_fill_stresses``)."""
    ws = solver.workspace
    a = ws.answer
    if status != core.SOLVED:
        iterations = a.iterations if status != core.MODEL_ERROR else 0
        reasons[c] = _failure_texts(solver, status)
        return [0.0, 0.0, float(iterations)] + [math.nan] * (width - 3)
    row = [1.0, 1.0 if a.stable else 0.0, float(a.iterations)]
    n = len(solver.problem.outputs)
    poses, ellipses = ws.pose[:n].tolist(), ws.ellipse[:n].tolist()
    est = estimate_answer(solver, status) if chunk.estimate else None
    reasons[c] = ("", *_messages(solver, status, est))
    errors = [max(p, q) for p, q in zip(est.pose, est.compliance)] if est else [math.nan] * n
    for pose, ellipse, error in zip(poses, ellipses, errors):
        row += pose
        row += ellipse
        row.append(error)
    if chunk.stress and has_area(solver.scene):
        p = solver.problem
        case = (c, solver.workspace.q.copy(), p.loads.copy(), p.tensions.copy())
        deferred.setdefault(id(solver), (solver, []))[1].append(case)
        row += [math.nan] * (width - len(row))
    elif chunk.stress and _has_section(solver):
        row += stress_columns(solver, solver.workspace.q)
    else:
        row += [math.nan] * (width - len(row))
    return row


def _messages(solver: Solver, status: int, est: Any) -> tuple[str, str]:
    """The warnings and notes ``flexgen.solve`` gives this solved case (joined by
    TEXT_SEPARATOR), but the safety factors' (the row has the safety factors; the warning of
    one within its estimate of 1 takes the stress estimate, which a study does not compute):
    the Result built and checked as ``flexgen.Solver``'s answers are, only where a warning or
    note may apply (the usual case reads the core's flags and returns at once)."""
    # the checks read the case's own loads where they could differ from the scene's (a
    # moment at a prb flexure, a load level that suggests the wrong units: review)
    scene = validity_loads_scene(solver)
    calm = scene is solver.scene and validity_calm(solver)  # a flag read (once)
    if calm and solver.quiet(est):  # the usual case (about 1 us a case on the finger)
        return "", ""
    result = solver._result(status, est, stress=False)
    if not calm:  # (calm reads the workspace, which _result leaves as it is)
        validity_check(scene, result, solver.models)
    return _joined(result)


def _failure_texts(solver: Solver, status: int) -> tuple[str, str, str]:
    """(reason, warnings, notes) ``flexgen.solve`` gives this failed case, from its Result:
    the notes above all, the switches to a certified kernel on the way to where the load path
    ended, which say the flexures were bent past a kernel's range (review: a failed row's notes
    were always empty)."""
    result = solver._result(status, None, stress=False)
    return (result.reason or "", *_joined(result))


def _joined(result: Any) -> tuple[str, str]:
    """A Result's warnings and notes, each list one cell (TEXT_SEPARATOR between them)."""
    return TEXT_SEPARATOR.join(result.warnings), TEXT_SEPARATOR.join(result.notes)


def _has_section(solver: Solver) -> bool:
    """Whether any flexure's stress can be known (E and thickness given: flexgen/stress.py);
    otherwise the stress columns are NaN without computing the profiles."""
    return any(f.E is not None and f.thickness is not None for f in solver.scene.flexures)


def _fill_stresses(solver: Solver, cases: list, table: np.ndarray) -> None:
    """The stress columns (the last two per flexure) of ``cases`` [(row, q, loads, tensions)]
    of one design: the statics of all of them at once (``Chain.frame_poses_batch``,
    ``StaticsPlan.transmitted``), then each flexure's peak (``stress.peak_stresses``; a
    flexure without an area: its bending peak, ``stress.peak_stress``)."""
    p = solver.problem
    rows = [c for c, _, _, _ in cases]
    Q = np.array([q for _, q, _, _ in cases])
    frames, roots = p.chain.frame_poses_batch(Q)
    forces = p.statics.transmitted(
        frames, np.array([ld for _, _, ld, _ in cases]), np.array([t for _, _, _, t in cases])
    )
    flexures = solver.scene.flexures
    start = table.shape[1] - 2 * len(flexures)
    for j, f in enumerate(flexures):
        model, sl = solver.models[f.name], p.chain.slices[f.name]
        if section_area(f) is not None:
            stress = peak_stresses(f, model, Q[:, sl], forces[:, j], roots[f.name][:, 2])
        else:
            stress = np.array([peak_stress(f, model, q[sl])[0] for q in Q], dtype=float)
        # NaN: no stress known (no E or thickness), so no safety factor (review: it read inf)
        safety = [safety_factor(f, None if math.isnan(x) else float(x))[0] for x in stress]
        table[rows, start + 2 * j] = stress
        table[rows, start + 2 * j + 1] = [math.nan if v is None else v for v in safety]


def stress_columns(solver: Solver, q: Any) -> list[float]:
    """max_stress, safety_factor per flexure (scene order) of the answer ``q`` (the workspace's
    packed coordinates): ``stress.peak_stress``, the maximum ``Result.flexures`` reports,
    without its profiles where no flexure has an area (bending only), with the axial stress
    of the statics at the case's own loads where one has (NaN for None: no section, no
    strength)."""
    values = q.tolist()
    slices = solver.problem.chain.slices
    statics = None
    if has_area(solver.scene):
        p = solver.problem
        statics = chain_statics(p.statics, p.chain.frame_poses(q), p.loads, p.tensions)
    out: list[float] = []
    for f in solver.scene.flexures:
        model = solver.models[f.name]
        stress, safety = peak_stress(f, model, values[slices[f.name]], statics)
        out.append(math.nan if stress is None else stress)
        out.append(math.nan if safety is None else safety)
    return out
