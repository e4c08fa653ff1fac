"""When a model's answer is past its validity, and the stability sweep's error classes.

``flexgen.api.solve_scene`` (the path of ``flexgen solve`` and ``flexgen.solve``) calls ``check``
on every converged chain-model result: it appends the validity warnings (prb past 64 deg or
outside its fitted case, a kernel past its certified range, a bend past 180 deg, a load near a
critical one). What an answer claims is its own error estimate (``flexgen.estimate``); the
CLAIMS table below no longer enters ``flexgen.solve`` (``check`` assesses with
``calibrated=False``). ``flexgen_tools.stability`` still assesses its sweep with the table
(``assess(..., calibrated=True)``) and ``python -m flexgen_tools.stability --calibrate`` still
rewrites it: left in place for that tool, unused by the runtime.

The indicative error class
--------------------------
Without a requested tolerance no model estimates its own error a posteriori. Every result instead
carries an indicative error class: an upper bound of its pose error (relative to the flexure
length, as in ``flexgen_tools.bench``) and of its compliance error (relative, spectral norm), by
model, by load level lambda (``load_level``) and by bend beta = max |phi(s)| over every flexure
(the angle relative to the flexure's root frame). The classes are ``CLAIMS`` below, calibrated on
the sweep of ``flexgen stability`` (``python -m flexgen_tools.stability --calibrate`` rewrites
the block): 3x the worst unwarned error per band, rounded up to a half decade, monotone in beta
and lambda.
A model without its own row borrows a calibrated neighbour that is no more accurate (``scmN
auto`` -> ``scmN gauss``; scm with more modes -> the largest calibrated N below; fem with other
element counts -> the largest calibrated count below). The Python API exposes the class as
``result.error_class = {"pose": p, "compliance": c}`` (inf where nothing is claimed); it is not
part of the JSON contract.

The warnings (``validity_warnings``)
------------------------------------
* prb past 64 deg of pin rotation (Howell's validity limit), or used outside its one-flexure
  tip-force case (no end moment, link lever arm or tendon);
* a polynomial scm kernel past its range (the answer is an interpolant outside its interval);
  with kernel "auto" the solver switches to the Gauss kernel and already says so, so nothing is
  added here;
* a Gauss kernel past its certified range (|phi| > 180 deg);
* any model bent past 180 deg (the error classes end there);
* the stiffness near singular: the margin to a critical load (the smallest generalized eigenvalue
  of the stiffness K at the equilibrium against the elastic Hessian, 1 - P/P_cr on an axial
  load) below 5 % (near a critical load the compliance error is amplified by 1/margin; the
  compliance class is divided by the margin);
* a load level above 30 (the classes end there);
* a band in which the model has no calibrated class (nothing is claimed);
* (``check`` only) a flexure bent past 90 deg at a load level above 1e3, which no elastic
  flexure survives: nearly always a scene in the wrong units (``units_warning``; a failed solve
  at such a load says so in its reason: ``units_reason``, added by ``flexgen.api``).

With a requested tolerance (``flexgen.select``) the claim is the a-posteriori ``error_estimate``
instead: the calibration-table warnings (load level, bands) are then not given, the others are.
``exact`` is the reference and is not assessed; a result that did not converge already says so.
"""

from __future__ import annotations

import math
import re
from bisect import bisect_left
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from flexgen.scene import Scene

PRB_LIMIT = math.radians(64.0)
NEAR_SINGULAR = 0.05
BANDS = (
    math.radians(30),
    math.radians(60),
    math.radians(90),
    math.radians(120),
    math.radians(150),
    math.pi,
)
LOAD_BANDS = (1.0, 3.0, 10.0, 30.0)  # load level lambda (see load_level)

