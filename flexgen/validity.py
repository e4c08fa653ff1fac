"""When a model's answer is past its validity: the warnings ``flexgen.solve`` adds to it.

``flexgen.api.solve_scene`` (the path of ``flexgen solve`` and ``flexgen.solve``) calls ``check``
on every converged chain-model result: it appends the validity warnings below. What an answer
claims is its own error estimate (``flexgen.estimate``: per output point, its difference to a
richer model); these warnings say where that estimate, or the model itself, cannot be trusted.
``flexgen_tools.stability`` assesses its sweep with the same ``assess`` and holds each answer to
its estimate against the exact elastica.

The warnings (``assess``, ``check``)
-----------------------------------
* prb past 64 deg of pin rotation (Howell's validity limit), or used outside its one-flexure
  tip-force case (no end moment, link lever arm or tendon);
* a polynomial scm kernel past its range (the answer is an interpolant outside its interval);
  with kernel "auto" the solver switches to the Gauss kernel and notes it, so nothing is
  added here;
* a Gauss kernel past its certified range (|phi| > 180 deg);
* any model bent past 180 deg (``BEND_LIMIT``: the Gauss kernels, which the estimate's richer
  models use, are certified to there);
* the stiffness near singular: the margin to a critical load (the smallest generalized eigenvalue
  of the stiffness K at the equilibrium against the elastic Hessian, 1 - P/P_cr on an axial
  load) below 5 % (near a critical load the compliance error is amplified by 1/margin);
* a flexure with a thickness whose outer-fibre bending strain passes 3 % (``STRAIN_LIMIT``),
  where no flexure material is linear (the exact solver's answers get it too);
* (``check`` only) a flexure bent past 90 deg at a load level above 1e3, which no elastic
  flexure survives: nearly always a scene in the wrong units (``units_warning``; a failed solve
  at such a load says so in its reason: ``units_reason``, added by ``flexgen.api``).

``exact`` is the reference and is not assessed (but for the strain); a result that did not
converge already says so.

``calm`` is ``flexgen.solve``'s shortcut for a cached prepared solver's answers: from the core's
bends and kernels and the margin, and each strained flexure's cheap curvature bound
(``curvature_bound``: sum |q_n| / L for smooth curvature), whether ``check`` could add anything
at all (the usual answer earns no warning); when it might, ``check`` decides.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from flexgen.scene import Scene, load_levels, with_loads

PRB_LIMIT = math.radians(64.0)
NEAR_SINGULAR = 0.05
# the largest bend of any flexure the estimate is trusted at (the Gauss kernels' certified range)
BEND_LIMIT = math.pi


# -- what a result claims ----------------------------------------------------------------------


@dataclass
class Claim:
    """The validity assessment of an answer (``assess``)."""

    beta: float  # largest bend (rad)
    margin: float  # margin to a critical load (stiffness_margin)
    out_of_range: bool  # a kernel past its valid (poly) or certified (gauss) range
    switched: bool  # an auto kernel moved from poly to gauss
    warnings: list = field(default_factory=list)  # validity warnings (added to solve's)


# A scene in the wrong units: above this load level a flexure bent past UNITS_BEND is far past
# any elastic material. The elastica of a tip force gives the root curvature
# kappa L = 2 sqrt(lambda) sin(bend / 2) (its first integral, the tip aligned with the force):
# at least 45 at lambda = 1e3 and 90 deg, a strain kappa t / 2 of at least 22 t / L, past the
# ~2 % elastic limit of flexure materials unless L / t > 1100. (An axial load may exceed it with
# little bend: that is not flagged.) Such a scene is nearly always a stiffness or a length in the
# wrong unit (E = 200 for 200 GPa in SI makes lambda 1e9 times too large).
UNITS_LOAD_LEVEL = 1e3
UNITS_BEND = math.pi / 2

# Past this outer-fibre bending strain (kappa thickness / 2) no flexure material is linear, which
# every model here assumes (M = EI kappa): metals yield below 1.5 % (spring steel about 0.7 %,
# titanium about 1 %), superelastic nitinol leaves its linear branch near 1 %, and polymers'
# stress-strain curves bend within a few percent. A warning on any answer whose flexure has a
# thickness (review: 5000 N on the steel finger strained it 7.7 %, with no warning but the
# safety factors, which a scene without strengths does not have).
STRAIN_LIMIT = 0.03


def strain_warnings(scene: Scene, max_curvature: Mapping[str, float]) -> list[str]:
    """The warning of every flexure with a thickness whose outer-fibre bending strain, its
    largest |kappa| (``max_curvature``, {flexure: 1/length}; a flexure missing is not checked)
    times thickness / 2, passes STRAIN_LIMIT: the chain models' (``assess``) and the exact
    solver's (flexgen/exact_result.py)."""
    out = []
    for f in scene.flexures:
        if f.thickness is not None and f.name in max_curvature:
            strain = max_curvature[f.name] * 0.5 * f.thickness
            if strain > STRAIN_LIMIT:
                out.append(_strain_warning(f.name, strain))
    return out


