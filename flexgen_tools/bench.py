"""Accuracy against speed of every flexure model on a fixed suite of scenes.

``flexgen bench`` (``run_bench``) solves every scene of the suite -- the examples plus a seeded set
of random chains and trees (1-4 flexures, forces, moments, tendons, bends up to 90 degrees) --
with every model and compares each answer with the exact elastica (``models.exact.solve_exact``):

* pose error of every output point: max(|position error| / L_p, |angle error|), L_p the total
  flexure length between the base and the point (so a single cantilever's error is relative to
  its length);
* compliance error of every output point: ||C - C_exact||_2 / ||C_exact||_2 (2x2 position block);
* time per solve (equilibrium + compliance of the output points) of the one solver, the C core,
  three ways (``flexgen_tools.timing``): (a) ``flexgen.solve(scene)`` through the public API (the
  same Scene object every call, so its prepared solver comes from the cache; error estimate and
  validity check included), (b) a prepared ``flexgen.Solver``'s ``solve()`` (the core call, the Result and the validity
  screen), (c)
  the bare core call ``core.lib.fg_solve`` on that solver's problem and workspace. (a)/(c) is
  what the Python API costs on top of the computation, (b)-(c) the overhead of the Result;
  ``exact`` is ``solve_exact`` (Python and SciPy) in every column;
* kernel evaluations per solve (``fg_answer.evaluations``), where the core counts them;
* ns per kernel call in C for the scm kernels, from ``benchmarks/kernels.py``'s harness.

A scene's error is the largest over its output points; a model's error is the median over the
suite (the table also gives the worst scene). Everything is measured in one run. The functions are
importable; tests/test_bench.py runs ``run_bench(quick=True)``. The suite needs ``examples/`` of a
source checkout (``NeedsCheckout`` otherwise).
"""

from __future__ import annotations

import importlib.util
import math
import os
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from flexgen.estimate import length_scales
from flexgen.outfiles import write_all
from flexgen.scene import Scene, load_scene, scene_from_dict
from flexgen.select import compliance_error, pose_parts  # noqa: F401  (stability imports it)
from flexgen_tools import repo_path
from flexgen_tools.timing import (  # noqa: F401
    core_call,
    evaluations,
    time_call,
    time_fast,
    time_interleaved,
    with_model,
)

SEED = 20240917
SMOOTH_SCENE = "cantilever_tip_load"  # the smooth case of the equal-accuracy comparison,
# and the one flexure under a tip force
FINGER_SCENE = "two_link_finger"
TARGET_ERROR = 1e-4  # equal-accuracy comparison of scm and fem


def examples_dir(what: str = "flexgen bench") -> Path:
    """examples/ of the source checkout (NeedsCheckout, one line, from an installed wheel)."""
    return repo_path("examples/", what)


# -- models ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelDef:
    label: str  # "scm3 poly", "fem16", "exact" ...
    family: str  # "cc", "prb", "scm-poly", "scm-gauss", "scm-local", "fem", "exact"
    kind: str  # model kind (scene.MODEL_KINDS)
    modes: int = 0
    elements: int = 0
    kernel: str = "auto"

    def scene(self, scene: Scene) -> Scene:
        """``scene`` with this model for every flexure (a new Scene object)."""
        if self.kind in ("scm", "cc"):
            return with_model(scene, self.kind, modes=self.modes, kernel=self.kernel)
        if self.kind == "fem":
            return with_model(scene, "fem", elements=self.elements)
        return with_model(scene, self.kind)

    def models(self, scene: Scene) -> dict:
        """{flexure: FlexureModel} of this model on ``scene`` (not for exact)."""
        if self.kind == "exact":
            raise ValueError(f"no chain model for {self.label}")
        from flexgen.models.registry import build_models

        return build_models(self.scene(scene))

    @property
    def c_kernel(self) -> str | None:
        """Name of the generated C kernel this model calls, if any."""
        if self.kind not in ("scm", "cc"):
            return None
        from flexgen import kernels

        # "auto" (cc) evaluates its polynomial kernel while in range
        return kernels.kernel_name(self.modes, "poly" if self.kernel == "auto" else self.kernel)


def model_defs(quick: bool = False) -> list[ModelDef]:
    """cc, prb, scm2..6 with the poly, the gauss and the local kernel, fem 4..64, exact (quick: a
    subset)."""
    defs = [ModelDef("cc", "cc", "cc", modes=1, kernel="auto"), ModelDef("prb", "prb", "prb")]
    modes = (2, 3, 4, 5) if quick else (2, 3, 4, 5, 6)
    defs += [
        ModelDef(f"scm{n} poly", "scm-poly", "scm", modes=n, kernel="poly")
        for n in ((3,) if quick else modes)
    ]
    defs += [ModelDef(f"scm{n} gauss", "scm-gauss", "scm", modes=n, kernel="gauss") for n in modes]
    defs += [ModelDef(f"scm{n} local", "scm-local", "scm", modes=n, kernel="local") for n in modes]
    defs += [
        ModelDef(f"fem{e}", "fem", "fem", elements=e)
        for e in ((4, 8, 16) if quick else (4, 8, 16, 32, 64))
    ]
    defs.append(ModelDef("exact", "exact", "exact"))
    return defs


def model_def(label: str) -> ModelDef:
    for d in model_defs():
        if d.label == label:
            return d
    raise KeyError(label)


# -- the suite -------------------------------------------------------------------------------


def example_scenes() -> list[tuple[str, Scene]]:
    return [(p.stem, load_scene(p)) for p in sorted(examples_dir().glob("*.toml"))]


def max_bend(result, scene: Scene) -> float:
    """Largest |phi(sigma)| (angle relative to the root frame) over the flexures of a solved
    result, in rad: the core's ``Result.bend``."""
    return max(result.bend[f.name] for f in scene.flexures)