# label -> table[load band][bend band] = (pose bound, compliance bound) or (None, None) where
# nothing is claimed. Calibrated (``flexgen_tools.stability.calibrate``) on the full sweep of
# `flexgen stability`; the block between the markers is rewritten by
# `python -m flexgen_tools.stability --calibrate`.
# CLAIMS-BEGIN
CLAIMS: dict = {
    "cc": (
        ((0.32, 1.0), (None, None), (None, None), (None, None), (None, None), (None, None)),
        ((1.0, 1.0), (1.0, 1.0), (1.0, 1.0), (None, None), (None, None), (None, None)),
        ((1.0, 1.0), (1.0, 1.0), (1.0, 1.0), (None, None), (None, None), (None, None)),
        ((1.0, 1.0), (1.0, 1.0), (1.0, 1.0), (None, None), (None, None), (None, None)),
    ),
    "fem16": (
        ((0.001, 0.01), (None, None), (None, None), (None, None), (None, None), (None, None)),
        ((0.0032, 0.01), (0.0032, 0.01), (0.01, 0.01), (None, None), (None, None), (None, None)),
        ((0.0032, 0.01), (0.01, 0.01), (0.032, 0.01), (0.032, 0.01), (0.032, 0.01), (0.032, 0.01)),
        ((0.01, 0.01), (0.01, 0.01), (0.032, 0.01), (0.032, 0.01), (0.032, 0.01), (0.032, 0.032)),
    ),
    "fem32": (
        ((0.00032, 0.001), (None, None), (None, None), (None, None), (None, None), (None, None)),
        (
            (0.001, 0.0032),
            (0.001, 0.0032),
            (0.0032, 0.0032),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (0.001, 0.0032),
            (0.0032, 0.0032),
            (0.01, 0.0032),
            (0.01, 0.0032),
            (0.01, 0.0032),
            (0.01, 0.0032),
        ),
        (
            (0.001, 0.0032),
            (0.0032, 0.0032),
            (0.01, 0.0032),
            (0.01, 0.0032),
            (0.01, 0.0032),
            (0.01, 0.0032),
        ),
    ),
    "fem4": (
        ((0.032, 0.1), (None, None), (None, None), (None, None), (None, None), (None, None)),
        ((0.1, 0.1), (0.1, 0.1), (0.1, 0.1), (None, None), (None, None), (None, None)),
        ((0.1, 0.1), (0.1, 0.1), (0.32, 0.1), (0.32, 0.1), (0.32, 0.32), (0.32, 0.32)),
        ((0.1, 0.32), (0.1, 0.32), (0.32, 0.32), (0.32, 0.32), (0.32, 0.32), (0.32, 0.32)),
    ),
    "fem64": (
        ((0.0001, 0.00032), (None, None), (None, None), (None, None), (None, None), (None, None)),
        (
            (0.00032, 0.00032),
            (0.00032, 0.00032),
            (0.00032, 0.001),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (0.00032, 0.001),
            (0.001, 0.001),
            (0.001, 0.001),
            (0.001, 0.001),
            (0.001, 0.001),
            (0.001, 0.001),
        ),
        (
            (0.00032, 0.001),
            (0.001, 0.001),
            (0.001, 0.001),
            (0.001, 0.001),
            (0.001, 0.001),
            (0.001, 0.001),
        ),
    ),
    "fem8": (
        ((0.01, 0.032), (None, None), (None, None), (None, None), (None, None), (None, None)),
        ((0.032, 0.032), (0.032, 0.032), (0.032, 0.032), (None, None), (None, None), (None, None)),
        ((0.032, 0.032), (0.032, 0.032), (0.1, 0.032), (0.1, 0.032), (0.1, 0.032), (0.1, 0.032)),
        ((0.032, 0.1), (0.032, 0.1), (0.1, 0.1), (0.1, 0.1), (0.1, 0.1), (0.1, 0.1)),
    ),
    "prb": (
        ((1.0, 0.32), (None, None), (None, None), (None, None), (None, None), (None, None)),
        ((1.0, 0.32), (3.2, 1.0), (3.2, 1.0), (None, None), (None, None), (None, None)),
        ((1.0, 0.32), (3.2, 1.0), (None, None), (None, None), (None, None), (None, None)),
        ((1.0, 0.32), (3.2, 1.0), (None, None), (None, None), (None, None), (None, None)),
    ),
    "scm2 gauss": (
        ((0.0032, 0.01), (None, None), (None, None), (None, None), (None, None), (None, None)),
        ((0.032, 0.032), (0.032, 0.1), (0.032, 0.1), (None, None), (None, None), (None, None)),
        ((0.1, 0.1), (0.1, 0.1), (0.1, 0.32), (0.1, 0.32), (0.1, 0.32), (0.1, 0.32)),
        ((0.1, 0.1), (0.32, 0.1), (0.32, 0.32), (0.32, 0.32), (1.0, 0.32), (1.0, 1.0)),
    ),
    "scm2 poly": (
        ((0.0032, 0.01), (None, None), (None, None), (None, None), (None, None), (None, None)),
        ((0.032, 0.032), (0.032, 0.1), (0.032, 0.1), (None, None), (None, None), (None, None)),
        ((0.1, 0.1), (0.1, 0.1), (0.1, 0.32), (None, None), (None, None), (None, None)),
        ((0.1, 0.1), (0.32, 0.1), (0.32, 0.32), (None, None), (None, None), (None, None)),
    ),
    "scm3 auto": (
        ((3.2e-05, 0.00032), (None, None), (None, None), (None, None), (None, None), (None, None)),
        ((0.001, 0.001), (0.001, 0.0032), (0.0032, 0.01), (None, None), (None, None), (None, None)),
        (
            (0.0032, 0.0032),
            (0.0032, 0.01),
            (0.0032, 0.01),
            (0.01, 0.032),
            (0.01, 0.032),
            (0.032, 0.032),
        ),
        ((0.032, 0.032), (0.032, 0.032), (0.032, 0.032), (0.032, 0.1), (0.032, 0.1), (0.032, 0.1)),
    ),
    "scm3 gauss": (
        ((3.2e-05, 0.00032), (None, None), (None, None), (None, None), (None, None), (None, None)),
        ((0.001, 0.001), (0.001, 0.0032), (0.0032, 0.01), (None, None), (None, None), (None, None)),
        (
            (0.0032, 0.0032),
            (0.0032, 0.01),
            (0.0032, 0.01),
            (0.01, 0.032),
            (0.01, 0.032),
            (0.032, 0.032),
        ),
        ((0.032, 0.032), (0.032, 0.032), (0.032, 0.032), (0.032, 0.1), (0.032, 0.1), (0.032, 0.1)),
    ),
    "scm3 poly": (
        ((3.2e-05, 0.00032), (None, None), (None, None), (None, None), (None, None), (None, None)),
        ((0.001, 0.001), (0.001, 0.0032), (0.0032, 0.01), (None, None), (None, None), (None, None)),
        (
            (0.0032, 0.0032),
            (0.0032, 0.01),
            (0.0032, 0.01),
            (None, None),
            (None, None),
            (None, None),
        ),
        ((0.032, 0.032), (0.032, 0.032), (0.032, 0.032), (None, None), (None, None), (None, None)),
    ),
    "scm4 gauss": (
        ((1e-06, 3.2e-05), (None, None), (None, None), (None, None), (None, None), (None, None)),
        (
            (1e-06, 3.2e-05),
            (3.2e-05, 0.00032),
            (0.00032, 0.001),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (0.0001, 0.0001),
            (0.0001, 0.00032),
            (0.00032, 0.001),
            (0.001, 0.01),
            (0.0032, 0.01),
            (0.0032, 0.01),
        ),
        (
            (0.001, 0.001),
            (0.0032, 0.0032),
            (0.0032, 0.0032),
            (0.0032, 0.01),
            (0.0032, 0.032),
            (0.01, 0.032),
        ),
    ),
    "scm4 poly": (
        ((1e-06, 3.2e-05), (None, None), (None, None), (None, None), (None, None), (None, None)),
        (
            (1e-06, 3.2e-05),
            (3.2e-05, 0.00032),
            (0.00032, 0.001),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (0.0001, 0.0001),
            (0.0001, 0.00032),
            (0.00032, 0.001),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (0.001, 0.001),
            (0.0032, 0.0032),
            (0.0032, 0.0032),
            (None, None),
            (None, None),
            (None, None),
        ),
    ),
    "scm5 auto": (
        ((1e-08, 3.2e-07), (None, None), (None, None), (None, None), (None, None), (None, None)),
        (
            (1e-07, 3.2e-07),
            (3.2e-06, 3.2e-05),
            (3.2e-06, 3.2e-05),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (1e-06, 3.2e-06),
            (3.2e-06, 3.2e-05),
            (3.2e-05, 0.00032),
            (0.0001, 0.001),
            (0.00032, 0.0032),
            (0.00032, 0.0032),
        ),
        (
            (0.0001, 0.0001),
            (0.0001, 0.0001),
            (0.0001, 0.001),
            (0.001, 0.0032),
            (0.0032, 0.01),
            (0.0032, 0.01),
        ),
    ),
    "scm5 gauss": (
        ((1e-08, 3.2e-07), (None, None), (None, None), (None, None), (None, None), (None, None)),
        (
            (1e-07, 3.2e-07),
            (3.2e-06, 3.2e-05),
            (3.2e-06, 3.2e-05),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (1e-06, 3.2e-06),
            (3.2e-06, 3.2e-05),
            (3.2e-05, 0.00032),
            (0.0001, 0.001),
            (0.00032, 0.0032),
            (0.00032, 0.0032),
        ),
        (
            (0.0001, 0.0001),
            (0.0001, 0.0001),
            (0.0001, 0.001),
            (0.001, 0.0032),
            (0.0032, 0.01),
            (0.0032, 0.01),
        ),
    ),
    "scm5 poly": (
        ((1e-08, 3.2e-07), (None, None), (None, None), (None, None), (None, None), (None, None)),
        (
            (1e-07, 3.2e-07),
            (3.2e-06, 3.2e-05),
            (3.2e-06, 3.2e-05),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (1e-06, 3.2e-06),
            (3.2e-06, 3.2e-05),
            (3.2e-05, 0.00032),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (0.0001, 0.0001),
            (0.0001, 0.0001),
            (0.0001, 0.001),
            (None, None),
            (None, None),
            (None, None),
        ),
    ),
    "scm6 gauss": (
        ((1e-10, 1e-08), (None, None), (None, None), (None, None), (None, None), (None, None)),
        (
            (1e-09, 1e-08),
            (1e-07, 1e-06),
            (1e-06, 3.2e-06),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (1e-08, 3.2e-07),
            (1e-06, 1e-05),
            (3.2e-06, 3.2e-05),
            (1e-05, 0.0001),
            (1e-05, 0.0001),
            (3.2e-05, 0.0001),
        ),
        (
            (1e-06, 3.2e-06),
            (3.2e-06, 3.2e-05),
            (3.2e-05, 0.00032),
            (0.00032, 0.001),
            (0.00032, 0.0032),
            (0.001, 0.0032),
        ),
    ),
    "scm6 poly": (
        ((3.2e-10, 1e-08), (None, None), (None, None), (None, None), (None, None), (None, None)),
        (
            (1e-09, 1e-08),
            (1e-07, 1e-06),
            (1e-06, 3.2e-06),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (1e-08, 3.2e-07),
            (1e-06, 1e-05),
            (3.2e-06, 3.2e-05),
            (None, None),
            (None, None),
            (None, None),
        ),
        (
            (1e-06, 3.2e-06),
            (3.2e-06, 3.2e-05),
            (3.2e-05, 0.00032),
            (None, None),
            (None, None),
            (None, None),
        ),
    ),
}
# CLAIMS-END


