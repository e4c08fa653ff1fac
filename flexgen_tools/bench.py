"""Accuracy against speed of every flexure model on a fixed suite of scenes.

``flexgen bench`` (``run_bench``) solves every scene of the suite -- the examples plus a seeded set
of random chains and trees (1-4 flexures, forces, moments, tendons, bends up to 90 degrees) --
with every model and compares each answer with the exact elastica (``models.exact.solve_exact``):

* pose error of every output point: max(|position error| / L_p, |angle error|), L_p the total
  flexure length between the base and the point (so a single cantilever's error is relative to
  its length);
* compliance error of every output point: ||C - C_exact||_2 / ||C_exact||_2 (2x2 position block);
* time per solve (equilibrium + compliance of the output points), three ways: the Python solver
  (median of repeated ``flexgen.equilibrium.solve`` calls; ``solve_exact`` for exact), the same
  call with ``backend="c"`` (the compiled chain solver behind the Python API: models, Result and
  any fall-back to the Python solver included), and the compiled solve alone (``plan.run()`` of
  ``flexgen.compiled.solver.prepare``, the scene flattened once, as a controller calls it; where
  the C solver hands the scene back to Python, the backend="c" time counts instead);
* ns per kernel call in C for the scm kernels, from ``benchmarks/kernels.py``'s harness.

A scene's error is the largest over its output points; a model's error is the median over the
suite (the table also gives the worst scene). Everything is measured in one run. The functions are
importable; tests/test_bench.py runs ``run_bench(quick=True)``.
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
from typing import Callable

import numpy as np

from flexgen.scene import Scene, load_scene, scene_from_dict

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
SEED = 20240917
SMOOTH_SCENE = "cantilever_tip_load"        # the smooth case of the equal-accuracy comparison
FINGER_SCENE = "two_link_finger"
TARGET_ERROR = 1e-4                          # equal-accuracy comparison of scm and fem


# -- models ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class ModelDef:
    label: str            # "scm3 poly", "fem16", "exact" ...
    family: str           # "cc", "prb", "scm-poly", "scm-gauss", "fem", "exact"
    kind: str             # model kind (scene.MODEL_KINDS)
    modes: int = 0
    elements: int = 0
    kernel: str = "auto"

    def factory(self) -> Callable:
        """Flexure -> FlexureModel (not for exact)."""
        kind, modes, elements, kernel = self.kind, self.modes, self.elements, self.kernel
        if kind in ("scm", "cc"):
            from flexgen.models.scm import SCMModel
            return lambda f: SCMModel(f.length, f.EI, modes, kernel)
        if kind == "prb":
            from flexgen.models.prb import PRBModel
            return lambda f: PRBModel(f.length, f.EI)
        if kind == "fem":
            from flexgen.models.fem import FEMModel
            return lambda f: FEMModel(f.length, f.EI, elements)
        raise ValueError(f"no chain model for {self.label}")

    @property
    def c_kernel(self) -> str | None:
        """Name of the generated C kernel this model calls, if any."""
        if self.kind not in ("scm", "cc"):
            return None
        if self.kernel == "gauss":
            from flexgen import kernels
            return kernels.gauss_kernel_name(self.modes)
        return f"scm{self.modes}"


def model_defs(quick: bool = False) -> list[ModelDef]:
    """cc, prb, scm2..6 with the poly and the gauss kernel, fem 4..64, exact (quick: a subset)."""
    defs = [ModelDef("cc", "cc", "cc", modes=1, kernel="auto"), ModelDef("prb", "prb", "prb")]
    modes = (2, 3, 4, 5) if quick else (2, 3, 4, 5, 6)
    defs += [ModelDef(f"scm{n} poly", "scm-poly", "scm", modes=n, kernel="poly")
             for n in ((3,) if quick else modes)]
    defs += [ModelDef(f"scm{n} gauss", "scm-gauss", "scm", modes=n, kernel="gauss") for n in modes]
    defs += [ModelDef(f"fem{e}", "fem", "fem", elements=e)
             for e in ((4, 8, 16) if quick else (4, 8, 16, 32, 64))]
    defs.append(ModelDef("exact", "exact", "exact"))
    return defs


def model_def(label: str) -> ModelDef:
    for d in model_defs():
        if d.label == label:
            return d
    raise KeyError(label)


# -- the suite -------------------------------------------------------------------------------

def example_scenes() -> list[tuple[str, Scene]]:
    return [(p.stem, load_scene(p)) for p in sorted(EXAMPLES.glob("*.toml"))]


def max_bend(result, scene: Scene) -> float:
    """Largest |phi(sigma)| (angle relative to the root frame) over the flexures of a solved scm
    result (from its curvature coefficients), in rad."""
    from flexgen.models.scm import angle_basis
    sigma = np.linspace(0.0, 1.0, 65)
    worst = 0.0
    for f in scene.flexures:
        q = np.asarray(result.q[f.name], dtype=float)
        worst = max(worst, float(np.max(np.abs(angle_basis(len(q), sigma) @ q))))
    return worst


def _random_layout(rng: np.random.Generator, index: int) -> dict:
    """A random chain or tree of 1-4 flexures with rigid links, unscaled loads and tendons."""
    n = int(rng.integers(1, 5))
    tree = n >= 3 and rng.random() < 0.5
    flexures, links = [], []
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
        links.append({"name": f"m{i}", "parent": f"f{i}",
                      "points": {"end": [rigid, 0.0], "hole": [0.05, 0.06],
                                 "pad": [0.5 * rigid, -0.05]}})
    leaves = [f"m{i}" for i in range(n) if children.get(f"m{i}", 0) == 0]
    EI0, L0 = flexures[0]["EI"], flexures[0]["length"]
    loads = []
    for leaf in leaves:
        ang = float(rng.uniform(0.0, 2 * math.pi))
        mag = float(rng.uniform(0.3, 1.0)) * EI0 / L0 ** 2
        load = {"point": f"{leaf}.{rng.choice(['end', 'pad'])}",
                "force": [mag * math.cos(ang), mag * math.sin(ang)]}
        if rng.random() < 0.3:
            load["moment"] = float(rng.uniform(-1.0, 1.0)) * EI0 / L0
        loads.append(load)
    tendons = []
    if rng.random() < 0.5:
        leaf = leaves[int(rng.integers(0, len(leaves)))]
        path = []
        body = leaf
        while body != "base":
            path.append(body)
            body = flexures[int(body[1:])]["parent"]
        route = ["base.a"] + [f"{b}.hole" for b in reversed(path)]
        tendons.append({"tension": float(rng.uniform(0.3, 1.0)) * EI0 / L0 / 0.06,
                        "route": route})
    outputs = list(dict.fromkeys([f"{leaf}.end" for leaf in leaves] + [ld["point"] for ld in loads]))
    return {"name": f"random{index}", "base": {"points": {"a": [-0.1, 0.06]}},
            "flexure": flexures, "link": links, "load": loads, "tendon": tendons,
            "output": {"points": outputs}}


def _scaled(d: dict, s: float) -> dict:
    out = dict(d)
    out["load"] = [{**ld, "force": [s * ld["force"][0], s * ld["force"][1]],
                    **({"moment": s * ld["moment"]} if "moment" in ld else {})} for ld in d["load"]]
    out["tendon"] = [{**t, "tension": s * t["tension"]} for t in d["tendon"]]
    return out


def random_scenes(count: int, seed: int = SEED) -> list[tuple[str, Scene]]:
    """``count`` seeded random scenes whose loads are scaled so that the largest bend (max |phi|
    over every flexure, by an scm6 solve) is U(15, 86) degrees. Scenes that buckle, snap, lose
    stability or on which scm6 and exact disagree by more than 1e-3 are redrawn."""
    from flexgen.models.exact import solve_exact
    from flexgen.equilibrium import solve
    ref = ModelDef("scm6", "scm-gauss", "scm", modes=6, kernel="gauss").factory()
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
            r = solve(scene, model_factory=ref)
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
    body = ref.split(".")[0]
    total = sum(scene.flexure(name).length for name in scene.flexure_path(body))
    return total if total > 0 else 1.0


def _pose_error(scene: Scene, ref: str, pose, exact_pose) -> float:
    d = np.asarray(pose, dtype=float) - np.asarray(exact_pose, dtype=float)
    ang = abs((d[2] + math.pi) % (2 * math.pi) - math.pi)
    return max(float(np.hypot(d[0], d[1])) / path_length(scene, ref), ang)


def compliance_error(C, C_exact) -> float:
    C, Ce = np.asarray(C, dtype=float), np.asarray(C_exact, dtype=float)
    if not np.all(np.isfinite(C)):
        return math.inf
    return float(np.linalg.norm(C - Ce, 2) / np.linalg.norm(Ce, 2))


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
    if md.kind == "exact":
        from flexgen.models.exact import solve_exact
        ex = solve_exact(scene)
        crit = [] if ex.critical_load_factor is None else [ex.critical_load_factor]
        return Answer(ex.converged, ex.stable, {k: np.asarray(v) for k, v in ex.poses.items()},
                      {k: np.asarray(v) for k, v in ex.compliance.items()}, list(ex.warnings),
                      crit, ex)
    from flexgen.equilibrium import solve
    r = solve(scene, model_factory=md.factory())
    return Answer(r.converged, r.stable, {k: np.asarray(p.pose) for k, p in r.points.items()},
                  {k: np.asarray(p.compliance) for k, p in r.points.items()}, list(r.warnings),
                  list(r.critical_load_factors), r)


def errors(scene: Scene, ans: Answer, ref: Answer) -> tuple[float, float]:
    """(pose error, compliance error) of ``ans`` against ``ref``: the largest over the output
    points; inf when the model did not converge."""
    if not ans.converged or not ans.poses:
        return math.inf, math.inf
    pe = max(_pose_error(scene, p, ans.poses[p], ref.poses[p]) for p in ref.poses)
    ce = max(compliance_error(ans.compliance[p], ref.compliance[p]) for p in ref.compliance)
    return pe, ce


def time_fast(fn: Callable[[], object], rounds: int = 7, batch_s: float = 2e-3,
              budget_s: float = 2.0) -> float:
    """Median seconds per call of a fast ``fn`` over ``rounds`` batches of about ``batch_s``."""
    fn()
    t0 = time.perf_counter()
    fn()
    one = time.perf_counter() - t0
    k = max(1, int(batch_s / max(one, 1e-7)))
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(k):
            fn()
        times.append((time.perf_counter() - t0) / k)
        if sum(times) * k > budget_s:
            break
    return float(np.median(times))


def time_call(fn: Callable[[], object], repeats: int, budget_s: float = 2.0) -> float:
    """Median seconds of ``repeats`` calls (fewer if one call exceeds budget_s / repeats)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
        if sum(times) > budget_s and len(times) >= 1:
            break
    return float(np.median(times))


