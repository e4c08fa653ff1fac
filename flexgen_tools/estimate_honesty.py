"""Is every answer's error estimate honest? Chain models against the exact elastica.

``estimate_scenes(seed)`` is a seeded set of scenes: the examples, single cantilevers under a tip
force, a tip moment or both at several magnitudes (bends up to about 150 degrees, so past the
polynomial kernels' range too), random two- and three-flexure chains (links, tip force and
moment, some driven by a tendon) and trees with an unloaded branch. ``estimate_cases`` solves
each with every chain model in ``MODELS`` through ``flexgen.solve`` (which gives every answer its
``error_estimate``) and measures the true error against ``flexgen.solve(scene, model="exact")``,
per output point, the same way (``select.error_components``: position / L_p, angle, relative
spectral norm of the compliance). ``estimate_rates`` sums them up: coverage (true <= estimate;
for the compliance, within the estimate plus the exact reference's own noise,
``honesty.REFERENCE_NOISE``, as the selection's honesty counts it), the worst true/estimate, and
the answers more than 10x above their estimate (in errors the reference resolves) without a
warning. Used by tests/test_estimate.py and benchmarks/estimate.py; never by the runtime.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from flexgen.scene import Scene, load_scene, scene_from_dict

from . import repo_path
from .honesty import (
    REFERENCE_NOISE,
    _alpha_for_bend,
    cantilever,
    honesty_suite,
    point_within,
    true_over_estimate,
)

# (label, flexgen.solve keyword arguments)
MODELS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("cc", {"model": "cc"}),
    ("prb", {"model": "prb"}),
    ("scm2", {"model": "scm", "modes": 2}),
    ("scm3", {"model": "scm", "modes": 3}),
    ("scm4", {"model": "scm", "modes": 4}),
    ("scm5", {"model": "scm", "modes": 5}),
    ("scm6", {"model": "scm", "modes": 6}),
    ("scm7", {"model": "scm", "modes": 7}),
    ("scm8", {"model": "scm", "modes": 8}),
    ("fem4", {"model": "fem", "elements": 4}),
    ("fem16", {"model": "fem", "elements": 16}),
    ("fem32", {"model": "fem", "elements": 32}),
)


def _examples() -> list[tuple[str, Scene]]:
    folder = repo_path("examples/", "the estimate honesty suite")
    return [(p.stem, load_scene(p)) for p in sorted(folder.glob("*.toml"))]


def _three_link(rng: np.random.Generator, k: int) -> tuple[str, Scene]:
    flex, links, outputs = [], [], []
    parent = "base"
    Ltot = 0.0
    for j in range(3):
        L, EI = float(rng.uniform(0.3, 1.0)), float(rng.uniform(0.5, 2.0))
        gap = float(rng.uniform(0.1, 0.5))
        at = [0.0, 0.0, 0.0] if j == 0 else [gap, 0.0, float(rng.uniform(-0.4, 0.4))]
        flex.append({"name": f"f{j}", "length": L, "EI": EI, "parent": parent, "at": at})
        links.append({"name": f"l{j}", "parent": f"f{j}", "points": {"p": [gap, 0.05]}})
        outputs.append(f"l{j}.p")
        parent = f"l{j}"
        Ltot += L + gap
    ang = float(rng.uniform(-0.8, 0.8) * math.pi)
    P = _alpha_for_bend(float(rng.uniform(0.2, 1.0)) * math.radians(100), ang) * 0.5 / Ltot**2
    d: dict[str, Any] = {
        "name": f"three-link chain {k}",
        "flexure": flex,
        "link": links,
        "load": [
            {
                "point": outputs[-1],
                "force": [P * math.cos(ang), P * math.sin(ang)],
                "moment": float(rng.uniform(-0.3, 0.3)),
            }
        ],
        "output": {"points": outputs},
    }
    return d["name"], scene_from_dict(d)


def _tree(rng: np.random.Generator, k: int) -> tuple[str, Scene]:
    """Two branches on the base: a loaded one (a flexure, a link, a second flexure; a force and
    a moment at its tip, or a tendon along it) and an unloaded one (a flexure and a link), whose
    points every model places exactly (their estimate is the answer's rounding alone)."""
    L = [float(v) for v in rng.uniform(0.5, 1.2, 3)]
    EI = [float(v) for v in rng.uniform(0.5, 2.0, 3)]
    gap = float(rng.uniform(0.1, 0.4))
    flex = [
        {
            "name": "a0",
            "parent": "base",
            "length": L[0],
            "EI": EI[0],
            "at": [0.0, 0.0, float(rng.uniform(-0.5, 0.5))],
        },
        {"name": "a1", "length": L[1], "EI": EI[1], "parent": "la", "at": [gap, 0.0, 0.2]},
        {
            "name": "b0",
            "parent": "base",
            "length": L[2],
            "EI": EI[2],
            "at": [0.0, 0.2, float(rng.uniform(0.5, 1.5))],
        },
    ]
    links = [
        {"name": "la", "parent": "a0", "points": {"hole": [gap / 2, 0.05]}},
        {"name": "lb", "parent": "b0", "points": {"pad": [0.2, 0.05]}},
    ]
    total = L[0] + gap + L[1]
    d: dict[str, Any] = {
        "name": f"tree {k}",
        "base": {"points": {"r0": [-0.2, 0.1]}},
        "flexure": flex,
        "link": links,
        "output": {"points": ["la.hole", "a1.tip", "lb.pad"]},
    }
    if k % 2 == 0:
        ang = float(rng.uniform(-0.8, 0.8) * math.pi)
        P = _alpha_for_bend(float(rng.uniform(0.2, 0.8)) * math.radians(90), ang) * 0.5 / total**2
        d["load"] = [
            {
                "point": "a1.tip",
                "force": [P * math.cos(ang), P * math.sin(ang)],
                "moment": float(rng.uniform(-0.3, 0.3)),
            }
        ]
    else:
        d["tendon"] = [
            {"tension": float(rng.uniform(0.5, 1.5)), "route": ["base.r0", "la.hole", "a1.tip"]}
        ]
    return d["name"], scene_from_dict(d)


def estimate_scenes(
    seed: int = 0,
    cantilevers: int = 9,
    chains: int = 2,
    tendons: int = 1,
    three: int = 2,
    trees: int = 2,
) -> list[tuple[str, Scene]]:
    """The examples, ``cantilevers`` single cantilevers (tip force, moment or both, bends up to
    about 150 deg), two-flexure chains (``honesty_suite``'s, bends up to about 120 deg, with and
    without a tendon), ``three`` three-flexure chains and ``trees`` trees with an unloaded
    branch; seeded. -> [(label, Scene)]."""
    rng = np.random.default_rng(seed)
    out = _examples() + [cantilever(rng, k, math.radians(150), 0.05) for k in range(cantilevers)]
    two = honesty_suite(
        seed, cantilevers=0, chains=chains, tendons=tendons, max_bend=math.radians(120)
    )
    out += [(f"{label} (seed {seed})", sc) for label, sc in two]
    out += [_three_link(rng, k) for k in range(three)]
    out += [(f"{label} (seed {seed})", sc) for label, sc in (_tree(rng, k) for k in range(trees))]
    return out


@dataclass
class EstimateCase:
    scene: str
    model: str
    estimate: float  # the answer's error_estimate
    true_error: float  # against the exact elastica, measured the same way
    ratio: float  # largest true/estimate over the points and components
    warned: bool  # the answer has a warning
    # every point's pose error <= its estimate, and its compliance error <= its estimate plus
    # the exact reference's own noise (REFERENCE_NOISE)
    covered: bool
    # ratio over the components whose true error the reference resolves (above its noise)
    resolved_ratio: float
    # the flexures' largest |curvature| (so strain and stress) against their error estimates:
    # every one within its estimate plus the reference's noise, and the largest true/estimate
    curvature_covered: bool = True
    curvature_ratio: float = 0.0


def estimate_cases(
    scenes: Sequence[tuple[str, Scene]],
    models: Sequence[tuple[str, dict[str, Any]]] = MODELS,
    progress=None,
) -> list[EstimateCase]:
    """Every scene with every model: the estimate against the exact elastica's true error."""
    import flexgen
    from flexgen.select import error_components, length_scales, outputs_of

    cases = []
    for label, scene in scenes:
        exact = flexgen.solve(scene, model="exact")
        ex = outputs_of(exact)
        if ex is None:
            continue
        scales = length_scales(scene, ex)
        for mlabel, kw in models:
            res = flexgen.solve(scene, **kw)
            got = outputs_of(res)
            if got is None or res.error_estimate is None:
                continue
            comps = error_components(got, ex, scales).reshape(-1, 3)
            ratio, resolved, covered = 0.0, 0.0, True
            for (dpos, dth, dC), p in zip(comps, res.points.values()):
                e = p.error_estimate
                assert e is not None
                covered = covered and point_within(max(dpos, dth), dC, e)
                for true, est, noise in (
                    (max(dpos, dth), e["pose"], 0.0),
                    (dC, e["compliance"], REFERENCE_NOISE),
                ):
                    r = true_over_estimate(true, est)
                    ratio = max(ratio, r)
                    if true > noise:  # the reference resolves it
                        resolved = max(resolved, r)
            true = float(comps.max()) if comps.size else 0.0
            kappa_covered, kappa_ratio = curvature_honesty(res, exact)
            case = EstimateCase(
                label,
                mlabel,
                res.error_estimate,
                true,
                ratio,
                bool(res.warnings),
                covered,
                resolved,
                kappa_covered,
                kappa_ratio,
            )
            cases.append(case)
            if progress:
                progress(case)
    return cases


def curvature_honesty(res: Any, exact: Any) -> tuple[bool, float]:
    """(every flexure's max |curvature| within its error estimate plus the reference's noise,
    the largest true/estimate) of an answer against the exact elastica's. The true error is
    relative to the larger of the two maxima (an unloaded flexure: both 0, no error)."""
    covered, worst = True, 0.0
    for name, st in res.flexures.items():
        ref = exact.flexures.get(name)
        if ref is None or st.error_estimate is None:
            continue
        peak = max(st.max_curvature, ref.max_curvature)
        true = abs(st.max_curvature - ref.max_curvature) / peak if peak > 0.0 else 0.0
        covered = covered and true <= st.error_estimate + REFERENCE_NOISE
        worst = max(worst, true_over_estimate(true, st.error_estimate))
    return covered, worst


def estimate_rates(cases: Sequence[EstimateCase]) -> dict[str, Any]:
    """Coverage per answer (every point's true pose and compliance error <= its estimate, the
    compliance's plus the reference's noise: ``EstimateCase.covered``), coverage of the whole
    answer (true error <= error_estimate + the noise), the worst ratio (raw, and over the errors
    the reference resolves), and the answers above 10x their estimate, in the errors the
    reference resolves, with and without a warning."""
    n = len(cases)
    whole = [c.true_error <= c.estimate + REFERENCE_NOISE for c in cases]
    return {
        "answers": n,
        "covered": sum(c.covered for c in cases) / n if n else 1.0,
        "covered_whole": sum(whole) / n if n else 1.0,
        "worst_ratio": max((c.ratio for c in cases), default=0.0),
        "worst": max(cases, key=lambda c: c.ratio) if cases else None,
        "worst_resolved_ratio": max((c.resolved_ratio for c in cases), default=0.0),
        "above_10x_unwarned": [c for c in cases if c.resolved_ratio > 10 and not c.warned],
        "above_10x_warned": [c for c in cases if c.resolved_ratio > 10 and c.warned],
        "curvature_covered": sum(c.curvature_covered for c in cases) / n if n else 1.0,
        "worst_curvature_ratio": max((c.curvature_ratio for c in cases), default=0.0),
        "worst_curvature": max(cases, key=lambda c: c.curvature_ratio) if cases else None,
    }
