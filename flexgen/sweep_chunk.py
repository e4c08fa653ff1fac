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

Only a converged, stable neighbour is used; otherwise the case solves cold. The answer is read
from the Solver's workspace, exactly the numbers ``Solver.solve`` puts in a Result (the same
arrays; no Result is built).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import core
from .estimate import estimate_answer
from .reasons import failure_reason
from .scene import Scene, SceneError, scene_from_dict
from .settings import SolverSettings
from .solver import Solver
from .stress import peak_stress

POINT_FIELDS = ("x", "y", "angle", "major", "minor", "ellipse_angle", "error_estimate")
FLEXURE_FIELDS = ("max_stress", "safety_factor")
CASE_FIELDS = ("converged", "stable", "iterations")

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


def run_chunk(chunk: Chunk) -> tuple[np.ndarray, list[str]]:
    """(cases x columns floats, reasons) for the chunk's cases, in its order. Columns: converged,
    stable, iterations, then POINT_FIELDS per output point, FLEXURE_FIELDS per flexure."""
    base = _scenes.get(chunk.study)
    if base is None:
        base = scene_from_dict(chunk.source, order=chunk.order, default_name=chunk.name)
        _keep(_scenes, chunk.study, base)
    points = list(base.outputs)
    flexures = [f.name for f in base.flexures]
    width = columns(points, flexures)
    failed_design = [0.0, 0.0, 0.0] + [math.nan] * (width - 3)
    rows = chunk.values.tolist()  # plain floats: cheaper than NumPy scalars at this size
    out: list[list[float]] = []
    reasons = [""] * len(rows)
    design_cols = [k for k, t in enumerate(chunk.targets) if t is None]
    load_cols = [(k, t) for k, t in enumerate(chunk.targets) if t is not None]
    solver: Solver | str | None = None
    design: tuple[float, ...] | None = None
    loads = tensions = None
    answers: list[dict[str, np.ndarray] | None] = [None] * len(rows)  # q of each stable answer
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
            reasons[c] = str(solver)
            continue
        assert loads is not None and tensions is not None
        for k, (what, i, j) in load_cols:
            if what == "load":
                loads[i, j] = row[k]
            else:
                tensions[i] = row[k]
        status = solver.run(loads, tensions, _neighbour(chunk, c, answers))
        out.append(_record(solver, status, chunk, width, reasons, c))
        ws = solver.workspace
        if status == core.SOLVED and ws.answer.stable:
            q = ws.q.copy()
            answers[c] = {name: q[sl] for name, sl in slices}
    return np.array(out, dtype=float).reshape(len(rows), width), reasons


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


def _neighbour(chunk: Chunk, c: int, answers: list) -> dict[str, np.ndarray] | None:
    """The warm start of case ``c`` of the chunk (see the module docstring)."""
    if c == 0:
        return None
    if (chunk.first + c) % chunk.row_length == 0 and c >= chunk.row_length:
        above = answers[c - chunk.row_length]
        if above is not None:
            return above
    return answers[c - 1]


def _record(solver: Solver, status: int, chunk: Chunk, width: int, reasons, c) -> list[float]:
    """One case's row from the answer in ``solver.workspace`` (see ``run_chunk``)."""
    ws = solver.workspace
    a = ws.answer
    if status != core.SOLVED:
        iterations = a.iterations if status != core.MODEL_ERROR else 0
        reasons[c] = failure_reason(solver, status)
        return [0.0, 0.0, float(iterations)] + [math.nan] * (width - 3)
    row = [1.0, 1.0 if a.stable else 0.0, float(a.iterations)]
    n = len(solver.problem.outputs)
    poses, ellipses = ws.pose[:n].tolist(), ws.ellipse[:n].tolist()
    est = estimate_answer(solver, status, Solver) if chunk.estimate else None
    errors = [max(p, q) for p, q in zip(est.pose, est.compliance)] if est else [math.nan] * n
    for pose, ellipse, error in zip(poses, ellipses, errors):
        row += pose
        row += ellipse
        row.append(error)
    if chunk.stress and _has_section(solver):
        row += stress_columns(solver, solver.workspace.q)
    else:
        row += [math.nan] * (width - len(row))
    return row


def _has_section(solver: Solver) -> bool:
    """Whether any flexure's stress can be known (E and thickness given: flexgen/stress.py);
    otherwise the stress columns are NaN without computing the profiles."""
    return any(f.E is not None and f.thickness is not None for f in solver.scene.flexures)


def stress_columns(solver: Solver, q: Any) -> list[float]:
    """max_stress, safety_factor per flexure (scene order) of the answer ``q`` (the workspace's
    packed coordinates): ``stress.peak_stress``, the maximum ``Result.flexures`` reports,
    without its profiles (NaN for None: no section, no strength)."""
    values = q.tolist()
    slices = solver.problem.chain.slices
    out: list[float] = []
    for f in solver.scene.flexures:
        model = solver.models[f.name]
        stress, safety = peak_stress(f, model, values[slices[f.name]])
        out.append(math.nan if stress is None else stress)
        out.append(math.nan if safety is None else safety)
    return out