# -- progress --------------------------------------------------------------------------------

class Progress:
    """A one-line progress bar on stderr (no dependency)."""

    def __init__(self, total: int, label: str, stream=None, enabled: bool = True):
        self.total, self.label, self.done = max(total, 1), label, 0
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.t0 = time.perf_counter()

    def step(self, what: str = "") -> None:
        self.done += 1
        if not self.enabled:
            return
        frac = min(self.done / self.total, 1.0)
        bar = "#" * int(30 * frac) + "." * (30 - int(30 * frac))
        el = time.perf_counter() - self.t0
        self.stream.write(f"\r[{self.label}] [{bar}] {self.done}/{self.total} {el:5.0f} s "
                          f"{what[:40]:<40}")
        if self.done >= self.total:
            self.stream.write("\n")
        self.stream.flush()


# -- Pareto ----------------------------------------------------------------------------------

def pareto_front(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the non-dominated (time, error) points (lower is better in both), sorted by
    time. A point is dominated if another is no worse in both and better in one."""
    idx = []
    for i, (t, e) in enumerate(points):
        if not (math.isfinite(t) and math.isfinite(e)):
            continue
        dominated = any((t2 <= t and e2 <= e and (t2 < t or e2 < e))
                        for j, (t2, e2) in enumerate(points)
                        if j != i and math.isfinite(t2) and math.isfinite(e2))
        if not dominated:
            idx.append(i)
    return sorted(idx, key=lambda i: points[i][0])


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
    path = REPO / "benchmarks" / "kernels.py"
    if not path.is_file():
        return None
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
    over repeats); empty if gcc or the benchmark module is missing."""
    import shutil
    kb = _kernel_bench_module()
    if kb is None or shutil.which("gcc") is None or not names:
        return {}
    ks = [kb.parse_header(kb.C_DIR / f"{n}.h") for n in sorted(set(names))
          if (kb.C_DIR / f"{n}.h").is_file()]
    cfg = kb.Config(quick=True, c_rounds=1 if quick else 3, c_repeats=2 if quick else 5,
                    c_target_ms=2.0 if quick else 5.0, n_random=4, n_edge=4)
    _log = kb.log
    kb.log = lambda msg: None           # keep our progress bar readable
    try:
        with tempfile.TemporaryDirectory(prefix="flexgen-bench-c-") as tmp:
            rows = kb.run_c(cfg, Path(tmp), ks)
    finally:
        kb.log = _log
    return {r["kernel"].name: float(r["time"]["double"]) for r in rows}


# -- the run ---------------------------------------------------------------------------------

@dataclass
class BenchData:
    quick: bool
    scenes: list[str]
    models: list[ModelDef]
    pose_err: dict          # (model label, scene) -> float
    comp_err: dict
    times: dict             # (model label, scene) -> seconds per solve, Python solver
    ok: dict                # (model label, scene) -> converged
    c_ns: dict              # kernel name -> ns
    summary: dict           # model label -> dict(pose, comp, pose_max, comp_max, time, failures)
    targets: dict
    elapsed: float = 0.0
    times_c: dict = field(default_factory=dict)     # ... flexgen.equilibrium.solve(backend="c")
    times_cs: dict = field(default_factory=dict)    # ... the compiled solve alone (see above)
    c_solved: dict = field(default_factory=dict)    # (model label, scene) -> C solved it itself
    backend_diff: dict = field(default_factory=dict)  # model label -> max |pose_c - pose_python|


def summarize(data: BenchData) -> None:
    for md in data.models:
        pe = [data.pose_err[md.label, s] for s in data.scenes]
        ce = [data.comp_err[md.label, s] for s in data.scenes]
        ts = [data.times[md.label, s] for s in data.scenes]
        data.summary[md.label] = {
            "pose": float(np.median(pe)), "comp": float(np.median(ce)),
            "pose_max": float(np.max(pe)), "comp_max": float(np.max(ce)),
            "time": float(np.median(ts)),
            "time_c": float(np.median([data.times_c.get((md.label, s), math.nan)
                                       for s in data.scenes])),
            "time_cs": float(np.median([data.times_cs.get((md.label, s), math.nan)
                                        for s in data.scenes])),
            "c_solved": sum(bool(data.c_solved.get((md.label, s))) for s in data.scenes),
            "failures": sum(not data.ok[md.label, s] for s in data.scenes),
            "c_ns": data.c_ns.get(md.c_kernel) if md.c_kernel else None}


TIMINGS = {"time": "Python solver", "time_c": "backend=\"c\" (Python API)",
           "time_cs": "compiled solve"}
_TIMES = {"time": "times", "time_c": "times_c", "time_cs": "times_cs"}


def chart_points(data: BenchData, which: str = "pose",
                 timing: str = "time") -> tuple[list[str], list[tuple[float, float]]]:
    """(labels, [(time, error)]) of the chart: exact's error is 0, so it is plotted at 1e-16.
    ``timing``: "time" (Python solver), "time_c" (backend c) or "time_cs" (compiled solve)."""
    labels, pts = [], []
    for md in data.models:
        s = data.summary[md.label]
        labels.append(md.label)
        pts.append((s[timing], max(s[which], 1e-16)))
    return labels, pts


def compute_targets(data: BenchData, finger_repeats: int) -> dict:
    from flexgen.equilibrium import solve
    tg: dict = {}
    scenes = dict(example_scenes())
    finger = scenes[FINGER_SCENE]
    from flexgen.compiled import library
    from flexgen.compiled.solver import prepare
    f3 = ModelDef("scm3", "scm-poly", "scm", modes=3, kernel="auto").factory()
    solve(finger, model_factory=f3)
    tg["finger_scm3_s"] = time_call(lambda: solve(finger, model_factory=f3), finger_repeats,
                                    budget_s=10.0)
    solve(finger, model_factory=f3, backend="c")
    tg["finger_scm3_c_s"] = time_fast(lambda: solve(finger, model_factory=f3, backend="c"))
    plan = prepare(finger, model_factory=f3)
    tg["finger_scm3_cs_s"] = (time_fast(plan.run) if plan is not None
                              and plan.run() == library.SOLVED else math.nan)
    tg["finger_exact_s"] = time_call(lambda: answer(finger, model_def("exact")),
                                     max(1, finger_repeats // 10), budget_s=10.0)
    tg["exact_ratio"] = tg["finger_exact_s"] / tg["finger_scm3_s"]
    tg["exact_ratio_c"] = tg["finger_exact_s"] / tg["finger_scm3_c_s"]
    tg["exact_ratio_cs"] = tg["finger_exact_s"] / tg["finger_scm3_cs_s"]
    ref = answer(finger, model_def("exact"))
    tg["finger_scm3_error"] = errors(finger, answer(finger, ModelDef(
        "scm3", "scm-poly", "scm", modes=3, kernel="auto")), ref)
    # equal accuracy: suite median and the smooth cantilever alone, for each way of timing
    for timing in TIMINGS:
        per_scene = getattr(data, _TIMES[timing])
        for key, getter in (
                ("suite", lambda lab: (data.summary[lab][timing], data.summary[lab]["pose"])),
                ("smooth", lambda lab: (per_scene.get((lab, SMOOTH_SCENE), math.nan),
                                        data.pose_err[lab, SMOOTH_SCENE]))):
            if key == "smooth" and SMOOTH_SCENE not in data.scenes:
                continue
            fam = {}
            for name in ("scm-gauss", "scm-poly", "fem"):
                pts = [getter(md.label) for md in data.models if md.family == name]
                fam[name] = time_at_error(pts, TARGET_ERROR)
            tg[f"equal_{key}_{timing}"] = fam
            t_fem = fam["fem"][0]
            best = min((fam[n][0] for n in ("scm-gauss", "scm-poly") if math.isfinite(fam[n][0])),
                       default=math.nan)
            tg[f"equal_{key}_{timing}_ratio"] = (t_fem / best if best and math.isfinite(best)
                                                 else math.nan)
    return tg


def _time_compiled(data: BenchData, name: str, scene: Scene, md: ModelDef,
                   ans: Answer) -> tuple[float, float]:
    """(seconds per solve with backend="c", seconds per compiled solve alone) of a chain model;
    records whether the C solver solved the scene itself and how far its poses are from the
    Python solver's (``data.backend_diff``: the two backends must agree)."""
    from flexgen.compiled import library
    from flexgen.compiled.solver import prepare
    from flexgen.equilibrium import solve
    rc = solve(scene, model_factory=md.factory(), backend="c")
    if rc.converged != ans.converged:
        diff = math.inf
    else:
        diff = max((float(np.max(np.abs(np.asarray(rc.points[p].pose) - ans.poses[p])))
                    for p in ans.poses), default=0.0)
    data.backend_diff[md.label] = max(data.backend_diff.get(md.label, 0.0), diff)
    tc = time_fast(lambda: solve(scene, model_factory=md.factory(), backend="c"))
    plan = prepare(scene, model_factory=md.factory())
    solved = plan is not None and plan.run() == library.SOLVED
    data.c_solved[md.label, name] = solved
    return tc, (time_fast(plan.run) if solved else tc)


def run_bench(quick: bool = False, out: Path | str | None = None, progress: bool = True,
              n_random: int | None = None) -> BenchData:
    """Run the suite through every model, measure, and (if ``out``) write the chart and table."""
    t_start = time.perf_counter()
    if progress:
        print(f"[bench] building the suite ({'quick' if quick else 'full'})", file=sys.stderr)
    scenes = suite(quick, n_random)
    models = model_defs(quick)
    repeats = 2 if quick else 7
    data = BenchData(quick, [n for n, _ in scenes], models, {}, {}, {}, {}, {}, {}, {})
    bar = Progress(len(scenes) * len(models), "bench", enabled=progress)
    for name, scene in scenes:
        ref = answer(scene, model_def("exact"))
        for md in models:
            tc = tcs = math.nan
            try:
                ans = answer(scene, md)
                pe, ce = errors(scene, ans, ref)     # exact: against its own earlier run
                reps = max(1, repeats // 2) if md.kind == "exact" else repeats
                t = time_call(lambda: answer(scene, md), reps)
                ok = ans.converged
                if md.kind == "exact":
                    tc = tcs = t
                else:
                    tc, tcs = _time_compiled(data, name, scene, md, ans)
            except Exception as exc:   # noqa: BLE001 - a model failing is a data point
                pe, ce, t, ok = math.inf, math.inf, math.nan, False
                print(f"\n[bench] {md.label} on {name}: {type(exc).__name__}: {exc}",
                      file=sys.stderr)
            data.pose_err[md.label, name] = pe
            data.comp_err[md.label, name] = ce
            data.times[md.label, name] = t
            data.times_c[md.label, name] = tc
            data.times_cs[md.label, name] = tcs
            data.ok[md.label, name] = ok
            bar.step(f"{md.label} / {name}")
    if progress:
        print("[bench] C kernel timing (benchmarks/kernels.py harness)", file=sys.stderr)
    data.c_ns = c_kernel_ns([md.c_kernel for md in models if md.c_kernel], quick)
    summarize(data)
    if progress:
        print("[bench] targets: finger scm3 vs exact, equal-accuracy times", file=sys.stderr)
    data.targets = compute_targets(data, finger_repeats=10 if quick else 40)
    data.elapsed = time.perf_counter() - t_start
    if out is not None:
        write_outputs(data, Path(out))
    return data


# -- outputs ---------------------------------------------------------------------------------

MARKERS = {"cc": "s", "prb": "D", "scm-poly": "o", "scm-gauss": "^", "fem": "v", "exact": "*"}
COLORS = {"cc": "tab:gray", "prb": "tab:brown", "scm-poly": "tab:blue", "scm-gauss": "tab:cyan",
          "fem": "tab:red", "exact": "black"}


def plot(data: BenchData, path: Path) -> None:
    """Two log-log panels (pose error, compliance error against time per solve): filled markers
    the compiled solve, hollow markers the Python solver, each series with its Pareto front."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(14, 6))
    for ax, which, title in ((axes[0], "pose", "pose error (median over the suite)"),
                             (axes[1], "comp", "compliance error (median over the suite)")):
        seen = set()
        for timing, filled in (("time", False), ("time_cs", True)):
            labels, pts = chart_points(data, which, timing)
            for md, lab, (t, e) in zip(data.models, labels, pts):
                if not (math.isfinite(t) and math.isfinite(e)):
                    continue
                if md.kind == "exact" and not filled:
                    continue                      # one solver only: drawn once, below
                key = (md.family, filled)
                name = ("exact (Python, shooting)" if md.kind == "exact"
                        else f"{md.family} ({'compiled' if filled else 'Python'})")
                ax.loglog(t * 1e3, e, MARKERS[md.family], ms=8 if filled else 7,
                          color=COLORS[md.family], mfc=COLORS[md.family] if filled else "none",
                          alpha=1.0 if filled else 0.6, label=name if key not in seen else None)
                seen.add(key)
                if filled:       # poly labels below-left of the marker, the rest above-right
                    left = md.family == "scm-poly"
                    ax.annotate(lab, (t * 1e3, e), textcoords="offset points",
                                xytext=(-5, -10) if left else (5, 4),
                                ha="right" if left else "left", fontsize=7)
            front = pareto_front(pts)
            ax.step([pts[i][0] * 1e3 for i in front], [pts[i][1] for i in front], where="post",
                    color="tab:green" if filled else "tab:gray", lw=1.5, alpha=0.7,
                    ls="-" if filled else "--",
                    label=f"Pareto front ({'compiled solve' if filled else 'Python solver'})")
        ax.set_xlabel("time per solve (ms; equilibrium + compliance)")
        ax.set_ylabel("relative error against exact")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left", ncol=2)
    fig.suptitle(f"flexgen bench: accuracy against speed ({len(data.scenes)} scenes"
                 f"{', quick' if data.quick else ''}; filled: compiled solve, hollow: Python "
                 f"solver; exact (Python, shooting) plotted at 1e-16)", fontsize=11)
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


def _lapack_min_size() -> int:
    from flexgen.compiled.library import LAPACK_MIN_SIZE
    return LAPACK_MIN_SIZE


def render_markdown(data: BenchData) -> str:
    tg = data.targets
    L = ["# Accuracy against speed", "",
         f"Generated by `flexgen bench{' --quick' if data.quick else ''}` in {data.elapsed:.0f} s "
         "(one run; every number below comes from it; rerun with `make bench`). "
         f"Machine: {os.cpu_count()} logical cores; BLAS threads OPENBLAS_NUM_THREADS="
         f"{os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}.", "",
         "![accuracy vs speed](accuracy-vs-speed.png)", "",
         "## Suite and measures", "",
         f"{len(data.scenes)} scenes: {', '.join(f'`{s}`' for s in data.scenes)}. The random ones "
         f"(seed {SEED}) are chains and trees of 1-4 flexures with rigid links, dead forces, "
         "moments and tendons, scaled so that the largest bend is 15-86 degrees; scenes that "
         "buckle or snap are redrawn (buckling is covered by `flexgen stability`).", "",
         "- **pose error**: per output point max(|position error| / L_p, |angle error| in rad), "
         "L_p = total flexure length between the base and the point; per scene the worst point.",
         "- **compliance error**: ||C - C_exact||_2 / ||C_exact||_2 of the 2x2 position "
         "compliance of each output point; per scene the worst point.",
         "- **time per solve** (equilibrium + compliance of the output points; per model the "
         "median over the suite), three ways:",
         "  - *Python solver*: median of repeated `flexgen.equilibrium.solve(scene, "
         "model_factory=...)` calls (models built inside the call); `exact` is "
         "`models.exact.solve_exact` (shooting, Python and SciPy) in every column;",
         "  - *backend c*: the same call with `backend=\"c\"`: the compiled chain solver "
         "(`flexgen/compiled/chain_solver.c`) behind the Python API, models, flattening cache "
         "look-up, Result and any hand-back to the Python solver included;",
         "  - *compiled solve*: `plan.run()` of `flexgen.compiled.solver.prepare(scene, ...)`, the "
         "scene flattened once, as a controller loop calls it (ctypes call included). Where the C "
         "solver hands a scene back to the Python solver (see docs/compiled-solver.md), the "
         "backend c time of that scene counts instead. Linear algebra: SciPy's "
         f"LAPACK from {_lapack_min_size()} coordinates on (the same routines numpy.linalg runs "
         "for the Python solver), built-in factorizations below.",
         "- **C ns/call**: one call of the generated C kernel (pose, J, H) in double, timed "
         "with `benchmarks/kernels.py`'s harness (min over repeats).",
         "- cc is one Legendre mode (`auto` kernel); `scmN poly` uses the polynomial kernel only "
         "(valid to 90 degrees), `scmN gauss` the Gauss kernel.", "",
         "## Per model", "",
         "| model | pose error (median) | pose error (worst) | compliance error (median) | "
         "compliance error (worst) | Python solver (ms) | backend c (ms) | compiled solve (us) | "
         "solved in C | not converged | C ns/kernel call |",
         "|---|---|---|---|---|---|---|---|---|---|---|"]
    labels, pts = chart_points(data, "pose", "time_cs")
    front = set(labels[i] for i in pareto_front(pts))
    n_scenes = len(data.scenes)
    for md in data.models:
        s = data.summary[md.label]
        cns = s["c_ns"]
        solved = "-" if md.kind == "exact" else f"{s['c_solved']}/{n_scenes}"
        L.append(f"| {'**' + md.label + '**' if md.label in front else md.label} | "
                 f"{format_error(s['pose'])} | {format_error(s['pose_max'])} | {format_error(s['comp'])} | "
                 f"{format_error(s['comp_max'])} | {s['time'] * 1e3:.2f} | {s['time_c'] * 1e3:.3f} | "
                 f"{s['time_cs'] * 1e6:.1f} | {solved} | {s['failures']} | "
                 f"{'-' if cns is None else f'{cns:.0f}'} |")
    diff = max(data.backend_diff.values(), default=0.0)
    L += ["", "Bold: on the Pareto front of (compiled solve time, median pose error). *solved in "
          "C*: scenes the C solver solved itself (the others went back to the Python solver). "
          + (f"The two backends agree: the largest difference of an output pose between backend "
             f"c and the Python solver over every model and scene is {diff:.1e}."
             if diff <= 1e-9 else
             f"**The two backends DISAGREE**: an output pose differs by {diff:.1e} between "
             f"backend c and the Python solver (models: "
             f"{', '.join(k for k, v in data.backend_diff.items() if v > 1e-9)})."), "",
          "## Per scene (pose error / Python solver ms / compiled solve us)", "",
          "| scene | " + " | ".join(md.label for md in data.models) + " |",
          "|---|" + "---|" * len(data.models)]
    for s in data.scenes:
        L.append(f"| `{s}` | " + " | ".join(
            f"{format_error(data.pose_err[md.label, s])} / {data.times[md.label, s] * 1e3:.1f} / "
            f"{data.times_cs.get((md.label, s), math.nan) * 1e6:.0f}"
            for md in data.models) + " |")
    fe = tg.get("finger_scm3_error", (math.nan, math.nan))
    def yes(ok: bool) -> str:
        return "yes" if ok else "NO"

    L += ["", "## Targets (measured in this run)", "",
          "| target | timing | measured | met? |", "|---|---|---|---|"]
    for timing, key in (("time", "finger_scm3_s"), ("time_c", "finger_scm3_c_s"),
                        ("time_cs", "finger_scm3_cs_s")):
        t = tg[key]
        L.append(f"| two-flexure finger, equilibrium + compliance with scm3, <= 2 ms per solve "
                 f"| {TIMINGS[timing]} | {t * 1e3:.3f} ms (pose error {format_error(fe[0])}, "
                 f"compliance error {format_error(fe[1])}) | {yes(t <= 2e-3)} |")
    for timing, key in (("time", "exact_ratio"), ("time_c", "exact_ratio_c"),
                        ("time_cs", "exact_ratio_cs")):
        r = tg[key]
        L.append(f"| exact >= 100x slower than scm3 on the finger | {TIMINGS[timing]} | exact "
                 f"{tg['finger_exact_s'] * 1e3:.0f} ms, ratio {r:.0f}x | "
                 f"{yes(math.isfinite(r) and r >= 100)} |")
    for timing in TIMINGS:
        for key, what in (("smooth", f"smooth cantilever (`{SMOOTH_SCENE}`)"),
                          ("suite", "suite median")):
            if f"equal_{key}_{timing}" not in tg:
                continue
            fam = tg[f"equal_{key}_{timing}"]
            r = tg[f"equal_{key}_{timing}_ratio"]
            detail = "; ".join(f"{n}: {t * 1e6:.0f} us ({how})" if math.isfinite(t)
                               else f"{n}: {how}" for n, (t, how) in fam.items())
            L.append(f"| smooth curvature >= 10x faster than the n-element chain at error "
                     f"{TARGET_ERROR:g}, {what} | {TIMINGS[timing]} | {r:.1f}x ({detail}) | "
                     f"{yes(math.isfinite(r) and r >= 10)} |")
    L += ["", "The equal-accuracy times are read off the (time, pose error) points of each family "
          "(log-log interpolation between members; extrapolation from the two most accurate "
          "members when even the largest does not reach the target, which is stated).", ""]
    return "\n".join(L)


def write_outputs(data: BenchData, out: Path) -> tuple[Path, Path]:
    out.mkdir(parents=True, exist_ok=True)
    png, md = out / "accuracy-vs-speed.png", out / "accuracy-vs-speed.md"
    plot(data, png)
    md.write_text(render_markdown(data))
    return png, md
