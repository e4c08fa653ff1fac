"""How a solve is timed: three layers of the one solver, and the timers.

    api       flexgen.solve(scene)       the public API: the prepared solver of that Scene object
                                         from its cache, the core call, the Result, its error
                                         estimate, the validity check (the same Scene object
                                         every call)
    prepared  solver.solve()             a prepared ``flexgen.Solver``: the core call, the
                                         Result and the core's validity screen (what a
                                         controller loop calls)
    core      core.lib.fg_solve(...)     the bare core call on the solver's problem and workspace

(api) / (core) is what the Python API costs on top of the computation; (prepared) - (core) is
the overhead of building the Result. ``with_model`` gives a scene every flexure of which uses one
model, so that ``flexgen.solve`` of the same Scene object hits the cache (``models=`` would
bypass it).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from flexgen.scene import Scene


def with_model(
    scene: Scene,
    kind: str,
    modes: int | None = None,
    elements: int | None = None,
    kernel: str | None = None,
) -> Scene:
    """``scene`` with every flexure's (and the scene's) model spec set to ``kind`` (and the
    modes, elements and kernel given) and no tolerance."""
    changes: dict[str, Any] = {"kind": kind, "tolerance": None}
    if modes is not None:
        changes["modes"] = modes
    if elements is not None:
        changes["elements"] = elements
    if kernel is not None:
        changes["kernel"] = kernel
    flexures = tuple(replace(f, model=replace(f.model, **changes)) for f in scene.flexures)
    return replace(scene, model=replace(scene.model, **changes), flexures=flexures)


def core_call(solver) -> Callable[[], int]:
    """The bare core call of a prepared ``Solver`` (its problem as the last ``solve`` left it:
    the scene's loads after ``solver.solve()``); returns the core's status."""
    from flexgen import core

    fg_solve = core.lib.fg_solve
    p, ws = solver.problem.struct, solver.workspace
    work, iwork, answer = ws.work_ptr, ws.iwork_ptr, ws.answer

    def call() -> int:
        return fg_solve(p, work, iwork, answer)

    return call


def evaluations(solver) -> int | None:
    """Kernel evaluations of the solver's last solve (``fg_answer.evaluations``), or None when
    this core does not count them."""
    answer = solver.workspace.answer
    if not hasattr(answer, "evaluations"):
        return None
    return int(answer.evaluations)


def time_fast(
    fn: Callable[[], object], rounds: int = 7, batch_s: float = 2e-3, budget_s: float = 2.0
) -> float:
    """Median seconds per call of a fast ``fn`` over ``rounds`` batches of about ``batch_s``
    (after two untimed calls; fewer rounds once ``budget_s`` is spent)."""
    fn()
    t0 = time.perf_counter()
    fn()
    one = time.perf_counter() - t0
    k = max(1, int(batch_s / max(one, 1e-7)))
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(k):
            fn()
        times.append((time.perf_counter() - t0) / k)
        if sum(times) * k > budget_s:
            break
    return float(np.median(times))


def time_interleaved(
    fns: Sequence[Callable[[], object]],
    rounds: int = 7,
    batch_s: float = 2e-3,
    budget_s: float = 2.0,
) -> list[float]:
    """Median seconds per call of each of ``fns``, timed in alternating batches of about
    ``batch_s`` each (so that a drift of the machine's speed hits all of them alike; their
    differences, e.g. prepared - core, are then meaningful): ``rounds`` rounds, fewer (but at
    least 3) once ``budget_s`` is spent."""
    ks = []
    for fn in fns:
        fn()
        t0 = time.perf_counter()
        fn()
        ks.append(max(1, int(batch_s / max(time.perf_counter() - t0, 1e-7))))
    times: list[list[float]] = [[] for _ in fns]
    t_end = time.perf_counter() + budget_s
    for r in range(max(1, rounds)):
        for fn, k, ts in zip(fns, ks, times):
            t0 = time.perf_counter()
            for _ in range(k):
                fn()
            ts.append((time.perf_counter() - t0) / k)
        if time.perf_counter() > t_end and r + 1 >= min(3, rounds):
            break
    return [float(np.median(ts)) for ts in times]


def time_call(fn: Callable[[], object], repeats: int, budget_s: float = 2.0) -> float:
    """Median seconds of ``repeats`` single calls (fewer once ``budget_s`` is spent)."""
    times = []
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
        if sum(times) > budget_s:
            break
    return float(np.median(times))
