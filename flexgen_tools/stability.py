"""Where the models fail: load sweeps, what each answer states, and buckling loads.

``flexgen stability`` (``run_stability``) sweeps a dead load's magnitude alpha = P L^2/EI (up to
20) and direction (0-360 deg, 0 = along the undeformed axis, i.e. tension; 180 = axial
compression) on a cantilever and on the two-link finger, solves every grid point with every model
and with the exact elastica, and records per point: converged, kernel out of range, stable,
buckled (a critical load factor on the path), error against exact, and the answer's own error
estimate.

What an answer states
---------------------
Every chain-model answer states its error estimate per output point (``flexgen.estimate``:
its difference to a richer model, times a margin; ``Solver.solve(estimate=True)``, as
``flexgen.solve`` does) and carries the validity warnings of ``flexgen.validity`` wherever it is
past what the model may claim (prb past 64 deg or outside its tip-force case, a kernel past its
range, bent past 180 deg, stiffness within 5 % of singular), besides every warning of ``solve``
itself (an unstable equilibrium, an undefined compliance, an estimate that could not be made)
and ``converged = False``. Here ``solve_assessed`` solves with a prepared solver
(``flexgen.solver.Solver``) and calls ``validity.assess`` with the sweep's model label, as
``validity.check`` does for ``flexgen.solve``.

The rule (tested in tests/test_stability.py): **no answer is silently wrong** -- wherever an
answer's true error (against the exact elastica, per output point: pose and compliance, as the
estimate defines them) exceeds its stated estimate, the result is not converged or carries a
warning. The same honesty criterion as ``flexgen_tools.estimate_honesty``; nothing is
calibrated on this sweep. ``exact`` is the reference and is not assessed.

Buckling (``buckling_loads``): along an axial compressive load ramp the stiffness at the straight
state is K(P) = hess U - P hess x_tip(0) (linear in P), so the loads where its eigenvalues cross
zero are the generalized eigenvalues of (hess U, hess x_tip(0)). They are compared with
(2k - 1)^2 pi^2/4 for k = 1, 2, 3; the first is cross-checked against ``solve``'s
``critical_load_factors`` on an axial load past it.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flexgen.outfiles import write_all
from flexgen.scene import Scene, load_scene, scene_from_dict
from flexgen.validity import assess
from flexgen_tools.bench import (
    ModelDef,
    Progress,
    answer,
    compliance_error,
    examples_dir,
    format_error,
    model_def,
    model_defs,
    pose_parts,
)


def finger_file() -> Path:
    """examples/two_link_finger.toml (NeedsCheckout from an installed wheel)."""
    return examples_dir("flexgen stability") / "two_link_finger.toml"


# -- scenes ----------------------------------------------------------------------------------


def cantilever(alpha: float, direction_deg: float, L: float = 1.0, EI: float = 1.0) -> Scene:
    """A cantilever along +x with a dead tip force alpha EI/L^2 in direction ``direction_deg``."""
    P = alpha * EI / L**2
    d = math.radians(direction_deg)
    return scene_from_dict(
        {
            "name": f"cantilever a={alpha:g} d={direction_deg:g}",
            "flexure": [{"name": "beam", "length": L, "EI": EI}],
            "load": [{"point": "beam.tip", "force": [P * math.cos(d), P * math.sin(d)]}],
            "output": {"points": ["beam.tip"]},
        }
    )


_FINGER_CACHE: dict = {}


def finger(alpha: float, direction_deg: float) -> Scene:
    """The two-link finger (examples/two_link_finger.toml, tendon at its file tension) with its
    pad force replaced by alpha EI_p / (L_p r) in direction ``direction_deg`` (world frame), EI_p
    and L_p of the proximal flexure and r the distance from its root to the pad: alpha is then the
    nondimensional root moment the force would exert on the straight finger."""
    import tomllib

    if "raw" not in _FINGER_CACHE:
        path = finger_file()
        _FINGER_CACHE["raw"] = tomllib.loads(path.read_text())
        _FINGER_CACHE["scene"] = load_scene(path)
    raw, base = _FINGER_CACHE["raw"], _FINGER_CACHE["scene"]
    prox, dist = base.flexures[0], base.flexures[1]
    # the pad's lever arm about the proximal root on the straight finger: the proximal flexure,
    # the link to the distal joint, the distal flexure, the pad's offset on the fingertip
    pad_x = base.link("fingertip").points["pad"][0]
    r = prox.length + dist.at[0] + dist.length + pad_x
    P = alpha * prox.EI / (prox.length * r)
    d = math.radians(direction_deg)
    d2 = dict(raw)
    d2["name"] = f"finger a={alpha:g} d={direction_deg:g}"
    d2["load"] = [{"point": "fingertip.pad", "force": [P * math.cos(d), P * math.sin(d)]}]
    return scene_from_dict(d2, order=("flexure", "link", "flexure", "link"))


SCENES = {"cantilever": cantilever, "finger": finger}


# -- solve and assess ---------------------------------------------------------------------


def solve_assessed(scene: Scene, md: ModelDef):
    """A solve with fresh models (a prepared solver with its error estimate, no validity
    check), and assess() of the result with the model's label (None if not converged)."""
    from flexgen.solver import Solver

    models = md.models(scene)
    solver = Solver(scene, models)
    r = solver.solve(estimate=True)  # (its stability_margin: the core's, on first access)
    claim = assess(scene, r, models, md.label) if r.converged else None
    return r, claim