# -- what a result claims ----------------------------------------------------------------------


@dataclass
class Claim:
    pose: float  # claimed bound on the pose error (inf: nothing claimed)
    comp: float  # claimed bound on the compliance error (inf: nothing claimed)
    beta: float  # largest bend (rad)
    margin: float  # margin to a critical load (stiffness_margin)
    out_of_range: bool  # a kernel past its valid (poly) or certified (gauss) range
    switched: bool  # an auto kernel moved from poly to gauss
    warnings: list = field(default_factory=list)  # validity warnings (added to solve's)
    uncalibrated: bool = False  # one of those warnings: no error class for this bend and load

    @property
    def error_class(self) -> dict[str, float]:
        return {"pose": self.pose, "compliance": self.comp}


_LOAD_EDGES = [e * (1 + 1e-12) for e in LOAD_BANDS]
_BEND_EDGES = [e + 1e-12 for e in BANDS]


def band_index(beta: float, lam: float) -> tuple[int, int] | None:
    """(load band, bend band) of an answer, None past the last of either."""
    i, j = bisect_left(_LOAD_EDGES, lam), bisect_left(_BEND_EDGES, beta)
    return None if i == len(_LOAD_EDGES) or j == len(_BEND_EDGES) else (i, j)


def load_level(scene: Scene) -> float:
    """lambda = max over flexures of L^2/EI x (sum of |force| of the loads + 2 x sum of tendon
    tensions) + max over flexures of L/EI x sum of |moment|: a bound of the nondimensional load
    through any flexure (alpha for a cantilever with one tip force). The calibration sweep has no
    moment loads; a moment counts as much as the force that would exert it at one flexure length
    (checked against exact on cantilevers with tip moments and forces: no answer above its class)."""
    total = sum(math.hypot(*ld.force) for ld in scene.loads) + 2 * sum(
        t.tension for t in scene.tendons
    )
    moments = sum(abs(ld.moment) for ld in scene.loads)
    return (
        max(f.length * f.length / f.EI for f in scene.flexures) * total
        + max(f.length / f.EI for f in scene.flexures) * moments
    )