def _strain_warning(name: str, strain: float) -> str:
    """The warning of a flexure strained past STRAIN_LIMIT."""
    head, tail = strain_warning_parts(name)
    return f"{head}{strain:.3g} ({100 * strain:.2g} %){tail}"


def strain_warning_parts(name: str) -> tuple[str, str]:
    """The strain warning's text before and after its numbers (the emitted controller's
    example prints them around its own, "%.3g (%.2g %%)")."""
    return (
        f"flexure {name!r}: outer-fibre bending strain ",
        f" is past the {100 * STRAIN_LIMIT:g} % beyond which no flexure material is linear, as "
        "every model here assumes: the answer does not hold for a real strip (check the load "
        "and the units)",
    )


def units_hint(scene: Scene) -> str:
    """The advice that ends the units warning and a failed solve's reason at such a load."""
    read = (
        f"in {scene.units.length} and {scene.units.force}"
        if scene.units is not None
        else "as one consistent set"
    )
    return (
        "check the units (a stiffness or length given in the wrong unit, e.g. E = 200 meant as "
        f"200 GPa; flexgen reads plain numbers {read})"
    )


def units_warning(scene: Scene, bends: Mapping[str, float]) -> str | None:
    """The warning for a flexure bent past UNITS_BEND at a load level above UNITS_LOAD_LEVEL
    (the one bent most, if several), else None."""
    if not any(b > UNITS_BEND for b in bends.values()):  # the usual case: no load level needed
        return None
    levels = scene.load_levels()
    suspects = [
        n for n, b in bends.items() if b > UNITS_BEND and levels.get(n, 0.0) > UNITS_LOAD_LEVEL
    ]
    if not suspects:
        return None
    name = max(suspects, key=lambda n: bends[n])
    return (
        f"flexure {name!r}: load level {levels[name]:.3g} (force x L^2/EI + moment x L/EI) and a bend of "
        f"{_deg(bends[name])}, far past what an elastic flexure survives: {units_hint(scene)}"
    )


def units_reason(scene: Scene) -> str | None:
    """What a failed solve's reason adds when a load level is above UNITS_LOAD_LEVEL, else None."""
    level = max(scene.load_levels().values(), default=0.0)
    if level <= UNITS_LOAD_LEVEL:
        return None
    return f"load level {level:.3g} (force x L^2/EI + moment x L/EI): {units_hint(scene)}"


_SCENE_CONSTANTS: dict[int, tuple] = {}


def _scene_constants(scene: Scene) -> str | None:
    """_prb_case_problem of a scene, kept for the last scenes checked (a Scene is immutable;
    the entry holds the scene, so its id is not reused while kept)."""
    got = _SCENE_CONSTANTS.get(id(scene))
    if got is None or got[0] is not scene:
        if len(_SCENE_CONSTANTS) >= 64:
            _SCENE_CONSTANTS.clear()
        got = _SCENE_CONSTANTS[id(scene)] = (scene, _prb_case_problem(scene))
    return got[1]