# -- the sweep -------------------------------------------------------------------------------


@dataclass
class Point:
    scene: str
    alpha: float
    direction: float
    model: str
    converged: bool
    stable: bool
    buckled: bool
    out_of_range: bool
    switched: bool
    warned: bool  # solve's warnings or assess's validity warnings
    pose_err: float  # true errors against exact: the largest over the output points
    comp_err: float
    estimate: float  # the answer's error_estimate (the largest over its points)
    ratio: float  # the largest true error / estimate over the points, pose and compliance
    beta: float
    reference: bool  # exact converged (stable, no snap) at this point
    margin: float = math.nan  # margin to a critical load (the core's fg_margin)

    @property
    def exceeds(self) -> bool:
        """The true error of some point's pose or compliance above its estimate."""
        return self.ratio > 1.0

    @property
    def silent(self) -> bool:
        """Wrong beyond its estimate, converged, and no warning: what must never happen."""
        return self.reference and self.converged and not self.warned and self.exceeds

    @property
    def category(self) -> str:
        if not self.reference:
            return "no reference"
        if not self.converged:
            return "not converged"
        if self.silent:
            return "SILENT"
        if self.warned:
            return "warned"
        return "within estimate"


def grid(quick: bool):
    if quick:
        return (1.0, 5.0, 20.0), (0.0, 90.0, 180.0, 225.0)
    return (
        (0.5, 1.0, 2.0, 3.0, 5.0, 8.0, 12.0, 20.0),
        tuple(float(d) for d in range(0, 360, 30)) + (165.0, 175.0, 195.0),
    )


def stability_models(quick: bool) -> list[ModelDef]:
    if quick:
        return [
            model_def(lab) for lab in ("cc", "prb", "scm3 poly", "scm3 gauss", "scm5 gauss", "fem8")
        ]
    defs = [md for md in model_defs() if md.kind != "exact"]
    defs += [ModelDef(f"scm{n} auto", "scm-auto", "scm", modes=n, kernel="auto") for n in (3, 5)]
    return defs


def sweep(
    scenes=("cantilever", "finger"),
    models: list[ModelDef] | None = None,
    alphas=None,
    directions=None,
    quick: bool = False,
    progress: bool = True,
) -> list[Point]:
    a_def, d_def = grid(quick)
    alphas = a_def if alphas is None else alphas
    directions = d_def if directions is None else directions
    models = stability_models(quick) if models is None else models
    exact = model_def("exact")
    pts: list[Point] = []
    bar = Progress(len(scenes) * len(alphas) * len(directions), "stability", enabled=progress)
    for sname in scenes:
        for a in alphas:
            for d in directions:
                scene = SCENES[sname](a, d)
                try:
                    ref = answer(scene, exact)
                    has_ref = (
                        ref.converged
                        and ref.stable
                        and not any(
                            "snap" in w or "stall" in w or "lost stability" in w
                            for w in ref.warnings
                        )
                    )
                except Exception:  # noqa: BLE001 - no reference at this point
                    ref, has_ref = None, False
                for md in models:
                    try:
                        r, claim = solve_assessed(scene, md)
                    except Exception as exc:  # noqa: BLE001 - a crash counts as not converged
                        print(
                            f"\n[stability] {md.label} {sname} a={a} d={d}: {exc}", file=sys.stderr
                        )
                        r, claim = None, None
                    conv = bool(r is not None and r.converged)
                    if conv and has_ref:
                        pe, ce, ratio = _errors_of(scene, r, ref)
                    else:
                        pe, ce, ratio = math.nan, math.nan, math.nan
                    pts.append(
                        Point(
                            sname,
                            a,
                            d,
                            md.label,
                            conv,
                            bool(r is not None and r.stable),
                            bool(r is not None and r.critical_load_factors),
                            bool(claim and claim.out_of_range),
                            bool(claim and claim.switched),
                            bool(r is not None and (r.warnings or (claim and claim.warnings))),
                            pe,
                            ce,
                            r.error_estimate if conv and r.error_estimate is not None else math.nan,
                            ratio,
                            claim.beta if claim else math.nan,
                            has_ref,
                            claim.margin if claim else math.nan,
                        )
                    )
                bar.step(f"{sname} a={a:g} d={d:g}")
    return pts


