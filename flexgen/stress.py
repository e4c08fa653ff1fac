"""Curvature, strain and stress along every flexure of an answer, and its safety factor.

Each model gives its own curvature profile kappa(s) (``curvature(q, s)``, 1/length; see each
model class for what its coordinates say about the curvature). From it, with the section the
scene gave (``Flexure.E``, ``width``, ``thickness``):

- strain: the outer-fibre bending strain kappa c, c = thickness / 2 (known when the thickness
  is), signed as kappa (the fibre on the convex side is stretched by it, the other shortened);
- stress: E kappa c, the bending stress (known when E and the thickness are);
- axial stress: N(s) / A, the force the flexure transmits along its tangent
  (``flexgen.statics``: the loads and tendon pulls beyond it) over the section's area
  A = width x thickness; known when the scene gives the strip's width and thickness (E, I and
  a thickness do not say the section is a rectangle), None otherwise;
- the largest stress: the outer fibres carry bending plus axial, so max_stress is the largest
  |E kappa c| + |N / A| along the flexure (bending alone where the axial stress is unknown),
  max_strain that over E, and ``at`` where it is;
- safety factor: the smaller of the given strengths (``yield_strength``, ``fatigue_strength``)
  over max_stress. The fatigue strength is compared with the peak stress as it is
  (fully reversed bending: the peak is the amplitude). A flexure without stress has an infinite
  safety factor (``inf`` in Python, null in JSON, as every non-finite number there); without a
  strength, or without a known stress, it is None.

The maximum is taken on a grid of ``num`` samples plus each model's ``curvature_extremes`` (the
arc lengths where |kappa| may peak: for smooth curvature the roots of kappa', found on the
polynomial; for the chain its joints), so the bending maximum is the model's own, not the
grid's (the axial part varies slowly, with the tangent's angle).

The error estimate of the profile (relative to its largest |kappa|, so of every maximum: the
axial part, from the geometry, is far more accurate) comes from ``flexgen.estimate`` (the richer
model's profile) and is passed in; a safety factor above 1 by less than it is a warning too
(``safety_warnings``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from .scene import Flexure, Scene
from .statics import axial_force

DEFAULT_SAMPLES = 129  # grid points along each flexure for the profiles


@dataclass(frozen=True)
class FlexureStress:
    s: np.ndarray = field(compare=False, repr=False)  # (n,) arc length from the root, 0..L
    curvature: np.ndarray = field(compare=False, repr=False)  # (n,) kappa(s), 1/length
    # (n,) outer-fibre strain kappa c (None: no thickness); (n,) stress E kappa c (None: E or
    # the thickness unknown)
    strain: np.ndarray | None = field(compare=False, repr=False)
    stress: np.ndarray | None = field(compare=False, repr=False)
    max_curvature: float  # max |kappa|
    max_strain: float | None  # max |kappa c| + |N / (E A)|: the outer fibre's, axial included
    max_stress: float | None  # max |E kappa c| + |N / A| (bending alone: axial stress unknown)
    at: float  # s / L of the largest stress (of the largest |kappa| without a stress)
    safety_factor: float | None  # smallest given strength / max_stress
    limited_by: str | None  # "yield" or "fatigue": the strength that gives safety_factor
    # the estimated error of the curvature profile relative to its largest |kappa|, and so of
    # max_curvature, max_strain and max_stress (flexgen.estimate: the richer model's profile);
    # None without an estimate (the exact model, or a solve asked for none)
    error_estimate: float | None = None
    # (n,) axial stress N(s) / A, tension positive (None: the section's area or the transmitted
    # force unknown) and its largest magnitude
    axial_stress: np.ndarray | None = field(default=None, compare=False, repr=False)
    max_axial_stress: float | None = None

    def outer_stress(self) -> np.ndarray | None:
        """(n,) the outer fibres' largest |stress| along the flexure: |bending| + |axial|."""
        if self.stress is None:
            return None
        bending = np.abs(self.stress)
        return bending if self.axial_stress is None else bending + np.abs(self.axial_stress)

    def contract(self) -> dict[str, Any]:
        """The JSON fields (None where unknown; inf is written as null by Result.to_json);
        ``error_estimate`` only where there is one, as an output point's."""
        out = {
            "max_curvature": self.max_curvature,
            "max_strain": self.max_strain,
            "max_stress": self.max_stress,
            "max_axial_stress": self.max_axial_stress,
            "at": self.at,
            "safety_factor": self.safety_factor,
            "limited_by": self.limited_by,
        }
        if self.error_estimate is not None:
            out["error_estimate"] = self.error_estimate
        return out