def _prb_case_problem(scene: Scene) -> str | None:
    """What in this answer's scene (its loads and tensions) leaves the PRB fitted case, a force
    at the tip of a single flexure, or None; in this order, which the emitted controller keeps
    (it checks the values per call): a moment, several flexures, a tendon that pulls, a force
    off the tip. A load at a link point on the tip is at the tip; a tendon without tension and
    a zero force are no part of it (review: a tension sweep's first row, at 0, claimed no
    accuracy)."""
    for ld in scene.loads:
        if ld.moment != 0.0:
            return f"a moment at {ld.point!r}"
    several = prb_several_flexures(scene)
    if several is not None:
        return several
    if any(t.tension != 0.0 for t in scene.tendons):
        return PRB_TENDON
    for i in prb_off_tip_loads(scene):
        if scene.loads[i].force != (0.0, 0.0):
            return prb_off_tip(scene.loads[i].point)
    return None


# what leaves the prb fitted case, as the warnings say it (the controller's too)
PRB_TENDON = "a tendon"


def prb_off_tip(point: str) -> str:
    return f"a load at {point!r}, not at the tip"


def prb_several_flexures(scene: Scene) -> str | None:
    """What leaves the prb fitted case in every answer of the scene: several flexures."""
    return f"{len(scene.flexures)} flexures" if len(scene.flexures) != 1 else None


def prb_off_tip_loads(scene: Scene) -> list[int]:
    """The indices of a one-flexure scene's loads that are not at its tip (whose force, where
    not zero, leaves the prb fitted case: the emitted controller checks them per call)."""
    return [i for i, ld in enumerate(scene.loads) if not _at_tip(scene, ld.point)]


def _at_tip(scene: Scene, ref: str) -> bool:
    """Whether the point ``ref`` is the one flexure's tip: its own, or a link's point at the
    origin of the link's frame, which is the tip frame of the flexure it is on."""
    flexure = scene.flexures[0].name
    if ref == f"{flexure}.tip":
        return True
    body, xy = scene.resolve_point(ref)
    return (
        scene.body_kind(body) == "link"
        and scene.link(body).parent == flexure
        and tuple(xy) == (0.0, 0.0)
    )


def model_label(model) -> str:
    """The label of a flexure model in warnings: its name (``registry.label``: "cc", "prb",
    "fem16", "scm3") and, with more than one mode, its kernel choice ("scm3 auto")."""
    from flexgen.models.registry import label, model_info

    info = model_info(model)
    name = label(info)
    return f"{name} {model.kernel}" if info["kind"] == "scm" and info["modes"] > 1 else name


def _deg(x: float) -> str:
    return f"{math.degrees(x):.0f} deg"


def _names(names) -> str:
    names = list(names)
    return (
        f"flexure {names[0]!r}"
        if len(names) == 1
        else "flexures " + ", ".join(repr(n) for n in names)
    )


def stiffness_margin(scene: Scene, models: Mapping, q: Mapping, K=None) -> float:
    """How far the equilibrium q (full load) is from a critical load: the smallest generalized
    eigenvalue of (K, hess U), i.e. the smallest eigenvalue of L^-1 K L^-T with hess U = L L^T.
    1 unloaded, 1 - P/P_cr on an axial load below buckling, 0 at a critical load, < 0 unstable
    (nan if hess U is not positive definite). Independent of the model's coordinates.

    ``K``: the stiffness at q (``Result.stiffness``, coordinates packed in the scene's flexure
    order); None: solved again by the core, warm-started at q. (The core reports the same
    number for its answers: ``Result.stability_margin``.)"""
    if K is None:
        from flexgen.solver import Solver

        K = Solver(scene, models).solve(q0=q).stiffness
        if K is None:
            return math.nan
    KU = np.zeros_like(K)
    start = 0
    for f in scene.flexures:
        m = models[f.name]
        k = int(m.n_dof)
        KU[start : start + k, start : start + k] = m.energy_hessian(np.asarray(q[f.name], float))
        start += k
    try:
        Li = np.linalg.inv(np.linalg.cholesky(0.5 * (KU + KU.T)))
    except np.linalg.LinAlgError:
        return math.nan
    return float(np.linalg.eigvalsh(Li @ K @ Li.T)[0])


