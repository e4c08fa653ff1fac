"""Solve a scene with the compiled chain solver and build the same Result the Python solver does.

``solve_compiled`` returns None whenever the C solver hands the scene back (``FALLBACK``: a case
for the load continuation; ``MODEL_ERROR``), or a model has no C counterpart: the caller then runs
the Python solver, which reports such cases in full.
"""
from __future__ import annotations

import numpy as np

from ..result import PointResult, Result, ellipse
from . import library as lib
from .plan import build_plan


def solve_compiled(scene, chain, system, outputs: list[str], info: dict, *, tol: float,
                   max_iterations: int, max_dq: float) -> Result | None:
    try:
        plan = build_plan(chain, system.loads, system.tendons, outputs, tol, max_dq,
                          max_iterations)
    except lib.CompileError:
        return None
    if plan is None or plan.run() != lib.SOLVED:
        return None
    return result_of(plan, scene.name, chain, info)


def result_of(plan, scene_name: str, chain, info: dict) -> Result:
    """The Result of a solved Plan (what ``equilibrium._result`` builds from a State)."""
    a = plan.answer
    warnings: list[str] = []
    stable = bool(a.stable)
    if not stable:
        warnings.append("the equilibrium is unstable: the stiffness matrix is not positive definite")
    points = {}
    for i, ref in enumerate(plan.outputs):
        C3 = plan.compliance[i]
        if not np.all(np.isfinite(C3)):
            warnings.append(f"compliance of {ref!r} is undefined: the stiffness matrix is singular")
        C2 = C3[:2, :2]
        points[ref] = PointResult(pose=plan.pose[i].tolist(), compliance=C2.tolist(),
                                  ellipse=ellipse(C2), compliance3=C3.tolist())
    q = {name: plan.q[sl].tolist() for name, sl in chain.slices.items()}
    return Result(scene=scene_name, converged=True, stable=stable, iterations=int(a.iterations),
                  model=info, q=q, points=points, warnings=warnings, reason=None,
                  critical_load_factors=[], load_factor=1.0, energy=float(a.energy),
                  residual=float(a.residual))