def flexure_stresses(
    scene: Scene,
    models: Mapping[str, Any],
    q: Mapping[str, Any],
    num: int = DEFAULT_SAMPLES,
    statics: tuple[Mapping[str, Any], Mapping[str, float]] | None = None,
) -> dict[str, FlexureStress]:
    """The profiles of every flexure whose model gives a curvature (``curvature(q, s)``;
    a model without one is left out), at the coordinates ``q`` ({flexure: coordinates}); their
    error estimates are the caller's (flexgen.estimate.CurvatureEstimates.of).
    ``statics``: ({flexure: transmitted world force}, {flexure: world angle of its root}) at
    the answer (``flexgen.statics``), for the axial stress of the flexures with an area."""
    out: dict[str, FlexureStress] = {}
    for f in scene.flexures:
        model = models.get(f.name)
        if model is None or not hasattr(model, "curvature") or f.name not in q:
            continue
        out[f.name] = flexure_stress(f, model, q[f.name], num, statics)
    return out


def flexure_stress(
    f: Flexure,
    model: Any,
    q: Any,
    num: int = DEFAULT_SAMPLES,
    statics: tuple[Mapping[str, Any], Mapping[str, float]] | None = None,
) -> FlexureStress:
    """One flexure's profiles (``flexure_stresses``)."""
    qf = np.asarray(q, dtype=float)
    s = _grid(f.length, num).copy()
    extremes = getattr(model, "curvature_extremes", None)
    if extremes is not None:
        s = np.union1d(s, np.clip(np.asarray(extremes(qf), dtype=float), 0.0, f.length))
    kappa = np.asarray(model.curvature(qf, s), dtype=float)
    axial = None
    if statics is not None and section_area(f) is not None and f.name in statics[0]:
        angle = statics[1][f.name] + np.asarray(model.tangent_angle(qf, s), dtype=float)
        axial = axial_force(statics[0][f.name], angle)
    return section_stress(f, s, kappa, axial)


@lru_cache(maxsize=256)
def _grid(length: float, num: int) -> np.ndarray:
    """``num`` arc lengths evenly from 0 to ``length`` (read-only: shared by every call)."""
    out = np.linspace(0.0, length, num)
    out.setflags(write=False)
    return out


def section_area(flexure: Flexure) -> float | None:
    """The strip's cross-section width x thickness; None unless both (and E) are given."""
    if flexure.width is None or flexure.thickness is None or flexure.E is None:
        return None
    return flexure.width * flexure.thickness


def has_area(scene: Scene) -> bool:
    """Does any flexure have a known area (then its axial stress needs the answer's statics)?"""
    return any(section_area(f) is not None for f in scene.flexures)


def section_stress(
    flexure: Flexure, s: np.ndarray, kappa: np.ndarray, axial_force: np.ndarray | None = None
) -> FlexureStress:
    """Strain, stress and safety factor of one flexure from its curvature profile and, where
    the section's area is known, the axial force N(s) along it (``flexgen.statics``)."""
    i_kappa = int(np.argmax(np.abs(kappa)))
    c = None if flexure.thickness is None else 0.5 * flexure.thickness
    strain = None if c is None else kappa * c
    stress = None if strain is None or flexure.E is None else flexure.E * strain
    area = section_area(flexure)
    axial = None if axial_force is None or area is None else axial_force / area
    i = i_kappa
    max_stress = max_strain = None
    if stress is not None:
        outer = np.abs(stress) if axial is None else np.abs(stress) + np.abs(axial)
        i = int(np.argmax(outer))
        max_stress = float(outer[i])
        max_strain = max_stress / float(flexure.E)  # type: ignore[arg-type]
    elif strain is not None:
        max_strain = float(abs(strain[i]))
    safety, limited_by = safety_factor(flexure, max_stress)
    return FlexureStress(
        s=s,
        curvature=kappa,
        strain=strain,
        stress=stress,
        max_curvature=float(abs(kappa[i_kappa])),
        max_strain=max_strain,
        max_stress=max_stress,
        at=float(s[i] / flexure.length),
        safety_factor=safety,
        limited_by=limited_by,
        axial_stress=axial,
        max_axial_stress=None if axial is None else float(np.max(np.abs(axial))),
    )


