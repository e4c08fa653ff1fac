"""Solve a scene with the compiled chain solver and build the same Result the Python solver does.

``solve_compiled`` gives no Result whenever the C solver finds no equilibrium
(``NO_EQUILIBRIUM``: for now the Python solver re-runs it for its reason; the answer's failure
fields hold it too, see tests/test_compiled.py's c_reason), meets more critical events than the
plan stores, or rejects the problem (``MODEL_ERROR``), a model has no C counterpart, a kernel has
no C source or gcc is missing: the caller then runs the Python solver (and, for the last two,
warns that the compiled solver was unavailable).

The Plan of a (scene, models, solver settings) is kept (the last ``CACHE_SIZE`` of them, keyed
by the scene object and the models' parameters), so solving the same scene again, as a
controller or a benchmark does, costs the C solve and the Result, not the flattening.
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from typing import NamedTuple

import numpy as np

from .. import kernels
from ..result import UNSTABLE, Result, point_result
from . import library as lib
from .plan import build_plan

CACHE_SIZE = 64
_plans: OrderedDict = OrderedDict()
# key -> (scene, plan, chain, system, outputs, info, why unavailable)
_lock = threading.Lock()                 # one solve at a time per process: plans share workspaces


def _signature(scene, models) -> tuple:
    """What of the models a plan depends on (with the scene object and the settings: its key)."""
    sig = []
    for f in scene.flexures:
        m = models[f.name]
        sig.append((type(m), m.n_dof, m.length, m.EI, getattr(m, "kernel", None),
                    getattr(m, "gauss_name", None), getattr(m, "gamma", None),
                    getattr(m, "K_theta", None)))
    return tuple(sig)


def solve_compiled(scene, models, settings: dict, prepare,
                   q0=None) -> tuple[Result | None, str | None]:
    """(the Result of the compiled solve, None) or (None, why not | None): None means run the
    Python solver; "why not" is set when the compiled solver is unavailable for this scene (no
    gcc, a kernel without C source), for the caller to warn of, and None when the C solver
    handed the scene back or a model has no C counterpart (the same answer follows, slower).

    ``prepare()`` gives (chain, system, outputs, info) as the Python solver builds them, called
    only when no Plan is cached; ``settings``: the solver settings (``plan.DEFAULTS``); ``q0``:
    a warm start, {flexure: coordinates} (padded with zeros or truncated to each model's size,
    as ``equilibrium._warm_start`` does)."""
    key = (id(scene), _signature(scene, models), tuple(sorted(settings.items())))
    with _lock:
        entry = _plans.get(key)
        if entry is None or entry[0] is not scene:
            chain, system, outputs, info = prepare()
            unavailable = None
            try:
                plan = build_plan(chain, system.loads, system.tendons, outputs, **settings)
            except (lib.CompileError, kernels.KernelNotFound) as exc:
                plan = None           # no gcc, or a kernel generated for NumPy only
                unavailable = (f"backend 'c' is unavailable ({exc}); solved by the Python "
                               f"solver")
            entry = (scene, plan, chain, system, outputs, info, unavailable)
            _plans[key] = entry
            if len(_plans) > CACHE_SIZE:
                _plans.popitem(last=False)
        _, plan, chain, system, outputs, info, unavailable = entry
        slices = chain.slices
        start = None
        if plan is not None and q0 is not None:
            start = np.zeros(plan.q.size)
            for name, sl in slices.items():
                v = np.asarray(q0.get(name, ()), dtype=float).ravel()[: sl.stop - sl.start]
                start[sl.start:sl.start + v.size] = v
        # for now (the Python solver still exists) a solve without an equilibrium, or with more
        # critical events than the plan stores, is handed back to it for its reason and warnings
        if (plan is None or plan.run(start) != lib.SOLVED
                or plan.answer.ncritical > plan.answer.max_critical):
            return None, unavailable
        res = result_of(plan, scene.name, slices, {k: dict(v) for k, v in info.items()},
                        models)
        # the chain and final stiffness, for the validity check to reuse (as equilibrium._result
        # leaves them): q and K copied, the chain and system those of this plan
        res._final = (chain, system, FinalState(plan.q.copy(), 1.0, plan.K.copy()))
        return res, None


class FinalState(NamedTuple):
    """The part of an equilibrium.State the validity check reads (``validity.stiffness_margin``)."""
    q: np.ndarray
    lam: float
    K: np.ndarray


def result_of(plan, scene_name: str, slices, info: dict, models=None) -> Result:
    """The Result of a solved Plan (what ``equilibrium._result`` builds from a State): the
    critical load factors the C continuation met, with the Python solver's warnings for them
    (``equilibrium.buckling_warning``, ``snap_warning``), then the kernel-switch warnings of
    ``models`` (their ``switched`` flags set from the C solve, as the Python solve sets them)."""
    a = plan.answer
    warnings: list[str] = []
    critical: list[float] = []
    if a.ncritical:
        from ..equilibrium import BUCKLING_SIDES, buckling_warning, snap_warning
        for lam, kind in zip(plan.critical[:a.ncritical].tolist(),
                             plan.critical_kind[:a.ncritical].tolist()):
            critical.append(lam)
            warnings.append(snap_warning(lam) if kind == lib.SNAP_THROUGH
                            else buckling_warning(lam, BUCKLING_SIDES[kind - 1]))
    if models is not None and plan.switched.any():
        from ..equilibrium import kernel_warnings
        for name, flag in zip(plan.flexure_order, plan.switched.tolist()):
            if flag:
                models[name].switched = True
        q = plan.q
        warnings += kernel_warnings(models, {name: q[sl] for name, sl in slices.items()})
    stable = bool(a.stable)
    if not stable:
        warnings.append(UNSTABLE)
    points = {ref: point_result(ref, plan.pose[i], plan.compliance[i].copy(), warnings)
              for i, ref in enumerate(plan.outputs)}
    q = plan.q
    return Result(scene=scene_name, converged=True, stable=stable, iterations=int(a.iterations),
                  model=info, q={name: q[sl].tolist() for name, sl in slices.items()},
                  points=points, warnings=warnings, reason=None, critical_load_factors=critical,
                  load_factor=1.0, energy=float(a.energy), residual=float(a.residual),
                  solver="c")


def prepare(scene, models=None, model_factory=None, **settings):
    """A Plan for repeated compiled solves of ``scene`` (the models as ``flexgen.equilibrium.solve``
    builds them; ``settings`` as ``plan.DEFAULTS``), or None if a model has no C counterpart.
    ``plan.run()`` solves (status
    ``library.SOLVED`` or a hand-back to the Python solver); ``result_of`` gives the Result. This
    is what a controller loop, or the benchmark of the compiled solve alone, calls."""
    from ..equilibrium import prepare_system
    from ..models.registry import build_models
    models = build_models(scene, models, model_factory)
    chain, system, outputs, _ = prepare_system(scene, models)
    return build_plan(chain, system.loads, system.tendons, outputs, **settings)