# The exact reference's own resolution: an error below it cannot be told from the reference's.
# Pose: the elastica is integrated to rtol 1e-13 (flexgen/models/exact.py); 1e-12 also covers
# rounding (an axially loaded fem answer is exact to 4e-16, with an estimate of 0).
# Compliance: the scene solver's compliance is from its shooting Jacobian by complex steps at
# polished root loads (no finite differences): a tip moment's arc agrees with the closed form to
# 1e-10 (tests/test_reference_models.py), the column below its Euler load to 1.7e-14 / margin.
# (With central differences it was 2e-8: 1.7e-8 off the variational compliance on this sweep's
# cantilever at 0.81 of the Euler load.)
REFERENCE_POSE = 1e-12
REFERENCE_COMPLIANCE = 1e-10


def _errors_of(scene: Scene, r, ref) -> tuple[float, float, float]:
    """(pose error, compliance error, largest true/estimate) of a converged answer against
    exact: per output point, the pose (position over the point's length scale, or angle) and
    the compliance (relative, spectral norm) errors, each against that point's estimate (an
    error within the reference's resolution, ``REFERENCE_POSE`` and ``REFERENCE_COMPLIANCE``,
    counts as no error: the reference cannot see it)."""
    from flexgen.estimate import length_scales

    scales = length_scales(scene, list(r.points))  # L_p, as the estimate scales positions
    pe = ce = ratio = 0.0
    for name, p in r.points.items():
        est = p.error_estimate or {"pose": math.nan, "compliance": math.nan}
        e_pose = max(pose_parts(p.pose, ref.poses[name], scales[name]))
        e_comp = compliance_error(p.compliance, ref.compliance[name])
        pe, ce = max(pe, e_pose), max(ce, e_comp)
        for true, stated, floor in (
            (e_pose, est["pose"], REFERENCE_POSE),
            (e_comp, est["compliance"], REFERENCE_COMPLIANCE),
        ):
            if true > floor:
                ratio = max(ratio, true / stated if stated > 0 else math.inf)
    return pe, ce, ratio


# -- buckling --------------------------------------------------------------------------------


def buckling_loads(modes: int, count: int = 3) -> np.ndarray:
    """First ``count`` critical axial loads (EI = L = 1) of scm ``modes``: the loads P where an
    eigenvalue of K(P) = hess U - P hess x_tip(0) crosses zero (generalized eigenvalues)."""
    import scipy.linalg

    from flexgen.models.scm import SCMModel

    m = SCMModel(1.0, 1.0, modes, "gauss")  # the tighter Hessian bound (every N ships one)
    q0 = np.zeros(modes)
    A = m.energy_hessian(q0)
    B = -m.tip(q0).H[0]  # -hess x_tip: positive definite
    w = scipy.linalg.eigh(A, 0.5 * (B + B.T), eigvals_only=True)
    w = np.sort(w[w > 0])
    out = np.full(count, np.nan)
    out[: min(count, len(w))] = w[:count]
    return out


def euler(k: int) -> float:
    return (2 * k - 1) ** 2 * math.pi**2 / 4


