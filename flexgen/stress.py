"""Bending curvature, strain and stress along every flexure of an answer, and its safety factor.

Each model gives its own curvature profile kappa(s) (``curvature(q, s)``, 1/length; see each
model class for what its coordinates say about the curvature). From it, with the section the
scene gave (``Flexure.E``, ``thickness``):

- strain: the outer-fibre bending strain kappa c, c = thickness / 2 (known when the thickness
  is), signed as kappa (the fibre on the convex side is stretched by it, the other shortened);
- stress: E kappa c (known when E and the thickness are);
- safety factor: the smaller of the given strengths (``yield_strength``, ``fatigue_strength``)
  over the largest |stress|. The fatigue strength is compared with the peak stress as it is
  (fully reversed bending: the peak is the amplitude). A flexure without stress has an infinite
  safety factor (``inf`` in Python, null in JSON, as every non-finite number there); without a
  strength, or without a known stress, it is None.

The maximum is taken on a grid of ``num`` samples plus each model's ``curvature_extremes`` (the
arc lengths where |kappa| may peak: for smooth curvature the roots of kappa', found on the
polynomial; for the chain its joints), so it is the model's own maximum, not the grid's.

The error estimate of the profile (relative to its largest |kappa|, so of every maximum) comes
from ``flexgen.estimate`` (the richer model's profile) and is passed in; a safety factor above 1
by less than it is a warning too (``safety_warnings``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .scene import Flexure, Scene

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
    max_strain: float | None
    max_stress: float | None
    at: float  # s / L of the largest |kappa|
    safety_factor: float | None  # smallest given strength / max_stress
    limited_by: str | None  # "yield" or "fatigue": the strength that gives safety_factor
    # the estimated error of the curvature profile relative to its largest |kappa|, and so of
    # max_curvature, max_strain and max_stress (flexgen.estimate: the richer model's profile);
    # None without an estimate (the exact model, or a solve asked for none)
    error_estimate: float | None = None

    def contract(self) -> dict[str, Any]:
        """The JSON fields (None where unknown; inf is written as null by Result.to_json);
        ``error_estimate`` only where there is one, as an output point's."""
        out = {
            "max_curvature": self.max_curvature,
            "max_strain": self.max_strain,
            "max_stress": self.max_stress,
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
) -> dict[str, FlexureStress]:
    """The profiles of every flexure whose model gives a curvature (``curvature(q, s)``;
    a model without one is left out), at the coordinates ``q`` ({flexure: coordinates}); their
    error estimates are the caller's (flexgen.estimate.Estimator.curvature_estimates)."""
    out: dict[str, FlexureStress] = {}
    for f in scene.flexures:
        model = models.get(f.name)
        if model is None or not hasattr(model, "curvature") or f.name not in q:
            continue
        qf = np.asarray(q[f.name], dtype=float)
        s = np.linspace(0.0, f.length, num)
        extremes = getattr(model, "curvature_extremes", None)
        if extremes is not None:
            s = np.union1d(s, np.clip(np.asarray(extremes(qf), dtype=float), 0.0, f.length))
        kappa = np.asarray(model.curvature(qf, s), dtype=float)
        out[f.name] = section_stress(f, s, kappa)
    return out


def section_stress(flexure: Flexure, s: np.ndarray, kappa: np.ndarray) -> FlexureStress:
    """Strain, stress and safety factor of one flexure from its curvature profile."""
    i = int(np.argmax(np.abs(kappa)))
    c = None if flexure.thickness is None else 0.5 * flexure.thickness
    strain = None if c is None else kappa * c
    stress = None if strain is None or flexure.E is None else flexure.E * strain
    max_stress = None if stress is None else float(abs(stress[i]))
    safety, limited_by = safety_factor(flexure, max_stress)
    return FlexureStress(
        s=s,
        curvature=kappa,
        strain=strain,
        stress=stress,
        max_curvature=float(abs(kappa[i])),
        max_strain=None if strain is None else float(abs(strain[i])),
        max_stress=max_stress,
        at=float(s[i] / flexure.length),
        safety_factor=safety,
        limited_by=limited_by,
    )


def max_abs_curvature(model: Any, q: Any) -> float:
    """The model's largest |kappa| at q: its own ``max_abs_curvature`` when it has one (smooth
    curvature: closed form), else the largest on its ``curvature_extremes``."""
    own = getattr(model, "max_abs_curvature", None)
    if own is not None:
        return float(own(q))
    q = np.asarray(q, dtype=float)
    return float(np.max(np.abs(model.curvature(q, model.curvature_extremes(q)))))


def peak_stress(flexure: Flexure, model: Any, q: Any) -> tuple[float | None, float | None]:
    """(max |stress|, safety factor) of one flexure at q, without the profiles: what a study
    records per case (None where ``FlexureStress`` has None). The model must give
    ``curvature_extremes`` or ``max_abs_curvature`` (every chain model does)."""
    if flexure.E is None or flexure.thickness is None:
        return None, None
    kappa = max_abs_curvature(model, q)
    stress = flexure.E * kappa * 0.5 * flexure.thickness
    return stress, safety_factor(flexure, stress)[0]


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


def safety_warnings(scene: Scene, stresses: Mapping[str, FlexureStress]) -> list[str]:
    """One warning per flexure whose safety factor is below 1, naming every strength its
    largest stress exceeds, or may be below 1: the largest stress its error estimate allows,
    max_stress / (1 - estimate) (the estimate is relative to the larger peak; any stress at an
    estimate of 1 or more), would exceed the smaller strength."""
    out = []
    # the stresses' unit where the scene names its units (review: "max stress 2360 ... yield
    # strength 1400" in an mm/N scene)
    unit = "" if scene.units is None else " " + scene.units.label("stress")
    for f in scene.flexures:
        st = stresses.get(f.name)
        if st is None or st.safety_factor is None:
            continue
        est = st.error_estimate or 0.0
        # the estimate is relative to the larger of the two peaks, so the true stress is at most
        # max_stress / (1 - est): the true safety factor at least safety_factor (1 - est)
        if st.safety_factor >= 1.0 and st.safety_factor * (1.0 - est) >= 1.0:
            continue
        if st.safety_factor >= 1.0:
            off = _percent(est) if math.isfinite(est) else "an unknown amount"
            out.append(
                f"flexure {f.name!r}: safety factor {safety_text(st.safety_factor)} "
                f"({st.limited_by}) "
                f"may be below 1: its max stress {st.max_stress:.4g}{unit} may be off by {off} (its "
                f"error estimate; more modes or elements resolve it)"
            )
            continue
        assert st.max_stress is not None
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