# A scene in the wrong units: above this load level a flexure bent past UNITS_BEND is far past
# any elastic material. The elastica of a tip force gives the root curvature
# kappa L = 2 sqrt(lambda) sin(bend / 2) (its first integral, the tip aligned with the force):
# at least 45 at lambda = 1e3 and 90 deg, a strain kappa t / 2 of at least 22 t / L, past the
# ~2 % elastic limit of flexure materials unless L / t > 1100. (An axial load may exceed it with
# little bend: that is not flagged.) Such a scene is nearly always a stiffness or a length in the
# wrong unit (E = 200 for 200 GPa in SI makes lambda 1e9 times too large).
UNITS_LOAD_LEVEL = 1e3
UNITS_BEND = math.pi / 2


def flexure_load_levels(scene: Scene) -> dict[str, float]:
    """``load_level`` per flexure: L^2/EI x (forces + 2 x tensions) + L/EI x moments."""
    total = sum(math.hypot(*ld.force) for ld in scene.loads) + 2 * sum(
        t.tension for t in scene.tendons
    )
    moments = sum(abs(ld.moment) for ld in scene.loads)
    return {f.name: f.length * (f.length * total + moments) / f.EI for f in scene.flexures}


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
    levels = flexure_load_levels(scene)
    suspects = [
        n for n, b in bends.items() if b > UNITS_BEND and levels.get(n, 0.0) > UNITS_LOAD_LEVEL
    ]
    if not suspects:
        return None
    name = max(suspects, key=lambda n: bends[n])
    return (
        f"flexure {name!r}: load level {levels[name]:.3g} (force x L^2/EI) and a bend of "
        f"{_deg(bends[name])}, far past what an elastic flexure survives: {units_hint(scene)}"
    )