def _random_layout(rng: np.random.Generator, index: int) -> dict:
    """A random chain or tree of 1-4 flexures with rigid links, unscaled loads and tendons."""
    n = int(rng.integers(1, 5))
    tree = n >= 3 and rng.random() < 0.5
    flexures: list[dict[str, Any]] = []
    links: list[dict[str, Any]] = []
    children: dict[str, int] = {}
    for i in range(n):
        L, EI = float(rng.uniform(0.6, 1.4)), float(rng.uniform(0.5, 2.0))
        if i == 0:
            parent, at = "base", [0.0, 0.0, float(rng.uniform(-0.3, 0.3))]
        else:
            if tree and i >= 2:
                parent = f"m{int(rng.integers(0, i))}"
            else:
                parent = f"m{i - 1}"
            rigid = links[int(parent[1:])]["points"]["end"][0]
            side = float(rng.choice([-1.0, 1.0])) * (0.08 if tree and children.get(parent) else 0.0)
            at = [rigid, side, float(rng.uniform(-0.5, 0.5))]
        children[parent] = children.get(parent, 0) + 1
        flexures.append({"name": f"f{i}", "parent": parent, "at": at, "length": L, "EI": EI})
        rigid = float(rng.uniform(0.1, 0.6))
        links.append(
            {
                "name": f"m{i}",
                "parent": f"f{i}",
                "points": {"end": [rigid, 0.0], "hole": [0.05, 0.06], "pad": [0.5 * rigid, -0.05]},
            }
        )
    leaves = [f"m{i}" for i in range(n) if children.get(f"m{i}", 0) == 0]
    EI0, L0 = flexures[0]["EI"], flexures[0]["length"]
    loads: list[dict[str, Any]] = []
    for leaf in leaves:
        ang = float(rng.uniform(0.0, 2 * math.pi))
        mag = float(rng.uniform(0.3, 1.0)) * EI0 / L0**2
        load: dict[str, Any] = {
            "point": f"{leaf}.{rng.choice(['end', 'pad'])}",
            "force": [mag * math.cos(ang), mag * math.sin(ang)],
        }
        if rng.random() < 0.3:
            load["moment"] = float(rng.uniform(-1.0, 1.0)) * EI0 / L0
        loads.append(load)
    tendons: list[dict[str, Any]] = []
    if rng.random() < 0.5:
        leaf = leaves[int(rng.integers(0, len(leaves)))]
        path: list[str] = []
        body = leaf
        while body != "base":
            path.append(body)
            body = flexures[int(body[1:])]["parent"]
        route = ["base.a"] + [f"{b}.hole" for b in reversed(path)]
        tendons.append({"tension": float(rng.uniform(0.3, 1.0)) * EI0 / L0 / 0.06, "route": route})
    outputs = list(
        dict.fromkeys([f"{leaf}.end" for leaf in leaves] + [ld["point"] for ld in loads])
    )
    return {
        "name": f"random{index}",
        "base": {"points": {"a": [-0.1, 0.06]}},
        "flexure": flexures,
        "link": links,
        "load": loads,
        "tendon": tendons,
        "output": {"points": outputs},
    }


def _scaled(d: dict, s: float) -> dict:
    out = dict(d)
    out["load"] = [
        {
            **ld,
            "force": [s * ld["force"][0], s * ld["force"][1]],
            **({"moment": s * ld["moment"]} if "moment" in ld else {}),
        }
        for ld in d["load"]
    ]
    out["tendon"] = [{**t, "tension": s * t["tension"]} for t in d["tendon"]]
    return out


def random_scenes(count: int, seed: int = SEED) -> list[tuple[str, Scene]]:
    """``count`` seeded random scenes whose loads are scaled so that the largest bend (max |phi|
    over every flexure, by an scm6 solve) is U(15, 86) degrees. Scenes that buckle, snap, lose
    stability or on which scm6 and exact disagree by more than 1e-3 are redrawn."""
    from flexgen.models.exact import solve_exact
    from flexgen.solver import solve_models

    ref = ModelDef("scm6", "scm-gauss", "scm", modes=6, kernel="gauss")
    rng = np.random.default_rng(seed)
    out: list[tuple[str, Scene]] = []
    attempts = 0
    while len(out) < count and attempts < 20 * count:
        attempts += 1
        raw = _random_layout(rng, len(out))
        target = math.radians(float(rng.uniform(15.0, 86.0)))
        s, ok = 1.0, False
        for _ in range(8):
            scene = scene_from_dict(_scaled(raw, s))
            r = solve_models(scene, ref.models(scene))
            if not r.converged or not r.stable or r.critical_load_factors or r.warnings:
                break
            beta = max_bend(r, scene)
            if abs(beta / target - 1.0) < 0.04:
                ok = True
                break
            s *= (target / beta) if beta > 0 else 2.0
        if not ok:
            continue
        ex = solve_exact(scene)
        if not ex.converged or not ex.stable or ex.warnings:
            continue
        if max(_pose_error(scene, p, r.points[p].pose, ex.poses[p]) for p in r.points) > 1e-3:
            continue
        out.append((scene.name, scene))
    return out


def suite(quick: bool = False, n_random: int | None = None) -> list[tuple[str, Scene]]:
    """The fixed suite: examples (quick: the cantilever and the arc) plus random scenes."""
    ex = example_scenes()
    if quick:
        ex = [(n, s) for n, s in ex if n in (SMOOTH_SCENE, "arc_moment")]
    n_random = (1 if quick else 20) if n_random is None else n_random
    return ex + random_scenes(n_random)


# -- errors ----------------------------------------------------------------------------------


def path_length(scene: Scene, ref: str) -> float:
    """L_p of a point: the scale the estimate and the selection measure its position error by
    (``flexgen.estimate.length_scales``)."""
    return length_scales(scene, [ref])[ref]


def _pose_error(scene: Scene, ref: str, pose, exact_pose) -> float:
    return max(pose_parts(pose, exact_pose, path_length(scene, ref)))


@dataclass
class Answer:
    """The output of one model on one scene (or of exact)."""

    converged: bool
    stable: bool
    poses: dict
    compliance: dict
    warnings: list = field(default_factory=list)
    critical: list = field(default_factory=list)
    result: object = None


