"""The exact elastica solver's answer as a Result, so ``kind = "exact"`` answers like any model.

``models.exact.solve_exact`` solves the whole scene by shooting (it is not a per-flexure chain
model), so "exact" applies to every flexure of a scene at once. The Result it becomes has:

- ``model``: ``{flexure: {"kind": "exact"}}``;
- ``q``: each flexure's root loads ``[Fx, Fy, M0]`` (the force it transmits, world frame, and its
  root moment; physical units), the exact solver's unknowns;
- ``points``: pose and 2x2 compliance of the output points (``compliance3`` has the 2x2 block and
  NaN in the angle row and column: the exact solver gives position compliance only);
- ``critical_load_factors``: the bifurcation or limit point it crossed, if any;
- ``flexures``: curvature, strain and stress along each flexure from the elastica's own curvature
  (``models.exact.ElasticaProfile``), computed at once (the exact solve costs far more), with
  the safety-factor warnings;
- ``stiffness``: None (the shooting unknowns are root loads, not coordinates with an energy);
- near a critical load (``SceneSolution.margin`` below ``validity.NEAR_SINGULAR``), a message
  with the margin and the compliance's own error (``COMPLIANCE_NOISE`` / margin): a note while
  that error is below ``models.exact.COMPLIANCE_RESOLVED``, a warning beyond it (there neither
  the compliance nor the stability is resolved: at a critical load itself they are a coin
  toss).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .result import PointResult, Result, ellipse
from .scene import BASE, Scene
from .scene_checks import scene_notes, scene_warnings
from .stress import FlexureStress, flexure_stresses, safety_warnings
from .units import result_units
from .validity import NEAR_SINGULAR, strain_warnings


def root_angle(scene: Scene, sol, name: str) -> float:
    """The world angle of a flexure's root frame in an exact answer: its parent's frame (the
    base, a flexure's tip, a link's = its flexure's tip) turned by its ``at`` angle."""
    f = scene.flexure(name)
    parent = f.parent
    if parent != BASE and scene.body_kind(parent) == "link":
        parent = scene.link(parent).parent
    base = 0.0 if parent == BASE else float(sol.tip_frames[parent][2])
    return base + float(f.at[2])


def exact_stresses(scene: Scene, sol) -> dict[str, FlexureStress]:
    """Every flexure's profiles from the elastica's curvature at the exact answer."""
    from .models.exact import ElasticaProfile

    profiles = {
        f.name: ElasticaProfile(f.length, f.EI, root_angle(scene, sol, f.name))
        for f in scene.flexures
    }
    # the force each flexure transmits is among the exact solver's unknowns (its root loads)
    forces = {name: np.asarray(loads[:2], dtype=float) for name, loads in sol.root_loads.items()}
    angles = {name: profile.root_angle for name, profile in profiles.items()}
    return flexure_stresses(scene, profiles, sol.root_loads, statics=(forces, angles))


def near_critical(sol, points: list[str]) -> tuple[str | None, bool]:
    """(message, is it a warning) for an answer near a critical load, (None, False) otherwise."""
    from .models.exact import COMPLIANCE_NOISE, COMPLIANCE_RESOLVED

    margin = float(sol.margin)
    if not margin < NEAR_SINGULAR:
        return None, False
    error = COMPLIANCE_NOISE / max(margin, 1e-300)
    where = ", ".join(repr(p) for p in points) or "the output points"
    head = (
        f"near a critical load: the shooting Jacobian is {margin:.2g} from singular (1 unloaded; "
    )
    if error > COMPLIANCE_RESOLVED:
        # the sign of det J (stability) is noise once the margin is within the Jacobian's error
        unresolved = " and whether it is stable is not resolved" if error > 0.1 else ""
        return (
            head + f"the limit is {NEAR_SINGULAR:g}), so the compliance at {where} may be off "
            f"by {error:.2g} relative (the solver's error, amplified by 1/margin){unresolved}",
            True,
        )
    return (
        head + f"the limit is {NEAR_SINGULAR:g}): the compliance at {where} is sensitive to "
        f"any imperfection; the solver's own error on it is about {error:.2g} relative",
        False,
    )


def to_result(scene: Scene, sol) -> Result:
    """Convert a ``models.exact.SceneSolution`` of ``scene`` into a Result."""
    info = {f.name: {"kind": "exact"} for f in scene.flexures}
    # a bifurcation crossed onto the stable branch is a note (a fact of the path); every other
    # message of the elastica solver (a stall, a loss of stability) is a warning
    notes = [w for w in sol.warnings if "followed the stable branch" in w]
    notes += list(sol.notes) + scene_notes(scene)
    warnings = [w for w in sol.warnings if w not in notes] + scene_warnings(scene)
    critical = [] if sol.critical_load_factor is None else [float(sol.critical_load_factor)]
    if not sol.converged:
        # the SceneSolution holds the equilibrium at the last converged load factor; the Result
        # gives no pose or q, so the warning that offers that partial result is not its own
        from .models.exact import PARTIAL_LOAD  # (scipy: imported by the exact solve anyway)

        warnings = [w for w in warnings if w != PARTIAL_LOAD]
        reason = f"exact solver: no equilibrium found beyond load factor {sol.load_factor:.6g}" + (
            f" ({(warnings + notes)[0]})" if warnings or notes else ""
        )
        return Result(
            scene=scene.name,
            solver="exact",
            units=result_units(scene),
            converged=False,
            stable=False,
            iterations=int(sol.iterations),
            model=info,
            q={},
            points={},
            warnings=warnings,
            notes=notes,
            reason=reason,
            critical_load_factors=critical,
            load_factor=float(sol.load_factor),
        )
    points = {}
    for ref, pose in sol.poses.items():
        C2 = np.asarray(sol.compliance[ref], dtype=float)
        C2 = 0.5 * (C2 + C2.T)
        C3 = np.full((3, 3), math.nan)
        C3[:2, :2] = C2
        points[ref] = PointResult(
            pose=[float(x) for x in pose],
            compliance=C2.tolist(),
            ellipse=ellipse(C2),
            compliance3=C3.tolist(),
        )
    if not sol.stable and not any(w.startswith(UNSTABLE_UNSEEN) for w in warnings):
        warnings.append(
            "the equilibrium is unstable (exact solver: the shooting Jacobian's "
            "determinant changed sign along the load path)"
        )
    # in scene order, as the chain models' q (the solver's own order is its traversal's)
    q = {
        f.name: [float(x) for x in sol.root_loads[f.name]]
        for f in scene.flexures
        if f.name in sol.root_loads
    }
    message, is_warning = near_critical(sol, list(points))
    if message is not None:
        (warnings if is_warning else notes).append(message)
    flexures = exact_stresses(scene, sol)
    # the chain models' strain check (validity.assess), on the elastica's own curvature
    warnings.extend(strain_warnings(scene, {n: st.max_curvature for n, st in flexures.items()}))
    warnings.extend(safety_warnings(scene, flexures))
    return Result(
        scene=scene.name,
        solver="exact",
        units=result_units(scene),
        converged=True,
        stable=bool(sol.stable),
        iterations=int(sol.iterations),
        model=info,
        q=q,
        points=points,
        warnings=warnings,
        notes=notes,
        reason=None,
        critical_load_factors=critical,
        load_factor=float(sol.load_factor),
        flexures=flexures,
    )


def solve(scene: Scene):
    """Solve ``scene`` with the exact elastica solver: ``(Result, SceneSolution or None)``.
    A solver failure (integration or shooting breaking down) is a Result with converged False."""
    from .models.exact import solve_exact

    try:
        sol = solve_exact(scene)
        sol = _checked(scene, sol)
    except (RuntimeError, ArithmeticError, np.linalg.LinAlgError) as exc:
        info = {f.name: {"kind": "exact"} for f in scene.flexures}
        return Result(
            scene=scene.name,
            solver="exact",
            units=result_units(scene),
            converged=False,
            stable=False,
            iterations=0,
            model=info,
            q={},
            points={},
            reason=f"exact solver failed: {exc}",
            load_factor=0.0,
        ), None
    return to_result(scene, sol), sol


# The cross-check of a stable exact answer (``_checked``): a chain model that claims at most
# CHECK_ESTIMATE and differs from the exact answer by more than CHECK_FACTOR times its estimate
# (and CHECK_FLOOR) means the exact continuation missed something; its rerun takes steps
# CHECK_STEP long (the default 0.25 / 5).
CHECK_MODES = 6
CHECK_ESTIMATE = 1e-3
CHECK_FACTOR = 100.0
CHECK_FLOOR = 1e-6
CHECK_STEP = 0.05
UNSTABLE_UNSEEN = "unstable: a compliance of this equilibrium has a negative eigenvalue"


def _difference(scene: Scene, sol, chain: Result) -> float:
    """The largest pose difference of the output points (position relative to L_p, angle), as
    the selection measures it (``select.error_components``, its pose components)."""
    from .select import error_components, length_scales, outputs_of, outputs_of_exact

    ref = outputs_of_exact(sol)
    got = outputs_of(chain)
    assert ref is not None and got is not None  # both converged (the caller)
    comps = error_components(got, ref, length_scales(scene, list(ref))).reshape(-1, 3)
    return float(comps[:, :2].max()) if comps.size else 0.0


def _indefinite(sol) -> bool:
    """Whether an output point's compliance has a clearly negative eigenvalue."""
    for C in sol.compliance.values():
        C = np.asarray(C, dtype=float)
        if not np.all(np.isfinite(C)):
            continue
        ev = np.linalg.eigvalsh(0.5 * (C + C.T))
        if ev[0] < -1e-9 * max(abs(ev[-1]), abs(ev[0])):
            return True
    return False


def _checked(scene: Scene, sol):
    """``sol``, or the exact solve rerun with shorter load steps where a chain model (scm6)
    that claims a small error finds another equilibrium: the exact solver judges stability by
    the sign of its shooting Jacobian's determinant, which two critical loads crossed in one
    load step leave unchanged, so it may keep an unstable straight state as stable (review:
    two columns, each past its Euler load within one step, reported straight and stable). If
    the rerun still differs, the answer says so."""
    if not (sol.converged and sol.stable and sol.poses):
        return sol
    from .models.exact import solve_exact

    if _indefinite(sol):
        # a stable equilibrium's compliance is positive semidefinite: this one is not stable
        # (two columns buckling at the same load cross it together: the determinant's sign
        # never changes, whatever the step). Shorter steps, else the answer says so.
        again = solve_exact(scene, max_step=CHECK_STEP)
        if again.converged and again.stable and not _indefinite(again):
            return again
        sol.stable = False
        sol.warnings.append(
            f"{UNSTABLE_UNSEEN}, so the load passed critical loads the exact solver's stability "
            "check (the sign of its Jacobian's determinant) cannot see, e.g. two equal critical "
            "loads at once; the stable branch was not followed"
        )
        return sol
    from dataclasses import replace

    from .solver import Solver  # (not flexgen.api, which imports this module)

    scm: dict[str, Any] = {"kind": "scm", "modes": CHECK_MODES, "tolerance": None}
    flexures = tuple(replace(f, model=replace(f.model, **scm)) for f in scene.flexures)
    try:
        chain = Solver(replace(scene, model=replace(scene.model, **scm), flexures=flexures)).solve(
            estimate=True
        )
    except (ValueError, RuntimeError, ArithmeticError):
        return sol
    est = chain.error_estimate
    if not (chain.converged and chain.stable and est is not None and est <= CHECK_ESTIMATE):
        return sol
    limit = max(CHECK_FACTOR * est, CHECK_FLOOR)
    if _difference(scene, sol, chain) <= limit:
        return sol
    again = solve_exact(scene, max_step=CHECK_STEP)
    if again.converged and _difference(scene, again, chain) <= limit:
        return again
    sol.warnings.append(
        f"the exact solver's answer differs from scm{CHECK_MODES}'s (estimated at {est:.2g}) by "
        f"{_difference(scene, sol, chain):.2g}, also with load steps of {CHECK_STEP}: it may "
        f"have missed a critical load; check it with fem or more modes"
    )
    return sol