@dataclass(frozen=True)
class _Context:
    """What ``assess`` needs of a scene and its models that does not change between answers
    (kept per models mapping: a prepared solver's answers reuse it)."""

    labels: dict[str, str]
    scm: tuple[str, ...]  # smooth curvature flexures
    prb: tuple[str, ...]
    prb_problem: str | None
    # whether the scene's own loads are above UNITS_LOAD_LEVEL (loads_scene)
    level_high: bool = False
    # (flexure, thickness / 2) of every flexure with a thickness: its strain is checked
    strained: tuple[tuple[str, float], ...] = ()


_CONTEXTS: dict[tuple, tuple] = {}


def _context(scene: Scene, models: Mapping, label: str | None) -> _Context:
    # the entry holds scene and models, so neither id is reused while it is kept
    key = (id(scene), id(models), label)
    got = _CONTEXTS.get(key)
    if got is not None and got[0] is scene and got[1] is models:
        return got[2]
    labels = {name: label or model_label(m) for name, m in models.items()}
    ctx = _Context(
        labels,
        tuple(n for n, m in models.items() if getattr(m, "kind", "") == "scm"),
        tuple(n for n, m in models.items() if getattr(m, "kind", "") == "prb"),
        _scene_constants(scene),
        max(scene.load_levels().values(), default=0.0) > UNITS_LOAD_LEVEL,
        tuple((f.name, 0.5 * f.thickness) for f in scene.flexures if f.thickness is not None),
    )
    if len(_CONTEXTS) >= 64:
        _CONTEXTS.clear()
    _CONTEXTS[key] = (scene, models, ctx)
    return ctx


def assess(
    scene: Scene,
    result,
    models: Mapping,
    label: str | None = None,
) -> Claim:
    """The validity warnings of a converged ``solve`` result whose flexure models are
    ``models`` ({flexure: model}, as passed to solve). ``label``: the label of every flexure's
    model in the warnings (default ``model_label`` of each).
    The bend and kernel at the equilibrium are the core's (``Result.bend``, ``kernel``), and so
    is the stability margin where the result carries it."""
    ctx = _context(scene, models, label)
    labels = ctx.labels
    warnings: list[str] = []
    oor = switched = False
    bends = result.bend  # the core's, per flexure
    beta_at = max(bends, key=bends.__getitem__)
    beta = bends[beta_at]
    kernels = result.kernel  # the core's: the kernel evaluating each scm flexure there
    for name in ctx.scm:
        m = models[name]
        state = kernels[name]
        switched |= (m.poly is not None or m.local is not None) and state.startswith("gauss")
        if state in ("poly past its range", "local past its range"):
            oor = True
            warnings.append(
                f"flexure {name!r} ({labels[name]}): bend {_deg(bends[name])}, past "
                f"{m.first_range()}; the answer may be wrong by any amount"
            )
        elif state == "gauss past its certified range":
            oor = True
            warnings.append(
                f"flexure {name!r} ({labels[name]}): bend {_deg(bends[name])} is past the "
                f"certified range of the Gauss kernel {m.gauss_name} "
                f"({math.degrees(m.gauss.PHI_MAX):.0f} deg); its error bound does not hold"
            )
    for name in ctx.prb:
        if bends[name] > PRB_LIMIT:
            warnings.append(
                f"flexure {name!r} (prb): pin rotation {_deg(bends[name])} is past the pseudo-"
                f"rigid-body model's {_deg(PRB_LIMIT)} validity; no accuracy is claimed for it"
            )
    if ctx.prb and ctx.prb_problem is not None:
        warnings.append(
            f"{_names(ctx.prb)} (prb): the pseudo-rigid-body constants are fitted for a force at "
            f"the tip of a single flexure, and this scene has {ctx.prb_problem}; no accuracy is "
            f"claimed"
        )
    if beta > BEND_LIMIT:
        warnings.append(
            f"flexure {beta_at!r} ({labels[beta_at]}): bent {_deg(beta)}, past the "
            f"{_deg(BEND_LIMIT)} to which the error estimate's Gauss kernels are certified; "
            f"no accuracy is claimed"
        )
    if ctx.strained:
        from flexgen.stress import max_abs_curvature

        q = result.q
        kappa = {
            name: max_abs_curvature(models[name], q[name])
            for name, _ in ctx.strained
            if name in models and name in q and hasattr(models[name], "curvature")
        }
        warnings.extend(strain_warnings(scene, kappa))
    margin = getattr(result, "stability_margin", None)
    if margin is None:
        margin = stiffness_margin(scene, models, result.q, getattr(result, "stiffness", None))
    if margin < NEAR_SINGULAR and getattr(result, "stable", True):
        pts = ", ".join(repr(p) for p in getattr(result, "points", {})) or "the output points"
        warnings.append(
            f"near a critical load: the stiffness is {margin:.1%} from singular (the limit is "
            f"{NEAR_SINGULAR:.0%}), so the compliance at {pts} amplifies any model error by "
            f"about {1 / max(margin, 1e-300):.3g}x"
        )
    return Claim(beta, margin, oor, switched, warnings)