def answer(scene: Scene, md: ModelDef) -> Answer:
    """``md``'s answer on ``scene``: a fresh prepared solve (exact: ``solve_exact``)."""
    if md.kind == "exact":
        from flexgen.models.exact import solve_exact

        ex = solve_exact(scene)
        crit = [] if ex.critical_load_factor is None else [ex.critical_load_factor]
        return Answer(
            ex.converged,
            ex.stable,
            {k: np.asarray(v) for k, v in ex.poses.items()},
            {k: np.asarray(v) for k, v in ex.compliance.items()},
            list(ex.warnings),
            crit,
            ex,
        )
    from flexgen.solver import solve_models

    return answer_of(solve_models(md.scene(scene)))


def answer_of(r) -> Answer:
    """The Answer of a chain-model Result."""
    return Answer(
        r.converged,
        r.stable,
        {k: np.asarray(p.pose) for k, p in r.points.items()},
        {k: np.asarray(p.compliance) for k, p in r.points.items()},
        list(r.warnings),
        list(r.critical_load_factors),
        r,
    )


def errors(scene: Scene, ans: Answer, ref: Answer) -> tuple[float, float]:
    """(pose error, compliance error) of ``ans`` against ``ref``: the largest over the output
    points; inf when the model did not converge."""
    if not ans.converged or not ans.poses:
        return math.inf, math.inf
    pe = max(_pose_error(scene, p, ans.poses[p], ref.poses[p]) for p in ref.poses)
    ce = max(compliance_error(ans.compliance[p], ref.compliance[p]) for p in ref.compliance)
    return pe, ce


def estimate_check(scene: Scene, ans: Answer, ref: Answer) -> tuple[bool, float] | None:
    """Is ``ans``'s error estimate honest against ``ref`` (the exact elastica)? (covered, worst
    true/estimate) over its output points, pose and compliance, measured as ``errors`` does:
    covered when every pose error is within its estimate and every compliance error within its
    estimate plus the exact reference's own noise (``honesty.REFERENCE_NOISE``, as
    ``tests/test_estimate.py`` counts it). None: no answer or no estimate."""
    from .honesty import point_within, true_over_estimate

    r: Any = ans.result  # a chain-model Result
    if not ans.converged or r is None or getattr(r, "error_estimate", None) is None:
        return None
    covered, worst = True, 0.0
    for p in ref.poses:
        e = r.points[p].error_estimate
        pe = _pose_error(scene, p, ans.poses[p], ref.poses[p])
        ce = compliance_error(ans.compliance[p], ref.compliance[p])
        covered = covered and point_within(pe, ce, e)
        worst = max(
            worst, true_over_estimate(pe, e["pose"]), true_over_estimate(ce, e["compliance"])
        )
    return covered, worst


def stress_check(scene: Scene, ans: Answer, ref: Answer) -> tuple[bool, float] | None:
    """Is each flexure's stress estimate of ``ans`` honest against the exact elastica's
    (``ref``)? (every flexure's max |curvature|, so strain and stress, within its estimate
    plus the reference's noise; the worst true/estimate), as ``tests/test_estimate.py``
    counts it (``estimate_honesty.curvature_honesty``). None: no answer or no estimate."""
    from flexgen.exact_result import exact_stresses

    from .estimate_honesty import curvature_honesty

    r: Any = ans.result
    if not ans.converged or r is None or not ref.converged or ref.result is None:
        return None
    if getattr(r, "error_estimate", None) is None:
        return None

    class Exact:  # what curvature_honesty reads of a Result
        flexures = exact_stresses(scene, ref.result)

    return curvature_honesty(r, Exact)


@dataclass
class Timed:
    """One model on one scene: its answer, seconds per solve three ways, kernel evaluations."""

    answer: Answer
    api: float
    prepared: float
    core: float
    evaluations: int | None