def buckling_table(modes=range(3, 9)) -> list[dict]:
    """Per N: the three critical loads, their relative errors, and solve's first critical load
    along an axial ramp to 1.2 x the first (cross-check)."""
    from flexgen.models.scm import SCMModel
    from flexgen.solver import solve_models

    rows = []
    for n in modes:
        P = buckling_loads(n)
        rel = [
            abs(P[k] - euler(k + 1)) / euler(k + 1) if math.isfinite(P[k]) else math.nan
            for k in range(3)
        ]
        kernel = "gauss" if n <= 6 else "poly"
        ramp = 1.2 * euler(1)
        scene = cantilever(ramp, 180.0)
        r = solve_models(scene, {"beam": SCMModel(1.0, 1.0, n, kernel, name="beam")})
        solve_first = r.critical_load_factors[0] * ramp if r.critical_load_factors else math.nan
        rows.append(
            {
                "modes": n,
                "loads": P.tolist(),
                "rel": rel,
                "solve_first": solve_first,
                "solve_rel": abs(solve_first - euler(1)) / euler(1),
            }
        )
    return rows


# -- run and outputs -------------------------------------------------------------------------


@dataclass
class StabilityData:
    quick: bool
    points: list
    buckling: list
    models: list
    elapsed: float = 0.0


def run_stability(
    quick: bool = False, out: Path | str | None = None, progress: bool = True
) -> StabilityData:
    t0 = time.perf_counter()
    finger_file()  # NeedsCheckout before any output
    models = stability_models(quick)
    pts = sweep(models=models, quick=quick, progress=progress)
    buck = buckling_table(range(3, 9) if not quick else (3, 5))
    data = StabilityData(quick, pts, buck, [md.label for md in models], time.perf_counter() - t0)
    if out is not None:
        write_outputs(data, Path(out))
    return data


CAT_COLORS = {
    "within estimate": "tab:green",
    "warned": "tab:orange",
    "not converged": "0.6",
    "SILENT": "red",
    "no reference": "white",
}


def plot(data: StabilityData, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = list(dict.fromkeys(p.scene for p in data.points))
    panels = [(m, s) for m in data.models for s in scenes]
    ncol = 6
    nrow = math.ceil(len(panels) / ncol)
    fig = plt.figure(figsize=(2.6 * ncol, 2.8 * nrow))
    amax = max(p.alpha for p in data.points)
    for i, (m, s) in enumerate(panels):
        ax = fig.add_subplot(nrow, ncol, i + 1, projection="polar")
        sel = [p for p in data.points if p.model == m and p.scene == s]
        for cat, color in CAT_COLORS.items():
            cp = [p for p in sel if p.category == cat]
            if not cp:
                continue
            ax.scatter(
                [math.radians(p.direction) for p in cp],
                [math.sqrt(p.alpha / amax) for p in cp],
                s=14,
                c=color,
                edgecolors="k",
                linewidths=0.3,
                marker="X" if cat == "SILENT" else "o",
                zorder=3,
            )
        bk = [p for p in sel if p.buckled]
        if bk:
            ax.scatter(
                [math.radians(p.direction) for p in bk],
                [math.sqrt(p.alpha / amax) for p in bk],
                s=40,
                facecolors="none",
                edgecolors="purple",
                linewidths=0.8,
                zorder=4,
            )
        ax.set_ylim(0, 1.05)
        ax.set_yticks([math.sqrt(a / amax) for a in (1, 5, 20) if a <= amax])
        ax.set_yticklabels([])
        ax.set_xticklabels([])
        ax.set_title(f"{m} / {s}", fontsize=8)
    handles = [
        plt.Line2D(
            [],
            [],
            marker="X" if c == "SILENT" else "o",
            ls="",
            color=col,
            markeredgecolor="k",
            label=c,
        )
        for c, col in CAT_COLORS.items()
    ]
    handles.append(
        plt.Line2D(
            [],
            [],
            marker="o",
            ls="",
            markerfacecolor="none",
            markeredgecolor="purple",
            label="buckled (critical load on path)",
        )
    )
    fig.legend(handles=handles, loc="lower center", ncol=6, fontsize=9)
    fig.suptitle(
        "flexgen stability: load direction (angle, 0 = tension along the axis, 180 = "
        "axial compression) and magnitude (radius ~ sqrt(alpha), rings at 1, 5, 20)",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0.04, 1, 0.97))
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _ratio(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:.2f}"