def models_of(scene: Scene, result, models: Mapping | None = None, model_factory=None) -> Mapping:
    """The flexure models a chain-model ``result`` of ``scene`` was solved with, rebuilt:
    ``models``/``model_factory`` as given to solve, else each flexure's ModelSpec with the modes
    and kernel the result reports (a tolerance chooses them per flexure)."""
    from flexgen.models.registry import as_reported, build_model, build_models

    if model_factory is None and models is not None and len(models) == len(scene.flexures):
        return models  # complete (a solver's own): kept as it is, so its context is reused
    if models is not None or model_factory is not None:
        return build_models(scene, models, model_factory)

    def factory(f):
        return build_model(replace(f, model=as_reported(f.model, result.model.get(f.name, {}))))

    return build_models(scene, None, factory)


def check(scene: Scene, result, models: Mapping | None = None, model_factory=None):
    """Append the validity warnings of a converged chain-model ``result`` to
    ``result.warnings`` (no duplicates): a model past its validity (prb past 64 deg or outside
    its fitted case, a kernel past its certified range, a bend past ``BEND_LIMIT``), a load
    near a critical one, a flexure strained past ``STRAIN_LIMIT``, or a bend at a load level
    that suggests the wrong units (``units_warning``). What the answer claims is its error estimate (``flexgen.estimate``).
    Returns the Claim (None if the result did not converge)."""
    if not result.converged or not scene.flexures:
        return None
    ms = models_of(scene, result, models, model_factory)
    claim = assess(scene, result, ms)
    units = units_warning(scene, result.bend)
    for w in claim.warnings + ([units] if units else []):
        if w not in result.warnings:
            result.warnings.append(w)
    return claim


@dataclass(frozen=True)
class _Screen:
    """What ``calm`` needs of a prepared solver, made once (kept on the solver)."""

    empty: bool  # no flexures: check adds nothing
    # prb outside its fitted case (a warning on every answer), or a flexure with a thickness
    # whose model has no cheap curvature bound: check decides every answer
    always: bool
    # per flexure (core order), the bend above which some warning may apply: BEND_LIMIT, and
    # PRB_LIMIT for prb, and UNITS_BEND at a load level above UNITS_LOAD_LEVEL; the core reads
    # them (fg_problem.bend_limit) and screens every answer itself (fg_answer.calm)
    limits: Any
    # per flexure with a thickness: (start, stop) of its coordinates in q and its model's
    # curvature_bound times thickness / 2: the strain screen (STRAIN_LIMIT), in Python
    strained: tuple = ()

    @property
    def by_core(self) -> bool:
        """The core's screen decides (else the answer is calm exactly when the scene has no
        flexures)."""
        return not self.empty and not self.always