def units_reason(scene: Scene) -> str | None:
    """What a failed solve's reason adds when a load level is above UNITS_LOAD_LEVEL, else None."""
    level = max(flexure_load_levels(scene).values(), default=0.0)
    if level <= UNITS_LOAD_LEVEL:
        return None
    return f"load level {level:.3g} (force x L^2/EI): {units_hint(scene)}"


_SCENE_CONSTANTS: dict[int, tuple] = {}


def _scene_constants(scene: Scene) -> tuple[float, str | None]:
    """(load_level, _prb_case_problem) of a scene, kept for the last scenes checked (a Scene
    is immutable; the entry holds the scene, so its id is not reused while kept)."""
    got = _SCENE_CONSTANTS.get(id(scene))
    if got is None or got[0] is not scene:
        if len(_SCENE_CONSTANTS) >= 64:
            _SCENE_CONSTANTS.clear()
        got = _SCENE_CONSTANTS[id(scene)] = (scene, load_level(scene), _prb_case_problem(scene))
    return got[1], got[2]


def prb_load_case(scene: Scene) -> bool:
    """The case the PRB constants are fitted for: one flexure, loads only at its tip, no moment,
    no tendon."""
    return _prb_case_problem(scene) is None


def _prb_case_problem(scene: Scene) -> str | None:
    if len(scene.flexures) != 1:
        return f"{len(scene.flexures)} flexures"
    if scene.tendons:
        return "a tendon"
    tip = f"{scene.flexures[0].name}.tip"
    for ld in scene.loads:
        if ld.moment != 0.0:
            return f"a moment at {ld.point!r}"
        if ld.point != tip:
            return f"a load at {ld.point!r}, not at the tip"
    return None


