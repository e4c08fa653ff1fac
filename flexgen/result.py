"""The result of solving a scene: equilibrium, stability, compliance of the output points.

``Result.to_json()`` gives every field of the public contract (``scene-format.md``, beside the checkout in ``../shared/``; a chain
model's ``error_estimate`` null where none was asked for), the few of flexgen's own that
docs/solve.md lists, and ``"reason"`` when not converged; ``Result`` itself carries more for the
Python API
(critical load factors, the load factor reached, the flexures' curvature and stress profiles as
arrays where the JSON has their maxima).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

from .stress import FlexureStress, safety_text


def ellipse(C) -> dict[str, float]:
    """Eigenvalues of a symmetric 2x2 compliance (``major`` >= ``minor``) and the angle of the
    major axis from the world x axis in (-pi/2, pi/2] (0 when the ellipse is a circle): the
    core's closed form (``fg_ellipse`` in chain_solver.h), which also gives every chain-model
    answer its ellipses."""
    from .core import ffi, lib
    from .settings import DEFAULT

    out = ffi.new("double[3]")
    lib.fg_ellipse(
        [float(C[0][0]), float(C[0][1]), float(C[1][0]), float(C[1][1])], DEFAULT.circle_tol, out
    )
    return {"major": out[0], "minor": out[1], "angle": out[2]}


@dataclass(slots=True)
class PointResult:
    pose: list[float]  # world x, y and body angle
    compliance: list[list[float]]  # 2x2 d(position)/d(force at the point)
    ellipse: dict[str, float]  # major, minor, angle
    compliance3: list[list[float]]  # 3x3 d(x, y, angle)/d(fx, fy, moment)
    # the estimated error {"pose": ..., "compliance": ...} (flexgen.estimate; pose relative to
    # the summed flexure length from the base to the point, angle in rad; compliance relative,
    # spectral norm, covering compliance and compliance3); None for the exact solver and when no
    # estimate was asked for
    error_estimate: dict[str, float] | None = None

    # the same numbers as NumPy arrays, for computing with them (the fields above stay plain
    # lists: the JSON contract's shape, and cheap to build for every answer)
    @property
    def pose_array(self) -> np.ndarray:
        """(3,) x, y, angle."""
        return np.array(self.pose, dtype=float)

    @property
    def compliance_matrix(self) -> np.ndarray:
        """(2, 2) d(x, y)/d(fx, fy)."""
        return np.array(self.compliance, dtype=float)

    @property
    def compliance3_matrix(self) -> np.ndarray:
        """(3, 3) d(x, y, angle)/d(fx, fy, moment); its inverse is the stiffness of the point."""
        return np.array(self.compliance3, dtype=float)

    def contract(self, chain: bool = False) -> dict[str, Any]:
        """The point's JSON fields; ``chain`` (a chain model's answer): ``error_estimate`` is
        always there, null where none was asked for (the contract: absent only for exact)."""
        out: dict[str, Any] = {
            "pose": list(self.pose),
            "compliance": [list(r) for r in self.compliance],
            "compliance3": [[float(x) for x in r] for r in self.compliance3],
            "ellipse": dict(self.ellipse),
        }
        if self.error_estimate is not None:
            out["error_estimate"] = {k: float(v) for k, v in self.error_estimate.items()}
        elif chain:
            out["error_estimate"] = None
        return out


def point_result(
    pose: list[float],
    c3: list[list[float]],
    ell: list[float],
    error_estimate: dict[str, float] | None = None,
) -> PointResult:
    """The PointResult of an output point from its pose, 3x3 compliance and ellipse (major,
    minor, angle) as plain lists (every chain-model answer is built here; plain floats are
    cheaper than numpy at this size), and its error estimate if there is one."""
    r0, r1, _ = c3
    major, minor, angle = ell
    return PointResult(
        pose,
        [r0[:2], r1[:2]],
        {"major": major, "minor": minor, "angle": angle},
        c3,
        error_estimate,
    )


UNSTABLE = "the equilibrium is unstable: the stiffness matrix is not positive definite"


@dataclass(slots=True)
class Result:
    scene: str
    converged: bool
    stable: bool
    iterations: int
    model: dict[str, dict[str, Any]]
    q: dict[str, list[float]]
    points: dict[str, PointResult]
    # what may make the answer wrong beyond its accuracy; ``notes``: facts that do not (a switch
    # to a certified kernel, a critical load passed and the branch taken)
    warnings: list[str] = field(default_factory=list)
    reason: str | None = None
    critical_load_factors: list[float] = field(default_factory=list)
    load_factor: float = 1.0  # load factor of the reported state (1 when converged)
    energy: float | None = None  # elastic energy at equilibrium
    residual: float | None = None  # relative residual at equilibrium (see flexgen/solver.py)
    # the estimated error of the whole answer (the largest of its points' pose and compliance
    # estimates: flexgen.estimate, or flexgen.select with a tolerance; inf when there is no
    # answer or the estimate failed; None for the exact solver and when none was asked for).
    # ``tolerance``: set only when a tolerance was requested (flexgen.select); model[flexure]
    # then also carries "kernel" and "error_estimate"
    tolerance: float | None = None
    error_estimate: float | None = None
    # which solver produced it (Python API only): "core" (flexgen.solver) or "exact"
    solver: str = "core"
    # the generalized stiffness at equilibrium, coordinates packed as ``q`` lists them (Python
    # API only; None when not converged or for the exact solver)
    stiffness: np.ndarray | None = field(default=None, compare=False, repr=False)
    # at equilibrium (Python API only; chain models): the margin to a critical load (smallest
    # generalized eigenvalue of the stiffness against the elastic Hessian: 1 unloaded,
    # 1 - P/P_cr on an axial load, < 0 unstable; computed on first access; Solver.margin()
    # gives the last answer's), each flexure's largest bend max |phi(s)|
    # relative to its root (rad), and the kernel evaluating each smooth curvature flexure
    # ("local", "poly", "gauss", "gauss past its certified range", ...)
    stability_margin: float | None = None
    bend: dict[str, float] = field(default_factory=dict, compare=False)
    kernel: dict[str, str] = field(default_factory=dict, compare=False)
    notes: list[str] = field(default_factory=list)
    # each flexure's curvature, strain and stress along it and their maxima (flexgen.stress;
    # empty when not converged); ``units``: the scene's units by quantity ("length": "m", ...),
    # None for a scene of plain numbers
    flexures: dict[str, FlexureStress] = field(default_factory=dict, compare=False, repr=False)
    units: dict[str, str] | None = None

    def to_dict(self) -> dict[str, Any]:
        """Every field, as plain Python data (NumPy arrays as nested lists, NumPy scalars as
        Python numbers)."""
        return _plain(asdict(self))

    def contract(self) -> dict[str, Any]:
        """The fields of the JSON contract and flexgen's own (docs/solve.md; ``reason`` when not
        converged)."""
        chain = self.solver != "exact"
        out: dict[str, Any] = {
            "scene": self.scene,
            "converged": bool(self.converged),
            "stable": bool(self.stable),
            "iterations": int(self.iterations),
            "model": {k: dict(v) for k, v in self.model.items()},
            "q": {k: [float(x) for x in v] for k, v in self.q.items()},
            "points": {ref: p.contract(chain) for ref, p in self.points.items()},
            "flexures": {name: st.contract() for name, st in self.flexures.items()},
            "stiffness": (
                None
                if self.stiffness is None or not self.converged
                else [[float(x) for x in row] for row in np.asarray(self.stiffness)]
            ),
        }
        if self.units is not None:
            out["units"] = dict(self.units)
        if self.tolerance is not None or self.error_estimate is not None:
            out["error_estimate"] = (
                math.inf if self.error_estimate is None else float(self.error_estimate)
            )
        elif chain:  # no estimate asked for (estimate=False): null, the key always there
            out["error_estimate"] = None
        out["warnings"] = list(self.warnings)
        out["notes"] = list(self.notes)
        if not self.converged:
            out["reason"] = self.reason or "not converged"
        return out

    @classmethod
    def unsolvable(cls, scene: str, reason: str) -> Result:
        """The answer to a scene that could not be solved at all (an invalid scene, a bad
        option): not converged, nothing solved, ``reason`` saying why. What ``flexgen solve
        --json`` prints for bad input, as the contract asks of every scene that cannot be
        solved."""
        return cls(scene, False, False, 0, {}, {}, {}, reason=reason, error_estimate=math.inf)

    def to_json(self, indent: int | None = None) -> str:
        """The contract object as JSON (non-finite numbers become null)."""
        return json.dumps(_finite(self.contract()), indent=indent, allow_nan=False)

    def table(self) -> str:
        """A human-readable summary."""
        lines = [f"scene: {self.scene}"]
        if self.units is not None:
            lines.append("units: " + ", ".join(f"{k} {v}" for k, v in self.units.items()))
        if self.converged:
            lines.append(
                f"converged in {self.iterations} Newton iterations; "
                f"{'stable' if self.stable else 'UNSTABLE'} equilibrium"
            )
        else:
            lines.append(f"NOT converged after {self.iterations} Newton iterations: {self.reason}")
        for name, spec in self.model.items():
            detail = ", ".join(
                f"{k}={v:.2g}" if isinstance(v, float) else f"{k}={v}"
                for k, v in spec.items()
                if k != "kind"
            )
            qs = " ".join(f"{x:+.6g}" for x in self.q.get(name, []))
            coordinates = (
                "root loads [Fx Fy M0]"
                if spec.get("kind") == "exact"
                else "q (generalized coordinates)"
            )
            lines.append(
                f"  {name}: {spec.get('kind')}"
                + (f" ({detail})" if detail else "")
                + (f"  {coordinates} = [{qs}]" if qs else "")
            )
        unit = _unit_labels(self.units)
        if self.points:
            w = max(max(len(ref) for ref in self.points), len("point"))
            with_est = any(p.error_estimate is not None for p in self.points.values())
            length, compliance = f"[{unit['length']}]", f"[{unit['compliance']}]"
            cw = max(15, len(compliance) + 1)  # a compound unit may be wider than the numbers
            lw = max(12, len(length) + 1)
            lines.append(
                f"  {'point':<{w}}  {'x':>{lw}} {'y':>{lw}} {'angle':>10}  "
                f"{'C major':>{cw}} {'C minor':>{cw}} {'C angle':>10}"
                + (f"  {'est. pose':>9} {'est. C':>8}" if with_est else "")
            )
            lines.append(
                f"  {'':<{w}}  {length:>{lw}} {length:>{lw}} {'[rad]':>10}  "
                f"{compliance:>{cw}} {compliance:>{cw}} {'[rad]':>10}"
                + (f"  {'[rel.]':>9} {'[rel.]':>8}" if with_est else "")
            )
            for ref, p in self.points.items():
                e = p.ellipse
                pe = p.error_estimate
                lines.append(
                    f"  {ref:<{w}}  {p.pose[0]:>{lw}.6g} {p.pose[1]:>{lw}.6g} {p.pose[2]:>10.5f}  "
                    f"{e['major']:>{cw}.5g} {e['minor']:>{cw}.5g} {e['angle']:>10.5f}"
                    + (
                        f"  {pe['pose']:>9.2g} {pe['compliance']:>8.2g}"
                        if with_est and pe is not None
                        else ""
                    )
                )
            lines.append(
                "  (x, y, angle: the point's pose; C major, C minor: its compliance ellipse, the "
                "largest and smallest"
            )
            lines.append(
                "  displacement per unit force, C angle: the direction of the largest"
                + ("; est.: estimated errors, relative)" if with_est else ")")
            )
        lines += _flexure_lines(self.flexures, unit)
        if self.tolerance is not None or self.error_estimate is not None:
            est = math.inf if self.error_estimate is None else self.error_estimate
            lines.append(
                f"  error estimate {est:.2g}"
                + (f" (tolerance {self.tolerance:.2g})" if self.tolerance is not None else "")
                + " (pose relative to the flexure length to the point; compliance relative)"
            )
        for lam in self.critical_load_factors:
            lines.append(f"  critical load factor: {lam:.8g}")
        for msg in self.warnings:
            lines.append(f"  warning: {msg}")
        for msg in self.notes:
            lines.append(f"  note: {msg}")
        # one line per entry: a newline inside a name (or a message) is shown escaped, so that
        # no name can forge a line of the table (found by review: a flexure named with a
        # newline printed a fake "converged" line)
        return "\n".join(line.replace("\n", "\\n").replace("\r", "\\r") for line in lines)


class LazyResult(Result):
    """A Result whose bulky fields (``LAZY_FIELDS``: the models, q, the points, the stiffness,
    bends and kernels) are built from a copy of the answer's arrays on first access, so a
    prepared solver's loop pays only for what it reads. It is a Result in every other way:
    equal to a Result with the same values, pickled and copied as a plain Result."""

    __slots__ = ("_build",)
    _build: Callable[[str], Any]

    def __getattr__(self, name: str) -> Any:  # only for a slot not filled yet
        if name not in LAZY_FIELDS:
            raise AttributeError(name)
        value = self._build(name)
        setattr(self, name, value)
        return value

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Result):
            return NotImplemented
        return all(
            getattr(self, f.name) == getattr(other, f.name) for f in fields(Result) if f.compare
        )

    __hash__ = None  # type: ignore[assignment]  # mutable, as Result

    def __reduce__(self) -> tuple:
        return (Result, tuple(getattr(self, f.name) for f in fields(Result)))


LAZY_FIELDS = frozenset(
    {"model", "q", "points", "stiffness", "bend", "kernel", "flexures", "stability_margin"}
)


# a table's unit labels for a scene of plain numbers (any consistent set: named by quantity)
PLAIN_UNITS = {
    "length": "length",
    "compliance": "length/force",
    "curvature": "1/length",
    "stress": "force/length^2",
}


def _unit_labels(units: dict[str, str] | None) -> dict[str, str]:
    """The table's unit of each quantity: the scene's (a Result's ``units``), else its name."""
    return PLAIN_UNITS if units is None else {k: units.get(k, v) for k, v in PLAIN_UNITS.items()}


def _flexure_lines(flexures: dict[str, FlexureStress], unit: dict[str, str]) -> list[str]:
    """The table's flexure section: maxima, their relative error estimate, where, safety
    factor ("—" where unknown), with a row of units."""
    if not flexures:
        return []

    def num(v: float | None, fmt: str) -> str:
        return "—" if v is None or not math.isfinite(v) else format(v, fmt)

    w = max(max(len(n) for n in flexures), len("flexure"))
    stress, curvature = f"[{unit['stress']}]", f"[{unit['curvature']}]"
    sw, kw = max(16, len(stress) + 1), max(14, len(curvature) + 1)  # compound units: wider
    lines = [
        f"  {'flexure':<{w}}  {'max curvature':>{kw}} {'max strain':>11} {'max stress':>{sw}} "
        f"{'axial stress':>{sw}} {'est.':>8} {'at s/L':>7}  safety factor",
        f"  {'':<{w}}  {curvature:>{kw}} {'[-]':>11} {stress:>{sw}} "
        f"{stress:>{sw}} {'[rel.]':>8} {'[-]':>7}",
    ]
    for name, st in flexures.items():
        sf = st.safety_factor
        safety = (
            "—" if sf is None or math.isnan(sf) else "inf" if math.isinf(sf) else safety_text(sf)
        )
        if st.limited_by is not None:
            safety += f" ({st.limited_by})"
        # the relative error estimate of the three maxima ("—": none, as the exact model's)
        e = st.error_estimate
        estimate = "—" if e is None else "inf" if math.isinf(e) else format(e, ".2g")
        lines.append(
            f"  {name:<{w}}  {num(st.max_curvature, '.5g'):>{kw}} {num(st.max_strain, '.5g'):>11} "
            f"{num(st.max_stress, '.5g'):>{sw}} {num(st.max_axial_stress, '.5g'):>{sw}} "
            f"{estimate:>8} {st.at:>7.3f}  {safety}"
        )
    return lines


def _finite(obj):
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj


def _plain(value: Any) -> Any:
    """``value`` with every NumPy array and scalar inside it as Python lists and numbers."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return type(value)(_plain(v) for v in value)
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()
    return value