def _screen(solver) -> _Screen:
    from flexgen import core

    scene, models = solver.scene, solver.models
    ctx = _context(scene, models, None)
    order = list(solver.problem.flexure_order)
    levels = scene.load_levels()
    limits = []
    for name in order:
        limit = BEND_LIMIT
        if name in ctx.prb:
            limit = min(limit, PRB_LIMIT)
        if levels.get(name, 0.0) > UNITS_LOAD_LEVEL:
            limit = min(limit, UNITS_BEND)
        limits.append(limit)
    # the core's screen (chain_solver.c: screen_calm) also asks every kernel flexure's kernel to
    # be within its certified set, and the margin to a critical load above NEAR_SINGULAR
    limit_array = np.array(limits if limits else [0.0], dtype=float)
    struct = solver.problem.struct
    struct.near_margin = NEAR_SINGULAR
    struct.bend_limit = core.ffi.cast("double *", limit_array.ctypes.data)
    slices = solver.problem.chain.slices
    strained = []  # (start, stop, use the max, factor x thickness / 2): see calm
    always = bool(ctx.prb) and ctx.prb_problem is not None
    for name, half in ctx.strained:
        terms = getattr(models[name], "curvature_bound", None)
        if terms is not None:
            use_max, factor = terms()
            strained.append((slices[name].start, slices[name].stop, use_max, factor * half))
        elif hasattr(models[name], "curvature"):  # no cheap bound: check decides every answer
            always = True
    return _Screen(
        empty=not scene.flexures,
        always=always,
        limits=limit_array,
        strained=tuple(strained),
    )


def loads_scene(solver) -> Scene:
    """The scene with the loads and tensions ``solver`` (a prepared ``flexgen.Solver``) was
    last given, where this module's checks could read them differently from the scene's own (a
    prb flexure's no-moment case, a load level above UNITS_LOAD_LEVEL; review: a Solver's answer
    at a moment missed prb's caveat, at 5000 N the units warning, and a Solver of a 5000 N
    scene warned of that level at 1 N, as did a study's rows); else the scene itself, with no
    Scene built (the usual loop: loads changed, neither rule concerned)."""
    scene = solver.scene
    if not solver.loads_changed:
        return scene
    ctx = _context(scene, solver.models, None)
    p = solver.problem
    if not ctx.prb and not ctx.level_high:
        # (lists: NumPy's calls cost more here)
        levels = load_levels(scene.flexures, p.loads.tolist(), p.tensions.tolist())
        if max(levels.values(), default=0.0) <= UNITS_LOAD_LEVEL:
            return scene  # the checks read these loads as they read the scene's
    return with_loads(scene, p.loads.tolist(), p.tensions.tolist())


def calm(solver) -> bool:
    """True when ``check(solver.scene, result, solver.models)`` would add no warning to the
    converged result that ``solver`` (a prepared ``flexgen.Solver``) just solved, decided
    from the core's bend and kernel per flexure still in ``solver.workspace`` (call it before
    the solver solves again) without building the Result's dicts: ``flexgen.solve``'s usual
    answer then skips ``check``. Conservative: False whenever a warning may apply (it needs every
    bend within its limit, every smooth curvature kernel within its range and the margin to a
    critical load not small: the core's screen, ``fg_answer.calm``, given the limits on the
    first call), and ``check`` decides."""
    screen = solver._validity_screen
    if screen is not None and screen.by_core:
        calm_now = bool(solver.workspace.answer.calm)  # the core screened it (screen_calm)
    elif screen is None:  # first answer: the screen made and given to the core, which screens
        screen = solver._validity_screen = _screen(solver)  # every answer from now on
        if screen.by_core:  # this one, solved before, by fg_calm
            from flexgen import core

            ws = solver.workspace
            calm_now = bool(
                core.lib.fg_calm(solver.problem.struct, ws.answer, ws.work_ptr, ws.iwork_ptr)
            )
        else:
            calm_now = screen.empty
    else:
        calm_now = screen.empty  # (no flexures: nothing to warn about; prb outside: always)
    if calm_now and screen.strained:  # every strain below its limit, by a cheap bound
        q = solver.workspace.q.tolist()
        for a, b, use_max, factor in screen.strained:
            part = map(abs, q[a:b])
            if (max(part) if use_max else sum(part)) * factor > STRAIN_LIMIT:
                return False
    return calm_now