def model_label(model) -> str:
    """The CLAIMS label of a flexure model: "cc", "prb", "scm3 auto", "fem16", ..."""
    from flexgen.models.registry import kind_of

    return kind_of(model).label(model)


def claim_table(label: str) -> tuple[tuple | None, str | None]:
    """(table, the label it was calibrated for) for a model label: its own row of CLAIMS or a
    calibrated neighbour that is no more accurate (see the module docstring); (None, None) if
    there is none."""
    if label in CLAIMS:
        return CLAIMS[label], label
    m = re.fullmatch(r"scm(\d+) (auto|poly|gauss)", label)
    if m:
        n, kernel = int(m[1]), m[2]
        for k in range(n, 1, -1):
            for cand in (
                (f"scm{k} auto", f"scm{k} gauss") if kernel == "auto" else (f"scm{k} {kernel}",)
            ):
                if cand in CLAIMS:
                    return CLAIMS[cand], cand
        return None, None
    m = re.fullmatch(r"fem(\d+)", label)
    if m:
        calibrated = sorted(
            (int(k[3:]) for k in CLAIMS if re.fullmatch(r"fem\d+", k)), reverse=True
        )
        e = next((e for e in calibrated if e <= int(m[1])), None)
        if e is not None:
            return CLAIMS[f"fem{e}"], f"fem{e}"
    return None, None


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
    by_label: tuple[tuple[str, tuple[str, ...], tuple | None], ...]  # label, flexures, table
    load_level: float
    prb_problem: str | None


_CONTEXTS: dict[tuple, tuple] = {}


def _context(scene: Scene, models: Mapping, label) -> _Context:
    key = (id(scene), id(models), label if isinstance(label, str | None) else id(label))
    got = _CONTEXTS.get(key)
    if got is not None and got[0] is scene and got[1] is models:
        return got[2]
    labels = {
        name: (label if isinstance(label, str) else (label or {}).get(name) or model_label(m))
        for name, m in models.items()
    }
    groups: dict[str, list[str]] = {}
    for name, lab in labels.items():
        groups.setdefault(lab, []).append(name)
    lam, prb_problem = _scene_constants(scene)
    ctx = _Context(
        labels,
        tuple(n for n, m in models.items() if getattr(m, "kind", "") == "scm"),
        tuple(n for n, m in models.items() if getattr(m, "kind", "") == "prb"),
        tuple((lab, tuple(names), claim_table(lab)[0]) for lab, names in groups.items()),
        lam,
        prb_problem,
    )
    if len(_CONTEXTS) >= 64:
        _CONTEXTS.clear()
    _CONTEXTS[key] = (scene, models, ctx)
    return ctx