def model_table(data: StabilityData) -> list[dict]:
    rows = []
    scenes = list(dict.fromkeys(p.scene for p in data.points))
    for m in data.models:
        for s in scenes:
            sel = [p for p in data.points if p.model == m and p.scene == s]
            ref = [p for p in sel if p.reference]
            conv = [p for p in ref if p.converged]
            quiet = [p for p in conv if not p.warned]
            ratio = max((p.ratio for p in quiet), default=math.nan)
            rows.append(
                {
                    "model": m,
                    "scene": s,
                    "points": len(sel),
                    "reference": len(ref),
                    "converged": sum(p.converged for p in sel),
                    "stable": sum(p.converged and p.stable for p in sel),
                    "buckled": sum(p.buckled for p in sel),
                    "out_of_range": sum(p.out_of_range for p in sel),
                    "switched": sum(p.switched for p in sel),
                    "warned": sum(p.converged and p.warned for p in sel),
                    "within": sum(p.category == "within estimate" for p in sel),
                    "silent": sum(p.silent for p in sel),
                    "worst_quiet_ratio": ratio,
                    "max_pose_quiet": max((p.pose_err for p in quiet), default=math.nan),
                    "max_pose_warned": max(
                        (p.pose_err for p in conv if p.warned), default=math.nan
                    ),
                }
            )
    return rows