def max_abs_curvature(model: Any, q: Any) -> float:
    """The model's largest |kappa| at q: its own ``max_abs_curvature`` when it has one (smooth
    curvature: closed form), else the largest on its ``curvature_extremes``."""
    own = getattr(model, "max_abs_curvature", None)
    if own is not None:
        return float(own(q))
    q = np.asarray(q, dtype=float)
    return float(np.max(np.abs(model.curvature(q, model.curvature_extremes(q)))))


def peak_stress(
    flexure: Flexure,
    model: Any,
    q: Any,
    statics: tuple[Mapping[str, Any], Mapping[str, float]] | None = None,
) -> tuple[float | None, float | None]:
    """(max |stress|, safety factor) of one flexure at q: what a study records per case (None
    where ``FlexureStress`` has None). Bending alone without the profiles (the model gives
    ``curvature_extremes`` or ``max_abs_curvature``: every chain model does); with ``statics``
    (``flexgen.statics.chain_statics``) and a known area, the profile's bending plus axial
    maximum, as ``Result.flexures`` reports it."""
    if flexure.E is None or flexure.thickness is None:
        return None, None
    if statics is not None and section_area(flexure) is not None and flexure.name in statics[0]:
        st = flexure_stress(flexure, model, q, DEFAULT_SAMPLES, statics)
        return st.max_stress, st.safety_factor
    kappa = max_abs_curvature(model, q)
    stress = flexure.E * kappa * 0.5 * flexure.thickness
    return stress, safety_factor(flexure, stress)[0]


def peak_stresses(
    flexure: Flexure,
    model: Any,
    Q: np.ndarray,
    forces: np.ndarray,
    root_angles: np.ndarray,
) -> np.ndarray:
    """(m,) max stress of one flexure with a known area over many answers at once: ``Q``
    (m, k) its coordinates, ``forces`` (m, 2) the force it transmits, ``root_angles`` (m,)
    its root's world angle (``Chain.frame_poses_batch``, ``StaticsPlan.transmitted``). The
    maximum ``peak_stress`` finds per answer, by the model's ``grid_profile`` and
    ``extremes_profile`` in one vectorised pass where it has them (smooth curvature), else
    ``peak_stress`` per answer."""
    area = section_area(flexure)
    assert area is not None and flexure.thickness is not None and flexure.E is not None
    Q = np.asarray(Q, dtype=float).reshape(len(forces), -1)
    if not hasattr(model, "grid_profile") or not hasattr(model, "extremes_profile"):
        return np.array(
            [
                peak_stress(flexure, model, q, ({flexure.name: f}, {flexure.name: float(a)}))[0]
                for q, f, a in zip(Q, forces, root_angles)
            ],
            dtype=float,
        )
    kappa, angle = model.grid_profile(Q, DEFAULT_SAMPLES)
    kappa_x, angle_x = model.extremes_profile(Q)
    kappa = np.concatenate([kappa, kappa_x], axis=1)
    angle = np.concatenate([angle, angle_x], axis=1) + np.asarray(root_angles)[:, None]
    axial = forces[:, :1] * np.cos(angle) + forces[:, 1:] * np.sin(angle)
    outer = np.abs(kappa) * (flexure.E * 0.5 * flexure.thickness) + np.abs(axial) / area
    return np.nanmax(outer, axis=1)