def assess(
    scene: Scene,
    result,
    models: Mapping,
    label: str | Mapping[str, str] | None = None,
    calibrated: bool = True,
) -> Claim:
    """The claim and the validity warnings of a converged ``solve`` result whose flexure models
    are ``models`` ({flexure: model}, as passed to solve). ``label``: the CLAIMS label of every
    flexure's model (a str for all, or {flexure: label}; default ``model_label`` of each).
    ``calibrated=False`` (a tolerance was requested: the claim is the error estimate) leaves out
    the warnings that only say the calibration table ends (load level, bands) and claims nothing
    from the table. The bend and kernel at the equilibrium are the core's (``Result.bend``,
    ``kernel``), and so is the stability margin where the result carries it."""
    ctx = _context(scene, models, label)
    labels = ctx.labels
    warnings: list[str] = []
    oor = switched = False
    bends = result.bend  # the core's, per flexure
    beta_at = max(bends, key=bends.__getitem__)
    beta = bends[beta_at]
    unclaimed: set[str] = set()  # flexures already warned that nothing is claimed
    kernels = result.kernel  # the core's: the kernel evaluating each scm flexure there
    for name in ctx.scm:
        m = models[name]
        state = kernels[name]
        switched |= m.poly is not None and state.startswith("gauss")
        if state == "poly past its range":
            oor = True
            warnings.append(
                f"flexure {name!r} ({labels[name]}): bend {_deg(bends[name])} is past the "
                f"{math.degrees(m.poly.PHI_MAX):.0f} deg range of the polynomial kernel "
                f"scm{m.n_dof}; the answer may be wrong by any amount"
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
            unclaimed.add(name)
            warnings.append(
                f"flexure {name!r} (prb): pin rotation {_deg(bends[name])} is past the pseudo-"
                f"rigid-body model's {_deg(PRB_LIMIT)} validity; no accuracy is claimed for it"
            )
    if ctx.prb and ctx.prb_problem is not None:
        unclaimed.update(ctx.prb)
        warnings.append(
            f"{_names(ctx.prb)} (prb): the pseudo-rigid-body constants are fitted for a force at "
            f"the tip of a single flexure, and this scene has {ctx.prb_problem}; no accuracy is "
            f"claimed"
        )
    if beta > BANDS[-1]:
        unclaimed.update(models)
        warnings.append(
            f"flexure {beta_at!r} ({labels[beta_at]}): bent {_deg(beta)}, past the "
            f"{_deg(BANDS[-1])} the error classes cover; no accuracy is claimed"
        )
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
    lam = ctx.load_level
    if calibrated and lam > LOAD_BANDS[-1]:
        unclaimed.update(models)
        warnings.append(
            f"load level {lam:.3g} (largest force x L^2/EI over the flexures) is above the "
            f"calibrated {LOAD_BANDS[-1]:g}; no accuracy is claimed"
        )
    pose = comp = math.inf
    uncalibrated = False
    idx = band_index(beta, lam)
    if calibrated and idx is not None:
        pose = comp = 0.0
        for lab, names, table in ctx.by_label:
            pe, ce = (None, None) if table is None else table[idx[0]][idx[1]]
            if pe is None:
                pose = comp = math.inf
                if not unclaimed.issuperset(names):  # else already warned: nothing claimed
                    uncalibrated = True
                    warnings.append(
                        f"{_names(names)} ({lab}): no calibrated error class at {_deg(beta)} of "
                        f"bend and load level {lam:.3g} (load x L^2/EI); no accuracy is claimed"
                    )
            else:
                assert ce is not None  # a CLAIMS cell is (pose, compliance) or (None, None)
                pose, comp = max(pose, pe), max(comp, ce)
    if unclaimed:
        pose = comp = math.inf
    if math.isfinite(comp):
        comp = comp / max(min(margin, 1.0), 1e-300)
    return Claim(pose, comp, beta, margin, oor, switched, warnings, uncalibrated)


def validity_warnings(scene: Scene, models: Mapping, result) -> list[str]:
    """The validity warnings of a converged result (``assess``); [] if it did not converge."""
    if not result.converged:
        return []
    return assess(scene, result, models, calibrated=result.tolerance is None).warnings


def models_of(scene: Scene, result, models: Mapping | None = None, model_factory=None) -> Mapping:
    """The flexure models a chain-model ``result`` of ``scene`` was solved with, rebuilt:
    ``models``/``model_factory`` as given to solve, else each flexure's ModelSpec with the modes
    and kernel the result reports (a tolerance chooses them per flexure)."""
    from flexgen.models.registry import build_model, build_models

    if model_factory is None and models is not None and len(models) == len(scene.flexures):
        return models  # complete (a solver's own): kept as it is, so its context is reused
    if models is not None or model_factory is not None:
        return build_models(scene, models, model_factory)

    def factory(f):
        info = result.model.get(f.name, {})
        changes = {k: info[k] for k in ("kind", "modes", "elements", "kernel") if k in info}
        return build_model(replace(f, model=replace(f.model, **changes)))

    return build_models(scene, None, factory)


def check(scene: Scene, result, models: Mapping | None = None, model_factory=None):
    """Append the validity warnings of a converged chain-model ``result`` to
    ``result.warnings`` (no duplicates): a model past its validity (prb past 64 deg or outside
    its fitted case, a kernel past its certified range), a load near a critical one, or a bend
    at a load level that suggests the wrong units (``units_warning``). What the
    answer claims is its error estimate (``flexgen.estimate``), not the CLAIMS table: the
    table's warnings (load level, bands, bends past its last band) are not given here. Returns
    the Claim (None if the result did not converge)."""
    if not result.converged or not scene.flexures:
        return None
    ms = models_of(scene, result, models, model_factory)
    claim = assess(scene, result, ms, calibrated=False)
    units = units_warning(scene, result.bend)
    for w in claim.warnings + ([units] if units else []):
        if w not in result.warnings:
            result.warnings.append(w)
    return claim