def render_markdown(data: StabilityData) -> str:
    a, d = grid(data.quick)
    silent = [p for p in data.points if p.silent]
    L = [
        "# Where the models fail",
        "",
        f"Generated by `flexgen stability{' --quick' if data.quick else ''}` in "
        f"{data.elapsed:.0f} s; every number below comes from that run (rerun with "
        f"{'that command' if data.quick else '`make bench-models`'}).",
        "",
        "![stability map](stability-map.png)",
        "",
        "## Sweep",
        "",
        f"Two scenes: a cantilever (EI = L = 1) with a dead tip force alpha EI/L^2, and the "
        "two-link finger (`examples/two_link_finger.toml`, tendon at 10 N) with its pad force "
        "replaced by alpha EI_p/(L_p r) (proximal flexure; r = 95 mm, the pad's lever arm "
        "about the proximal root on the straight finger: alpha is the nondimensional root moment). alpha in "
        f"{', '.join(f'{x:g}' for x in a)}; direction (world frame, 0 = along the undeformed "
        f"axis, i.e. tension; 180 = axial compression) in {', '.join(f'{x:g}' for x in d)} deg. "
        "Every point is solved by every model (load continuation from the unloaded state) and "
        "by the exact elastica; points where the exact solver does not converge or reports a "
        "snap or loss of stability have no reference.",
        "",
        "## What each answer states",
        "",
        "Every chain-model answer states its own error estimate per output point "
        "(`flexgen/estimate.py`, docs/solve.md): its pose error (position relative to the "
        "length of the flexures between the base and the point, or angle) and its compliance "
        "error (relative, spectral norm), measured as the difference to a richer model (scm N "
        "against N + 2, cc and prb against scm3, fem n against 2n) times a margin, plus the "
        "kernels' certified bounds. Nothing is calibrated on this sweep. Besides, a warning "
        "wherever the answer is past the model's validity (`flexgen/validity.py`): prb past 64 "
        "deg or outside its one-flexure tip-force case, a polynomial kernel past 90 deg, a "
        "Gauss kernel past 180 deg, any model bent past 180 deg, the stiffness within 5 % of "
        "singular (margin = smallest generalized eigenvalue of K against the elastic Hessian, "
        "1 - P/P_cr on an axial load); and every warning of `solve` itself (unstable, an "
        "undefined compliance, an estimate that could not be made; buckling, snap-through and "
        "a switch to a certified kernel are notes, not warnings). The sweep solves each point "
        "as `flexgen.solve` does (a prepared solver with its estimate, then `validity.assess`). "
        "The test sweep (tests/test_stability.py) uses loads and directions off this grid.",
        "",
        "## The rule: no answer is silently wrong",
        "",
        (
            f"**{len(silent)} silent failures** (true error above the stated estimate at some "
            "output point, converged, no warning)."
            if silent
            else "**No silent failure** on this grid: wherever an answer's true error (against "
            "the exact elastica, per output point, pose and compliance) exceeds its stated "
            "estimate, the result is not converged or carries a warning. The estimate is an "
            "estimate, not a bound: off this grid, the random scenes of "
            "[accuracy-vs-speed.md](accuracy-vs-speed.md) find a few answers past their "
            "estimates without a warning (its honesty table: the share covered and the worst "
            "true/estimate)."
        ),
        "",
        f"An error within the reference's own resolution is not judged: pose "
        f"{REFERENCE_POSE:.0e} (the elastica is integrated to rtol 1e-13), compliance "
        f"{REFERENCE_COMPLIANCE:.0e} (the exact scene solver's compliance is from its "
        "shooting Jacobian by complex steps: a tip moment's arc agrees with the closed form to "
        "1e-10).",
        "",
    ]
    for p in silent[:20]:
        L.append(
            f"- {p.model} / {p.scene} alpha={p.alpha:g} dir={p.direction:g}: pose error "
            f"{format_error(p.pose_err)}, compliance error {format_error(p.comp_err)}, "
            f"estimate {format_error(p.estimate)} (true/estimate {p.ratio:.2f})"
        )
    L += [
        "",
        "## Per model and scene",
        "",
        "Counts over the grid points. `warned`: converged with a warning (solve's or a "
        "validity warning); `out of range`: a kernel past its range; `switched`: an auto "
        "kernel moved to Gauss; `buckled`: a critical load on the path; `worst quiet ratio`: "
        "the largest true error / estimate (per output point, pose and compliance) among "
        "converged points without a warning (<= 1 is the rule).",
        "",
        "| model | scene | points | with reference | converged | stable | buckled | "
        "out of range | switched | warned | within estimate | SILENT | worst quiet ratio | "
        "max pose err (quiet) | max pose err (warned) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in model_table(data):
        L.append(
            f"| {r['model']} | {r['scene']} | {r['points']} | {r['reference']} | "
            f"{r['converged']} | {r['stable']} | {r['buckled']} | {r['out_of_range']} | "
            f"{r['switched']} | {r['warned']} | {r['within']} | {r['silent']} | "
            f"{_ratio(r['worst_quiet_ratio'])} | "
            f"{format_error(r['max_pose_quiet'])} | {format_error(r['max_pose_warned'])} |"
        )
    L += [
        "",
        "## Buckling: critical axial loads of scm N",
        "",
        "Stiffness at the straight state under an axial compressive tip load P (EI = L = 1): "
        "K(P) = hess U - P hess x_tip(0); the loads where its eigenvalues cross zero are the "
        "generalized eigenvalues of (hess U, -hess x_tip(0)) (the Gauss kernels, exact at "
        "q = 0). Exact: (2k - 1)^2 pi^2/4 = "
        f"{euler(1):.7f}, {euler(2):.5f}, {euler(3):.5f}. The last column is `solve`'s first "
        "critical load factor on an axial ramp to 1.2 x the Euler load (bisection on the "
        "smallest eigenvalue along the path).",
        "",
        "| N | P1 | rel. error | P2 | rel. error | P3 | rel. error | solve: P1 (rel. error) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in data.buckling:
        P, rel = r["loads"], r["rel"]
        row = " | ".join(
            f"{P[k]:.8g} | {format_error(rel[k])}" if math.isfinite(P[k]) else "- | -"
            for k in range(3)
        )
        L.append(
            f"| {r['modes']} | {row} | {r['solve_first']:.9g} ({format_error(r['solve_rel'])}) |"
        )
    L += ["", _convergence_sentence(data.buckling), ""]
    return "\n".join(L)


def _convergence_sentence(rows: list[dict]) -> str:
    """How the third critical load converges, from the rows shown (review: a --quick page,
    N = 3 and 5 only, quoted N = 6 from the full run's)."""

    def first_within(limit: float) -> str:
        n = next((r["modes"] for r in rows if r["rel"][2] < limit), None)
        return f"from N = {n}" if n is not None else f"at no N shown (N <= {rows[-1]['modes']})"

    if not rows:
        return ""
    first = next((r for r in rows if r["modes"] == 5), rows[-1])
    return (
        f"Each further load needs more modes: the third is within 3 % {first_within(0.03)} "
        f"and 0.3 % {first_within(0.003)}; the first is spectrally accurate "
        f"({format_error(first['rel'][0])} for N = {first['modes']}; model-notes: 8.6e-9 for "
        "N = 5)."
    )


# the files write_outputs writes into --out (the command checks them before the run)
PAGES = ("stability-map.png", "stability.md")


def write_outputs(data: StabilityData, out: Path) -> tuple[Path, Path]:
    png, md = (out / name for name in PAGES)
    text = render_markdown(data)

    def write_page(tmp: Path) -> None:
        tmp.write_text(text)

    write_all([(png, lambda tmp: plot(data, tmp)), (md, write_page)])
    return png, md
