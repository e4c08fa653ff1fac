"""The honesty suite: the mode selection (``flexgen.select``) measured against the exact elastica.

``honesty_suite(seed)`` is a seeded set of scenes (cantilevers under tip forces and moments of
several magnitudes and directions, two-flexure chains with links, chains driven by a tendon;
bends up to about 90 degrees); ``honesty_cases`` runs the selection on each of them for every
tolerance and measures the chosen models against ``models.exact.solve_exact`` (is the estimate an
upper bound of the true error? would one mode fewer have met T?); ``honesty_rates`` sums the
cases up per tolerance. Used by ``benchmarks/selection.py`` and tests/test_select.py; never by
the runtime.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from flexgen.scene import Scene, scene_from_dict
from flexgen.select import (
    error,
    estimate_table,
    length_scales,
    outputs_of,
    outputs_of_exact,
    select_from_table,
)


def honesty_suite(
    seed: int = 0,
    cantilevers: int = 8,
    chains: int = 3,
    tendons: int = 2,
    max_bend: float = math.radians(90.0),
) -> list[tuple[str, Scene]]:
    """A seeded set of scenes: cantilevers (tip force and/or moment, several magnitudes and
    directions, random length and EI), two-flexure chains joined by a link, and chains with a
    tendon; bends up to about ``max_bend`` (loads are drawn so that the estimated bend stays
    below it). -> [(label, Scene)]."""
    rng = np.random.default_rng(seed)
    out: list[tuple[str, Scene]] = []
    out += [cantilever(rng, k, max_bend, 0.2) for k in range(cantilevers)]
    for k in range(chains + tendons):
        L1, L2 = float(rng.uniform(0.5, 1.5)), float(rng.uniform(0.4, 1.2))
        EI1, EI2 = float(rng.uniform(0.5, 2.0)), float(rng.uniform(0.3, 1.5))
        gap = float(rng.uniform(0.2, 1.0))
        bend = float(rng.uniform(0.3, 1.0)) * max_bend
        d: dict[str, Any] = {
            "model": {"kind": "scm"},
            "base": {"points": {"r0": [-0.2, 0.1]}},
            "flexure": [
                {"name": "proximal", "length": L1, "EI": EI1, "parent": "base"},
                {
                    "name": "distal",
                    "length": L2,
                    "EI": EI2,
                    "parent": "middle",
                    "at": [gap, 0.0, float(rng.uniform(-0.3, 0.3))],
                },
            ],
            "link": [
                {
                    "name": "middle",
                    "parent": "proximal",
                    "points": {"pad": [0.5 * gap, -0.1], "hole": [0.05, 0.1]},
                },
                {
                    "name": "tip",
                    "parent": "distal",
                    "points": {"pad": [0.3, -0.05], "anchor": [0.05, 0.1]},
                },
            ],
            "output": {"points": ["middle.pad", "tip.pad"]},
        }
        Ltot = L1 + gap + L2
        if k < chains:
            ang = float(rng.uniform(-0.8, 0.8) * math.pi)
            P = _alpha_for_bend(bend, ang) * min(EI1, EI2) / Ltot**2
            d["name"] = f"chain {k}"
            d["load"] = [
                {
                    "point": "tip.pad",
                    "force": [P * math.cos(ang), P * math.sin(ang)],
                    "moment": float(rng.uniform(-0.3, 0.3)) * bend * EI2 / L2,
                }
            ]
        else:
            d["name"] = f"tendon {k - chains}"
            T = bend * min(EI1, EI2) / (0.1 * (L1 + L2)) * float(rng.uniform(0.3, 0.6))
            d["tendon"] = [{"tension": T, "route": ["base.r0", "middle.hole", "tip.anchor"]}]
            d["load"] = [{"point": "tip.pad", "force": [0.0, -0.2 * T * 0.1 / Ltot]}]
        out.append((d["name"], scene_from_dict(d)))
    return out


def cantilever(rng: np.random.Generator, k: int, max_bend: float, low: float) -> tuple[str, Scene]:
    """The k-th seeded cantilever of a suite: random length and EI, a tip force (directions away
    from the axial compressive one: no bifurcation), a tip moment or both (kind by k % 3), drawn
    so that the estimated bend is between ``low`` and 1 times ``max_bend``."""
    L = float(10 ** rng.uniform(-2, 0))
    EI = float(10 ** rng.uniform(-3, 0))
    kind = ("force", "moment", "both")[k % 3]
    bend = float(rng.uniform(low, 1.0)) * max_bend
    force, moment = [0.0, 0.0], 0.0
    if kind in ("force", "both"):
        ang = float(rng.uniform(-0.8, 0.8) * math.pi)
        alpha = _alpha_for_bend(bend * (0.6 if kind == "both" else 1.0), ang)
        force = [alpha * EI / L**2 * math.cos(ang), alpha * EI / L**2 * math.sin(ang)]
    if kind in ("moment", "both"):
        moment = (bend * (0.4 if kind == "both" else 1.0)) * EI / L * float(rng.choice([-1, 1]))
    d: dict[str, Any] = {
        "name": f"cantilever {k} ({kind})",
        "model": {"kind": "scm"},
        "flexure": [{"name": "beam", "length": L, "EI": EI}],
        "load": [{"point": "beam.tip", "force": force, "moment": moment}],
        "output": {"points": ["beam.tip"]},
    }
    return d["name"], scene_from_dict(d)


def _alpha_for_bend(bend: float, direction: float) -> float:
    """A load factor alpha = P L^2/EI that bends a cantilever's tip by about ``bend`` rad under a
    dead load at ``direction`` from its axis (linear estimate alpha |sin| / 2, made larger where
    the load pulls, so the bend stays near ``bend``)."""
    s = abs(math.sin(direction))
    return min(2.0 * bend / max(s, 0.25), 8.0)


@dataclass
class HonestyCase:
    label: str
    tol: float
    modes: tuple[int, ...]
    estimate: float
    true_error: float
    reached: bool
    cheapest: bool | None  # None: not checked (T not reached, or all flexures at 1 mode)


def honesty_cases(
    scenes: Sequence[tuple[str, Scene]],
    tols: Sequence[float] = (1e-2, 1e-4, 1e-6, 1e-8),
    progress=None,
) -> list[HonestyCase]:
    """Run the selection on every scene for every tolerance and measure it against the exact
    elastica: the true error of the chosen models, and whether one mode fewer on any flexure
    would also have met T (then the choice was not the cheapest)."""
    from flexgen.models.exact import solve_exact

    cases = []
    for label, scene in scenes:
        ex = outputs_of_exact(solve_exact(scene))
        if ex is None:
            continue
        table = estimate_table(scene)
        pb = table.problem
        scales = length_scales(scene, ex)
        for tol in tols:
            sel = select_from_table(table, tol)
            modes = tuple(sel.modes[n] for n in pb.names)
            true = error(outputs_of(sel.result), ex, scales)
            cheapest = None
            if sel.reached and any(n > 1 for n in modes):
                cheapest = True
                assert table.rich is not None  # reached: the table has a rich answer
                for k, n in enumerate(modes):
                    if n <= 1:
                        continue
                    fewer = tuple(m - (j == k) for j, m in enumerate(modes))
                    if any(pb.kernel_choice(j, m) is None for j, m in enumerate(fewer)):
                        continue
                    s = pb.solve(fewer, q0=table.rich.q)
                    if error(s.outputs, ex, scales) <= tol:
                        cheapest = False
            cases.append(
                HonestyCase(label, tol, modes, sel.error_estimate, true, sel.reached, cheapest)
            )
            if progress:
                progress(cases[-1])
    return cases


# What the exact reference resolves: a measured true error is the answer's error plus the
# reference's own, so an answer is within its estimate when the measured error is within the
# estimate plus this. The reference's compliance is by complex steps of the shooting map
# (models/exact.py): a tip moment's arc is within 4e-15 (one radian) to 3.2e-13 (two roll-ups) of
# the closed form, relative, and the honesty suites bend less than one roll-up. (It was 3e-9 while
# that compliance was central differences, which moved by 1e-9 to 2.4e-9 with their step.)
REFERENCE_NOISE = 1e-12


def true_over_estimate(true: float, estimate: float) -> float:
    """A measured error against its estimate: true / estimate, 0 for 0 / 0, inf for an error
    against an estimate of 0."""
    if estimate > 0:
        return true / estimate
    return 0.0 if true == 0 else math.inf


def point_within(pose_error: float, compliance_error: float, estimate: dict) -> bool:
    """Whether one output point's measured errors are within its ``error_estimate``
    ({"pose", "compliance"}): the pose error within the pose estimate, the compliance error
    within the compliance estimate plus the reference's own noise (``REFERENCE_NOISE``, which
    the compliance of the exact reference carries)."""
    return (
        pose_error <= estimate["pose"]
        and compliance_error <= estimate["compliance"] + REFERENCE_NOISE
    )


def honesty_rates(cases: Sequence[HonestyCase]) -> dict[float, dict[str, float]]:
    """Per tolerance: cases, covered (true <= estimate + the reference's own noise
    ``REFERENCE_NOISE``), worst true/estimate, reached, cheapest."""
    out = {}
    for tol in sorted({c.tol for c in cases}, reverse=True):
        cs = [c for c in cases if c.tol == tol]
        ratios = [true_over_estimate(c.true_error, c.estimate) for c in cs]
        checked = [c for c in cs if c.cheapest is not None]
        met = [c for c in cs if c.reached]
        out[tol] = {
            "cases": len(cs),
            "covered": sum(c.true_error <= c.estimate + REFERENCE_NOISE for c in cs) / len(cs),
            "worst_ratio": max(ratios),
            "reached": sum(c.reached for c in cs) / len(cs),
            "true_within_tol": (sum(c.true_error <= c.tol for c in met) / len(met)) if met else 1.0,
            "cheapest": (sum(bool(c.cheapest) for c in checked) / len(checked)) if checked else 1.0,
            "checked": len(checked),
            "mean_modes": float(np.mean([sum(c.modes) for c in cs])),
        }
    return out


__all__ = ["honesty_suite", "honesty_cases", "honesty_rates", "HonestyCase"]