def measure(scene: Scene, md: ModelDef, repeats: int = 7, budget_s: float = 2.0) -> Timed:
    """Solve ``scene`` with ``md`` and time it: (a) ``flexgen.solve`` of one Scene object (its
    prepared solver cached), (b) a prepared ``Solver.solve()``, (c) the bare core call. exact:
    ``solve_exact`` in all three (median of ``max(1, repeats // 2)`` calls)."""
    if md.kind == "exact":
        ans = answer(scene, md)
        t = time_call(lambda: answer(scene, md), max(1, repeats // 2), budget_s)
        return Timed(ans, t, t, t, None)
    import flexgen

    sc = md.scene(scene)
    solver = flexgen.Solver(sc)  # the public class, with its validity screen (as labelled)
    ans = answer_of(solver.solve(estimate=True))  # the answer flexgen.solve gives, estimated
    evals = evaluations(solver)
    t_api, t_prepared, t_core = time_interleaved(
        [lambda: flexgen.solve(sc), solver.solve, core_call(solver)],
        rounds=max(3, repeats),
        budget_s=budget_s,
    )
    return Timed(ans, t_api, t_prepared, t_core, evals)


# -- progress --------------------------------------------------------------------------------


class Progress:
    """Progress on stderr: a tqdm bar on a terminal; elsewhere (a log file, CI) one plain line
    at each tenth of the work, so a redirected log has no carriage-return-joined line."""

    def __init__(self, total: int, label: str, stream=None, enabled: bool = True):
        self.total, self.label, self.done = max(total, 1), label, 0
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.t0 = time.perf_counter()
        self.bar = None
        if enabled and getattr(self.stream, "isatty", lambda: False)():
            from tqdm import tqdm

            self.bar = tqdm(total=self.total, desc=label, file=self.stream, unit="solve")

    def step(self, what: str = "") -> None:
        self.done += 1
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.set_postfix_str(what[:40], refresh=False)
            self.bar.update(1)
            if self.done >= self.total:
                self.bar.close()
            return
        if self.done * 10 // self.total > (self.done - 1) * 10 // self.total:
            el = time.perf_counter() - self.t0
            self.stream.write(f"[{self.label}] {self.done}/{self.total} {el:.0f} s {what[:40]}\n")
            self.stream.flush()


# -- Pareto ----------------------------------------------------------------------------------


# relative difference below which two models' median errors are one error (the same answer
# through two kernels differs in the 8th digit)
ERROR_TIE = 1e-6


def pareto_front(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the non-dominated (time, error) points (lower is better in both), sorted by
    time. Walked in order of time: a point is on the front unless a faster point already on it
    has an error no worse (within ERROR_TIE: review, scm2 poly, 8th digit above scm2 local's
    and slower, was bolded), or a point as fast has a smaller error. Only points on the front
    dominate (review: a pairwise tie rule is not transitive, and dropped a point better than
    every faster one by more than the tie)."""
    finite = [i for i, (t, e) in enumerate(points) if math.isfinite(t) and math.isfinite(e)]
    finite.sort(key=lambda i: points[i])
    front: list[int] = []
    best = math.inf  # the smallest error on the front among faster points
    k = 0
    while k < len(finite):
        t = points[finite[k]][0]
        group = [i for i in finite[k:] if points[i][0] == t]  # equally fast
        least = min(points[i][1] for i in group)
        kept = [
            i
            for i in group
            if points[i][1] == least and not best <= points[i][1] * (1.0 + ERROR_TIE)
        ]
        front += kept
        if kept:
            best = min(best, least)
        k += len(group)
    return front


def time_at_error(pts: list[tuple[float, float]], target: float) -> tuple[float, str]:
    """Time at which a family's (time, error) curve reaches ``target`` error, interpolated (or
    extrapolated from the two most accurate points) in log-log. Returns (seconds, how)."""
    pts = sorted((t, e) for t, e in pts if math.isfinite(e) and e > 0 and math.isfinite(t))
    if not pts:
        return math.nan, "no data"
    # walk by increasing time; the first segment that crosses the target
    for (t1, e1), (t2, e2) in zip(pts, pts[1:]):
        if e1 >= target >= e2 and e1 != e2:
            a = math.log(target / e1) / math.log(e2 / e1)
            return math.exp(math.log(t1) + a * math.log(t2 / t1)), "interpolated"
    if pts[0][1] <= target:
        return pts[0][0], "reached by the cheapest member (upper bound)"
    (t1, e1), (t2, e2) = pts[-2:] if len(pts) >= 2 else (pts[0], pts[0])
    if e2 >= e1 or len(pts) < 2:
        return math.nan, "does not reach it"
    a = math.log(target / e1) / math.log(e2 / e1)
    return math.exp(math.log(t1) + a * math.log(t2 / t1)), "extrapolated from the two most accurate"


# -- C kernel timing (benchmarks/kernels.py) -------------------------------------------------


def _kernel_bench_module():
    """benchmarks/kernels.py of this checkout as a module (NeedsCheckout, one line, without one:
    a wheel's site-packages may hold another distribution's benchmarks/)."""
    path = repo_path("benchmarks/kernels.py", "flexgen bench's C kernel timing")
    name = "flexgen_benchmarks_kernels"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def c_kernel_ns(names: list[str], quick: bool) -> dict[str, float]:
    """ns per double call of each generated C kernel, with benchmarks/kernels.py's harness (min
    over repeats); empty if gcc is missing."""
    import shutil

    if shutil.which("gcc") is None or not names:
        return {}
    kb = _kernel_bench_module()
    ks = [
        kb.parse_header(kb.C_DIR / f"{n}.h")
        for n in sorted(set(names))
        if (kb.C_DIR / f"{n}.h").is_file()
    ]
    cfg = kb.Config(
        quick=True,
        c_rounds=1 if quick else 3,
        c_repeats=2 if quick else 5,
        c_target_ms=2.0 if quick else 5.0,
        n_random=4,
        n_edge=4,
    )
    _log = kb.log
    kb.log = lambda msg: None  # keep our progress bar readable
    try:
        with tempfile.TemporaryDirectory(prefix="flexgen-bench-c-") as tmp:
            rows = kb.run_c(cfg, Path(tmp), ks)
    finally:
        kb.log = _log
    return {r["kernel"].name: float(r["time"]["double"]) for r in rows}


# -- the run ---------------------------------------------------------------------------------

# the three timings of a chain model (flexgen_tools.timing): key -> what it is
TIMINGS = {
    "time_api": "flexgen.solve (API)",
    "time_prepared": "prepared Solver.solve()",
    "time_core": "bare core call",
}
_TIMES = {"time_api": "times_api", "time_prepared": "times_prepared", "time_core": "times_core"}


@dataclass
class BenchData:
    quick: bool
    scenes: list[str]
    models: list[ModelDef]
    pose_err: dict = field(default_factory=dict)  # (model label, scene) -> float
    comp_err: dict = field(default_factory=dict)
    times_api: dict = field(default_factory=dict)  # (model label, scene) -> s, flexgen.solve
    times_prepared: dict = field(default_factory=dict)  # ... a prepared Solver.solve()
    times_core: dict = field(default_factory=dict)  # ... the bare core call
    evals: dict = field(default_factory=dict)  # (model label, scene) -> kernel evaluations
    ok: dict = field(default_factory=dict)  # (model label, scene) -> converged
    # (model label, scene) -> (covered, worst true/estimate) of the answer's error estimate
    estimate: dict = field(default_factory=dict)
    # (model label, scene) -> (covered, worst true/estimate) of its flexures' stress estimates
    stress_estimate: dict = field(default_factory=dict)
    c_ns: dict = field(default_factory=dict)  # kernel name -> ns per C call
    summary: dict = field(default_factory=dict)  # model label -> dict (see summarize)
    targets: dict = field(default_factory=dict)
    elapsed: float = 0.0

    @property
    def counts_evaluations(self) -> bool:
        """The core reports kernel evaluations (``fg_answer.evaluations``)."""
        return any(v is not None for v in self.evals.values())


def _median(values) -> float:
    vals = [v for v in values if v is not None and not math.isnan(v)]
    return float(np.median(vals)) if vals else math.nan


def summarize(data: BenchData) -> None:
    """Per model: the median and worst errors, the median times, the median overhead of the
    Result (prepared - core) and ratio API / core over the suite, the kernel evaluations per
    solve (median over the suite, and on the one flexure under a tip force)."""
    for md in data.models:
        lab = md.label
        pe = [data.pose_err[lab, s] for s in data.scenes]
        ce = [data.comp_err[lab, s] for s in data.scenes]
        ev: list[int] = [
            e for e in (data.evals.get((lab, s)) for s in data.scenes) if e is not None
        ]
        chain = md.kind != "exact"
        data.summary[lab] = {
            "pose": float(np.median(pe)),
            "comp": float(np.median(ce)),
            "pose_max": float(np.max(pe)),
            "comp_max": float(np.max(ce)),
            **{
                t: _median(getattr(data, _TIMES[t]).get((lab, s)) for s in data.scenes)
                for t in TIMINGS
            },
            "overhead": _median(
                data.times_prepared[lab, s] - data.times_core[lab, s] for s in data.scenes
            )
            if chain
            else math.nan,
            "api_core": _median(
                data.times_api[lab, s] / data.times_core[lab, s] for s in data.scenes
            )
            if chain
            else math.nan,
            "evals": float(np.median(ev)) if ev else None,
            "evals_tip": data.evals.get((lab, SMOOTH_SCENE)),
            "failures": sum(not data.ok[lab, s] for s in data.scenes),
            "c_ns": data.c_ns.get(md.c_kernel) if md.c_kernel else None,
        }


def chart_points(
    data: BenchData, which: str = "pose", timing: str = "time_prepared"
) -> tuple[list[str], list[tuple[float, float]]]:
    """(labels, [(time, error)]) of the chart: exact's error is 0, so it is plotted at 1e-16.
    ``timing``: one of ``TIMINGS``."""
    labels, pts = [], []
    for md in data.models:
        s = data.summary[md.label]
        labels.append(md.label)
        pts.append((s[timing], max(s[which], 1e-16)))
    return labels, pts


def compute_targets(data: BenchData, rounds: int, exact_repeats: int) -> dict:
    """The two-link finger with its own models (scm3, auto kernel) three ways, exact on it, and
    the equal-accuracy comparison of scm and fem for every timing."""
    import flexgen

    tg: dict = {}
    finger = dict(example_scenes())[FINGER_SCENE]
    s = flexgen.Solver(finger)
    r = s.solve()
    tg["finger_evaluations"] = evaluations(s)
    *times, t_run = time_interleaved(
        [lambda: flexgen.solve(finger), s.solve, core_call(s), s.run],
        rounds=rounds,
        budget_s=10.0,
    )
    for timing, t in zip(TIMINGS, times):
        tg[f"finger_scm3_{timing}"] = t
    tg["finger_run_overhead_s"] = t_run - tg["finger_scm3_time_core"]
    tg["finger_api_core_ratio"] = tg["finger_scm3_time_api"] / tg["finger_scm3_time_core"]
    tg["finger_overhead_s"] = tg["finger_scm3_time_prepared"] - tg["finger_scm3_time_core"]
    exact = model_def("exact")
    # the per-scene table's timing of exact on the finger where it has one, so that the page
    # quotes one number for one measurement (review: 153.6 ms there, 140 ms here, one run)
    known = data.times_api.get((exact.label, FINGER_SCENE))
    tg["finger_exact_s"] = (
        known
        if known is not None
        else time_call(lambda: answer(finger, exact), exact_repeats, budget_s=10.0)
    )
    for timing in TIMINGS:
        tg[f"exact_ratio_{timing}"] = tg["finger_exact_s"] / tg[f"finger_scm3_{timing}"]
    tg["finger_scm3_error"] = errors(finger, answer_of(r), answer(finger, exact))
    # equal accuracy: suite median and the smooth cantilever alone, for each way of timing
    for timing in TIMINGS:
        per_scene = getattr(data, _TIMES[timing])
        for key in ("suite", "smooth"):
            if key == "smooth" and SMOOTH_SCENE not in data.scenes:
                continue
            fam = {}
            for name in ("scm-gauss", "scm-poly", "scm-local", "fem"):
                pts = [
                    (data.summary[md.label][timing], data.summary[md.label]["pose"])
                    if key == "suite"
                    else (
                        per_scene.get((md.label, SMOOTH_SCENE), math.nan),
                        data.pose_err[md.label, SMOOTH_SCENE],
                    )
                    for md in data.models
                    if md.family == name
                ]
                fam[name] = time_at_error(pts, TARGET_ERROR)
            tg[f"equal_{key}_{timing}"] = fam
            t_fem = fam["fem"][0]
            best = min(
                (
                    fam[n][0]
                    for n in ("scm-gauss", "scm-poly", "scm-local")
                    if math.isfinite(fam[n][0])
                ),
                default=math.nan,
            )
            tg[f"equal_{key}_{timing}_ratio"] = (
                t_fem / best if best and math.isfinite(best) else math.nan
            )
    return tg


def timing_inconsistencies(data: Any) -> list[str]:
    """The timings of a run that contradict each other (a part timed slower than the whole
    that contains it): what a busy machine does to a timing run, which the page then states."""
    out = []
    for md in data.models:
        s = data.summary[md.label]
        if math.isfinite(s["overhead"]) and s["overhead"] < 0:
            out.append(f"{md.label}: core call slower than Solver.solve(), which contains it")
    tg = data.targets
    for key, what in (
        ("finger_overhead_s", "Solver.solve()"),
        ("finger_run_overhead_s", "Solver.run()"),
    ):
        if key in tg and tg[key] < 0:
            out.append(f"finger scm3: core call slower than {what}, which contains it")
    return out


def run_bench(
    quick: bool = False,
    out: Path | str | None = None,
    progress: bool = True,
    n_random: int | None = None,
) -> BenchData:
    """Run the suite through every model, measure, and (if ``out``) write the chart and table."""
    t_start = time.perf_counter()
    examples_dir()  # NeedsCheckout before any output
    if progress:
        print(f"[bench] building the suite ({'quick' if quick else 'full'})", file=sys.stderr)
    scenes = suite(quick, n_random)
    models = model_defs(quick)
    repeats = 3 if quick else 7
    budget = 0.5 if quick else 2.0
    data = BenchData(quick, [n for n, _ in scenes], models)
    bar = Progress(len(scenes) * len(models), "bench", enabled=progress)
    for name, scene in scenes:
        ref = answer(scene, model_def("exact"))
        for md in models:
            key = (md.label, name)
            try:
                m = measure(scene, md, repeats, budget)
                pe, ce = errors(scene, m.answer, ref)  # exact: against its own earlier run
                ok = m.answer.converged
                if md.kind != "exact":
                    data.estimate[key] = estimate_check(scene, m.answer, ref)
                    data.stress_estimate[key] = stress_check(scene, m.answer, ref)
                times = (m.api, m.prepared, m.core)
                evals = m.evaluations
            except Exception as exc:  # noqa: BLE001 - a model failing is a data point
                pe, ce, ok, times, evals = math.inf, math.inf, False, (math.nan,) * 3, None
                print(
                    f"\n[bench] {md.label} on {name}: {type(exc).__name__}: {exc}", file=sys.stderr
                )
            data.pose_err[key], data.comp_err[key], data.ok[key] = pe, ce, ok
            data.times_api[key], data.times_prepared[key], data.times_core[key] = times
            data.evals[key] = evals
            bar.step(f"{md.label} / {name}")
    if progress:
        print("[bench] C kernel timing (benchmarks/kernels.py harness)", file=sys.stderr)
    data.c_ns = c_kernel_ns([md.c_kernel for md in models if md.c_kernel], quick)
    summarize(data)
    if progress:
        print(
            "[bench] targets: finger scm3 three ways, exact, equal-accuracy times", file=sys.stderr
        )
    data.targets = compute_targets(data, rounds=7 if quick else 21, exact_repeats=1 if quick else 4)
    data.elapsed = time.perf_counter() - t_start
    if out is not None:
        write_outputs(data, Path(out))
    return data


# -- outputs ---------------------------------------------------------------------------------

MARKERS = {
    "cc": "s",
    "prb": "D",
    "scm-poly": "o",
    "scm-gauss": "^",
    "scm-local": "P",
    "fem": "v",
    "exact": "*",
}
COLORS = {
    "cc": "tab:gray",
    "prb": "tab:brown",
    "scm-poly": "tab:blue",
    "scm-gauss": "tab:cyan",
    "scm-local": "tab:green",
    "fem": "tab:red",
    "exact": "black",
}


# a label's offset (points) and alignment by family (default: above-right). scm N's three
# kernels lie close in time, local left of poly left of gauss: local's label goes below-left,
# poly's below-right, gauss's above-right, so that none sits on a neighbour's marker
LABEL_PLACES = {"scm-local": ((-5, -10), "right"), "scm-poly": ((5, -11), "left")}


def plot(data: BenchData, path: Path) -> None:
    """Two log-log panels (pose error, compliance error against time per solve): filled markers
    a prepared ``Solver.solve()``, hollow markers ``flexgen.solve`` (the API), each with its
    Pareto front."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(14, 6))
    for ax, which, title in (
        (axes[0], "pose", "pose error (median over the suite)"),
        (axes[1], "comp", "compliance error (median over the suite)"),
    ):
        seen = set()
        for timing, filled in (("time_api", False), ("time_prepared", True)):
            labels, pts = chart_points(data, which, timing)
            for md, lab, (t, e) in zip(data.models, labels, pts):
                if not (math.isfinite(t) and math.isfinite(e)):
                    continue
                if md.kind == "exact" and not filled:
                    continue  # one solver only: drawn once, below
                key = (md.family, filled)
                name = (
                    "exact (Python, shooting)"
                    if md.kind == "exact"
                    else f"{md.family} ({'prepared' if filled else 'flexgen.solve'})"
                )
                ax.loglog(
                    t * 1e3,
                    e,
                    MARKERS[md.family],
                    ms=8 if filled else 7,
                    color=COLORS[md.family],
                    mfc=COLORS[md.family] if filled else "none",
                    alpha=1.0 if filled else 0.6,
                    label=name if key not in seen else None,
                )
                seen.add(key)
                if filled:  # the label beside the marker, where its neighbours' are not
                    offset, align = LABEL_PLACES.get(md.family, ((5, 4), "left"))
                    ax.annotate(
                        lab,
                        (t * 1e3, e),
                        textcoords="offset points",
                        xytext=offset,
                        ha=align,
                        fontsize=7,
                    )
            front = pareto_front(pts)
            ax.step(
                [pts[i][0] * 1e3 for i in front],
                [pts[i][1] for i in front],
                where="post",
                color="tab:green" if filled else "tab:gray",
                lw=1.5,
                alpha=0.7,
                ls="-" if filled else "--",
                label=f"Pareto front ({'prepared' if filled else 'flexgen.solve'})",
            )
        ax.set_xlabel("time per solve (ms; equilibrium + compliance)")
        ax.set_ylabel("relative error against exact")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left", ncol=2)
    fig.suptitle(
        f"flexgen bench: accuracy against speed ({len(data.scenes)} scenes"
        f"{', quick' if data.quick else ''}; filled: prepared Solver.solve(), hollow: "
        f"flexgen.solve; exact (Python, shooting) plotted at 1e-16)",
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def format_error(x: float) -> str:
    """An error for the tables: 1.2e-05, "0", "inf", or "-" when there is none."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if math.isinf(x):
        return "inf"
    return "0" if x == 0 else f"{x:.1e}"


def _us(t: float) -> str:
    """Seconds as microseconds for the tables ("-" when not measured)."""
    if t is None or math.isnan(t):
        return "-"
    return f"{t * 1e6:.1f}" if t < 1e-3 else f"{t * 1e6:.0f}"


def _count(x) -> str:
    return "-" if x is None else f"{x:.0f}"


def render_markdown(data: BenchData) -> str:
    from flexgen.settings import DEFAULT

    tg = data.targets
    counted = data.counts_evaluations
    L = [
        "# Accuracy against speed",
        "",
        f"Generated by `flexgen bench{' --quick' if data.quick else ''}` in {data.elapsed:.0f} s "
        f"(one run; every number below comes from it; rerun with "
        f"{'that command' if data.quick else '`make bench-models`'}). "
        f"Machine: {os.cpu_count()} logical cores; BLAS threads OPENBLAS_NUM_THREADS="
        f"{os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}.",
        "",
        "![accuracy vs speed](accuracy-vs-speed.png)",
        "",
        "## Suite and measures",
        "",
        f"{len(data.scenes)} scenes: {', '.join(f'`{s}`' for s in data.scenes)}. The random ones "
        f"(seed {SEED}) are chains and trees of 1-4 flexures with rigid links, dead forces, "
        "moments and tendons, scaled so that the largest bend is 15-86 degrees; scenes that "
        "buckle or snap are redrawn (buckling is covered by `flexgen stability`).",
        "",
        "- **pose error**: per output point max(|position error| / L_p, |angle error| in rad), "
        "L_p = total flexure length between the base and the point; per scene the worst point.",
        "- **compliance error**: ||C - C_exact||_2 / ||C_exact||_2 of the 2x2 position "
        "compliance of each output point; per scene the worst point.",
        "- **time per solve** (equilibrium + compliance of the output points; per model the "
        "median over the suite) of the one solver, the C core (`flexgen/compiled/chain_solver.c`"
        ", the extension `flexgen._core`), three ways (`flexgen_tools/timing.py`):",
        "  - *flexgen.solve*: `flexgen.solve(scene)` through the public API, the same Scene "
        "object (every flexure given the model) each call, so its prepared solver comes from "
        "the API's cache; the Result, its error estimate (Newton on the richer model, fg_estimate: "
        "`flexgen/estimate.py`) and the validity check included;",
        "  - *Solver.solve()*: a prepared `flexgen.Solver` (problem and workspace built once), "
        "as a controller loop calls it: the core call, the Result and the core's validity screen;",
        "  - *core call*: the bare `core.lib.fg_solve(problem, work, iwork, answer)` on that "
        "solver's problem and workspace (the cffi call included).",
        "  Each is the median over batches of calls lasting about 2 ms. `exact` is "
        "`models.exact.solve_exact` (shooting, Python and SciPy) in every column. *Result "
        "overhead* = Solver.solve() - core call; *API / core* = flexgen.solve / core call (both "
        "medians over the suite of the per-scene values). Linear algebra: SciPy's LAPACK from "
        f"{DEFAULT.lapack_min_size} coordinates on (`SolverSettings.lapack_min_size`), the "
        "core's built-in factorizations below.",
        "- **kernel evaluations per solve**: "
        + (
            "`fg_answer.evaluations` of one solve (as the core counts them), the median over "
            f"the suite and on `{SMOOTH_SCENE}` (one flexure under a tip force)."
            if counted
            else "not reported: this core does not count them (`fg_answer.evaluations` is missing)."
        ),
        "- **C ns/call**: one call of the generated C kernel (pose, J, H) in double, timed "
        "with `benchmarks/kernels.py`'s harness (min over repeats).",
        "- cc is one Legendre mode (`auto` kernel); `scmN poly` uses the polynomial kernel only "
        "(valid to 90 degrees), `scmN gauss` the Gauss kernel, `scmN local` the local Gauss "
        'kernel (`[model] kernel = "local"`: its bound certified at each q, the Gauss kernel '
        "where it is not).",
        "",
        "## Per model",
        "",
        "| model | pose error (median) | pose error (worst) | compliance error (median) | "
        "compliance error (worst) | flexgen.solve (us) | Solver.solve() (us) | core call (us) | "
        "Result overhead (us) | API / core | kernel evals per solve (median) | kernel evals "
        "per solve (tip force) | not converged | C ns/kernel call |",
        "|---|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|---:|",
    ]
    labels, pts = chart_points(data, "pose", "time_prepared")
    front = set(labels[i] for i in pareto_front(pts))
    for md in data.models:
        s = data.summary[md.label]
        cns = s["c_ns"]
        ratio = "-" if math.isnan(s["api_core"]) else f"{s['api_core']:.1f}x"
        L.append(
            f"| {'**' + md.label + '**' if md.label in front else md.label} | "
            f"{format_error(s['pose'])} | {format_error(s['pose_max'])} | "
            f"{format_error(s['comp'])} | {format_error(s['comp_max'])} | "
            f"{_us(s['time_api'])} | {_us(s['time_prepared'])} | {_us(s['time_core'])} | "
            f"{_us(s['overhead'])} | {ratio} | {_count(s['evals'])} | "
            f"{_count(s['evals_tip'])} | {s['failures']} | "
            f"{'-' if cns is None else f'{cns:.0f}'} |"
        )
    busy = timing_inconsistencies(data)
    L += [
        "",
        "Bold: on the Pareto front of (Solver.solve() time, median pose error).",
        "",
        *(
            [
                f"**The times of this run are not consistent** ({'; '.join(busy)}): the "
                "machine was busy while it ran, so no time on this page, and no timing target "
                "below, can be relied on; run `flexgen bench` again on an idle machine.",
                "",
            ]
            if busy
            else []
        ),
        *estimate_section(data),
        "",
        "## Per scene (pose error / Solver.solve() us / core call us)",
        "",
        "| scene | " + " | ".join(md.label for md in data.models) + " |",
        "|---|" + "---|" * len(data.models),
    ]
    for s in data.scenes:
        L.append(
            f"| `{s}` | "
            + " | ".join(
                f"{format_error(data.pose_err[md.label, s])} / "
                f"{_us(data.times_prepared.get((md.label, s), math.nan))} / "
                f"{_us(data.times_core.get((md.label, s), math.nan))}"
                for md in data.models
            )
            + " |"
        )
    fe = tg.get("finger_scm3_error", (math.nan, math.nan))

    def yes(ok: bool) -> str:
        return "yes" if ok else "NO"

    L += [
        "",
        "## The Python layer on the two-link finger (scm3)",
        "",
        "`examples/two_link_finger.toml` with its own models (scm3, auto kernel; two flexures, "
        "a tendon, a pad force, two output points):",
        "",
        "| flexgen.solve (us) | Solver.solve() (us) | core call (us) | flexgen.solve / core "
        "call | Result overhead: Solver.solve() - core call (us) | Solver.run() - core call "
        "(us) | kernel evaluations per solve |",
        "|---:|---:|---:|---:|---:|---:|---:|",
        f"| {_us(tg['finger_scm3_time_api'])} | {_us(tg['finger_scm3_time_prepared'])} | "
        f"{_us(tg['finger_scm3_time_core'])} | {tg['finger_api_core_ratio']:.2f}x | "
        f"{_us(tg['finger_overhead_s'])} | {_us(tg['finger_run_overhead_s'])} | "
        f"{_count(tg['finger_evaluations'])} |",
        "",
        "`Solver.run()` is `Solver.solve()` without building the Result (the answer stays in the "
        "workspace arrays); flexgen.solve adds the error estimate (`fg_estimate`) and the "
        "validity check (whether the margin to a critical load exceeds 5 %: the core's screen, "
        "`fg_answer.calm`).",
    ]
    L += [
        "",
        "## Targets (measured in this run)",
        "",
        "| target | timing | measured | met? |",
        "|---|---|---|---|",
    ]
    for timing, what in TIMINGS.items():
        t = tg[f"finger_scm3_{timing}"]
        L.append(
            f"| two-flexure finger, equilibrium + compliance with scm3, <= 2 ms per solve "
            f"| {what} | {t * 1e3:.3f} ms (pose error {format_error(fe[0])}, "
            f"compliance error {format_error(fe[1])}) | {yes(t <= 2e-3)} |"
        )
    for timing, what in TIMINGS.items():
        r = tg[f"exact_ratio_{timing}"]
        L.append(
            f"| exact >= 100x slower than scm3 on the finger | {what} | exact "
            f"{tg['finger_exact_s'] * 1e3:.0f} ms, ratio {r:.0f}x | "
            f"{yes(math.isfinite(r) and r >= 100)} |"
        )
    for timing, what in TIMINGS.items():
        for key, which in (
            ("smooth", f"smooth cantilever (`{SMOOTH_SCENE}`)"),
            ("suite", "suite median"),
        ):
            if f"equal_{key}_{timing}" not in tg:
                continue
            fam = tg[f"equal_{key}_{timing}"]
            r = tg[f"equal_{key}_{timing}_ratio"]
            detail = "; ".join(
                f"{n}: {t * 1e6:.0f} us ({how})" if math.isfinite(t) else f"{n}: {how}"
                for n, (t, how) in fam.items()
            )
            L.append(
                f"| smooth curvature >= 10x faster than the n-element chain at error "
                f"{TARGET_ERROR:g}, {which} | {what} | {r:.1f}x ({detail}) | "
                f"{yes(math.isfinite(r) and r >= 10)} |"
            )
    L += [
        "",
        "The equal-accuracy times are read off the (time, pose error) points of each family "
        "(log-log interpolation between members; extrapolation from the two most accurate "
        "members when even the largest does not reach the target, which is stated).",
        "",
    ]
    return "\n".join(L)


def estimate_section(data: BenchData) -> list[str]:
    """The page's account of the error estimate: per model and over the suite, the answers
    whose every point is within its estimate (``estimate_check``) and the worst
    true/estimate (issue 10)."""
    from .honesty import REFERENCE_NOISE

    rows, every, stress = [], [], []
    for md in data.models:
        got = [data.estimate[md.label, s] for s in data.scenes if data.estimate.get((md.label, s))]
        if not got:
            continue
        every += got
        covered = sum(c for c, _ in got)
        st = [
            data.stress_estimate[md.label, s]
            for s in data.scenes
            if data.stress_estimate.get((md.label, s))
        ]
        stress += st
        st_cells = (
            f"{sum(c for c, _ in st) / len(st):.0%} | {max(r for _, r in st):.2f}"
            if st
            else "— | —"
        )
        rows.append(
            f"| {md.label} | {len(got)} | {covered / len(got):.0%} | "
            f"{max(r for _, r in got):.2f} | {st_cells} |"
        )
    if not every:
        return []
    share = sum(c for c, _ in every) / len(every)
    worst = max(r for _, r in every)
    st_share = sum(c for c, _ in stress) / len(stress) if stress else 1.0
    st_worst = max((r for _, r in stress), default=0.0)
    return [
        "## The error estimate against the exact elastica",
        "",
        "Every chain-model answer above with its `error_estimate` (`Solver.solve(estimate=True)`, "
        "what `flexgen.solve` gives), against the exact elastica, per output point and measured "
        "as the errors above: covered when every point's pose error is within its pose estimate "
        "and its compliance error within its compliance estimate plus the exact reference's own "
        f"noise ({REFERENCE_NOISE:g}, `flexgen_tools.honesty.REFERENCE_NOISE`); worst: the "
        "largest true/estimate over the points and both errors. Over the suite: "
        f"{len(every)} answers, {share:.1%} covered, worst true/estimate {worst:.2f} (issue 10: "
        "at least 95 % covered and never above 10x without a warning).",
        "",
        "Stress: each flexure's `error_estimate` (its curvature profile against the richer "
        "model's, relative to the peak) against the elastica's largest |curvature| (so strain "
        "and stress), covered within the estimate plus the same noise "
        "(`flexgen_tools.estimate_honesty.curvature_honesty`). Over the suite: "
        f"{len(stress)} answers, {st_share:.1%} covered, worst true/estimate {st_worst:.2f}.",
        "",
        "| model | answers | covered | worst true/estimate | stress covered | stress worst |",
        "|---|---:|---:|---:|---:|---:|",
        *rows,
    ]


# the files write_outputs writes into --out (the command checks them before the run)
PAGES = ("accuracy-vs-speed.png", "accuracy-vs-speed.md")


def write_outputs(data: BenchData, out: Path) -> tuple[Path, Path]:
    png, md = (out / name for name in PAGES)
    text = render_markdown(data)

    def write_page(tmp: Path) -> None:
        tmp.write_text(text)

    write_all([(png, lambda tmp: plot(data, tmp)), (md, write_page)])
    return png, md