def strengths(flexure: Flexure) -> dict[str, float]:
    """The strengths the scene gave this flexure, by name ("yield", "fatigue")."""
    given = {"yield": flexure.yield_strength, "fatigue": flexure.fatigue_strength}
    return {k: v for k, v in given.items() if v is not None}


def safety_factor(flexure: Flexure, max_stress: float | None) -> tuple[float | None, str | None]:
    """(smallest strength / max_stress, which strength); (None, None) without a strength or a
    known stress; inf for a flexure without stress."""
    given = strengths(flexure)
    if not given or max_stress is None:
        return None, None
    limited_by = min(given, key=lambda k: given[k])
    strength = given[limited_by]
    return (strength / max_stress if max_stress > 0.0 else float("inf")), limited_by


def safety_text(factor: float) -> str:
    """A safety factor in words: 3 significant digits, more where those would round it to 1
    (1.0028 is "1.003", not "1": its side of 1 is the point)."""
    for digits in range(3, 8):
        text = f"{factor:.{digits}g}"
        if float(text) != 1.0 or factor == 1.0:
            return text
    return text


def _percent(fraction: float) -> str:
    """A relative error as a percentage a reader sees is not zero: 39%, 0.61%, 0.0067%."""
    pct = 100.0 * fraction
    return f"{pct:.0f}%" if pct >= 10.0 else f"{pct:.2g}%"


def stress_bound(flexure: Flexure, st: FlexureStress) -> float:
    """The largest max_stress the error estimate allows: the bending peak E c max|kappa| over
    (1 - estimate) (the estimate is relative to the larger of the model's and the richer
    model's peaks; inf at an estimate of 1 or more) plus the axial peak (from the statics and
    the pose, whose error is far smaller); max_stress itself without an estimate."""
    assert st.max_stress is not None and flexure.E is not None and flexure.thickness is not None
    est = st.error_estimate or 0.0
    if not est < 1.0:
        return math.inf
    bending = flexure.E * st.max_curvature * 0.5 * flexure.thickness
    return max(st.max_stress, (st.max_axial_stress or 0.0) + bending / (1.0 - est))


def safety_warnings(scene: Scene, stresses: Mapping[str, FlexureStress]) -> list[str]:
    """One warning per flexure whose safety factor is below 1, naming every strength its
    largest stress exceeds, or may be below 1: the largest stress its error estimate allows
    (``stress_bound``) would exceed the smaller strength."""
    out = []
    # the stresses' unit where the scene names its units (review: "max stress 2360 ... yield
    # strength 1400" in an mm/N scene)
    unit = scene.unit_of("stress")
    unit = f" {unit}" if unit else ""
    for f in scene.flexures:
        st = stresses.get(f.name)
        if st is None or st.safety_factor is None:
            continue
        assert st.max_stress is not None
        if st.safety_factor >= 1.0:
            bound = stress_bound(f, st)
            if min(strengths(f).values()) >= bound:
                continue
            est = st.error_estimate or 0.0
            high = (
                f"may be as high as {bound:.4g}{unit} (its error estimate: {_percent(est)} of the "
                "bending stress)"
                if math.isfinite(bound)
                else f"has no upper bound (its error estimate: {_percent(est)} of the bending "
                "stress)"
                if math.isfinite(est)
                else "has no upper bound (its error estimate is unknown)"
            )
            out.append(
                f"flexure {f.name!r}: safety factor {safety_text(st.safety_factor)} "
                f"({st.limited_by}) may be below 1: its max stress {st.max_stress:.4g}{unit} "
                f"{high}; more modes or elements resolve it"
            )
            continue
        exceeded = " and ".join(
            f"{name} strength {value:.4g}{unit}"
            for name, value in strengths(f).items()
            if value < st.max_stress
        )
        out.append(
            f"flexure {f.name!r}: max stress {st.max_stress:.4g}{unit} at s/L = {st.at:.3g} exceeds "
            f"its {exceeded} (safety factor {safety_text(st.safety_factor)})"
        )
    return out


def has_strengths(scene: Scene) -> bool:
    """Does any flexure have a strength (then a Result computes its stresses at once, for the
    safety-factor warnings)?"""
    return any(strengths(f) for f in scene.flexures)
