"""Time per solve (equilibrium + compliance) of the chain solver, Python and compiled, on fixed cases.

    python benchmarks/solver_speed.py [--repeats N] [--budget S] [--json OUT] [--out PAGE.md]

Cases: the two-flexure finger (examples/two_link_finger.toml) with scm3 (auto kernel, as
``flexgen bench`` times it), the same through ``flexgen.solve`` (the scene's own scm3 model,
plus the validity check every API solve runs), fem16, fem64 and exact
(``models.exact.solve_exact``); the 90-degree arc (scm3); the rectangular elastica (scm3;
buckling: the path crosses the bifurcation and ends on the post-buckled branch); the cantilever
under a tip load (examples/cantilever_tip_load.toml) with scm3, fem16, fem32 and fem64.

Speed table, three timings per case (exact: Python only):

- *Python solver*: median milliseconds per solve over ``repeats`` calls after one warm-up call,
  plus the Newton iterations and the state evaluations per solve (Python solver);
- *backend c*: the same call with ``backend="c"`` (the compiled chain solver behind the Python
  API: models, plan cache look-up, Result, any hand-back to the Python solver);
- *compiled solve*: ``plan.run()`` of ``flexgen.compiled.solver.prepare(scene, model_factory=...)``
  alone, or "fallback" where the C solver hands the scene back (then backend c runs the Python
  solver).

The two compiled timings are medians over batches of calls of at least ``BATCH_S`` each (after a
warm-up call), reported per call.

LAPACK table: the compiled solve of fem16, fem32 and fem64 on the cantilever and on the finger,
with the plan as prepared (SciPy's LAPACK from ``library.LAPACK_MIN_SIZE`` coordinates on) and
with LAPACK switched off on that plan (``plan.problem.settings.lapack_min_size = 10**9``: the built-in
factorizations), timed in alternating batches; the two q must agree to ``Q_RTOL`` (relative).

``--out`` writes both tables as a markdown page (the page is printed to stdout either way;
progress goes to stderr). ``--json``: the numbers; one key per speed case, plus ``"lapack"``
(the LAPACK table, keyed "scene model") and ``"machine"``. Single-threaded BLAS is recommended
(OPENBLAS_NUM_THREADS=1, the default here), as in ``flexgen bench``.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np                               # noqa: E402

from flexgen.compiled import library             # noqa: E402
from flexgen.compiled.solver import prepare      # noqa: E402
from flexgen.equilibrium import System, solve    # noqa: E402
from flexgen.models.fem import FEMModel          # noqa: E402
from flexgen.models.scm import SCMModel          # noqa: E402
from flexgen.scene import load_scene             # noqa: E402

BATCH_S = 2e-3          # a timed batch of compiled calls lasts at least this long
ROUNDS = 21             # batches per compiled timing (scaled by --repeats)
Q_RTOL = 1e-12          # LAPACK and built-in factorizations: max |dq| / max |q|
LAPACK_OFF = 10**9      # plan.problem.settings.lapack_min_size that switches LAPACK off
COMMAND = "python benchmarks/solver_speed.py"


def scm3(f):
    return SCMModel(f.length, f.EI, 3, "auto", name=f.name)


def fem(n):
    return lambda f: FEMModel(f.length, f.EI, n)


@dataclass
class Case:
    """One row of the speed table. ``python``/``backend_c``: one solve each way (None: not
    timed); ``plan``: builds the compiled plan (None: no compiled solve); ``reps``: Python
    solver repeats."""
    name: str
    python: Callable[[], object]
    backend_c: Callable[[], object] | None
    plan: Callable[[], object] | None
    reps: int
    exact: bool = False


def chain_case(name: str, scene, factory, reps: int) -> Case:
    """A chain-model case: ``flexgen.equilibrium.solve(scene, model_factory=factory)``."""
    return Case(name, lambda: solve(scene, model_factory=factory),
                lambda: solve(scene, model_factory=factory, backend="c"),
                lambda: prepare(scene, model_factory=factory), reps)


def api_case(name: str, scene, reps: int) -> Case:
    """``flexgen.solve(scene)``: the scene's own models, plus the validity check."""
    import flexgen
    return Case(name, lambda: flexgen.solve(scene), lambda: flexgen.solve(scene, backend="c"),
                lambda: prepare(scene), reps)


def exact_case(name: str, scene, reps: int) -> Case:
    from flexgen.models.exact import solve_exact
    return Case(name, lambda: solve_exact(scene), None, None, reps, exact=True)


def scenes() -> dict:
    ex = REPO / "examples"
    return {"finger": load_scene(ex / "two_link_finger.toml"),
            "arc": load_scene(ex / "arc_moment.toml"),
            "elastica": load_scene(ex / "rectangular_elastica.toml"),
            "cantilever": load_scene(ex / "cantilever_tip_load.toml")}


def cases(sc: dict | None = None) -> list[Case]:
    sc = sc or scenes()
    finger, cant = sc["finger"], sc["cantilever"]
    return [
        chain_case("finger scm3", finger, scm3, 200),
        api_case("finger scm3 API+validity", finger, 200),
        chain_case("finger fem16", finger, fem(16), 100),
        chain_case("finger fem64", finger, fem(64), 30),
        exact_case("finger exact", finger, 5),
        chain_case("arc scm3", sc["arc"], scm3, 300),
        chain_case("elastica scm3 (buckling)", sc["elastica"], scm3, 100),
        chain_case("cantilever scm3", cant, scm3, 200),
        chain_case("cantilever fem16", cant, fem(16), 100),
        chain_case("cantilever fem32", cant, fem(32), 60),
        chain_case("cantilever fem64", cant, fem(64), 30),
    ]


def lapack_cases(sc: dict | None = None) -> list[tuple[str, str, object, Callable]]:
    """(scene label, model label, scene, model factory) of the LAPACK table."""
    sc = sc or scenes()
    return [(s, f"fem{n}", sc[s], fem(n)) for s in ("cantilever", "finger") for n in (16, 32, 64)]


# -- timing ----------------------------------------------------------------------------------

def count_states(fn) -> int:
    """State evaluations of one call (System.state calls)."""
    orig = System.state
    n = [0]

    def counting(self, q, lam):
        n[0] += 1
        return orig(self, q, lam)

    System.state = counting
    try:
        fn()
    finally:
        System.state = orig
    return n[0]


def median_ms(fn, repeats: int, budget_s: float) -> float:
    """Median milliseconds of single calls (after one warm-up call)."""
    fn()     # warm-up (kernel import, caches)
    times = []
    t_end = time.perf_counter() + budget_s
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
        if time.perf_counter() > t_end and len(times) >= 5:
            break
    return 1e3 * statistics.median(times)


def batch_size(fn, batch_s: float = BATCH_S) -> int:
    """Calls per batch so that a batch lasts at least ``batch_s`` (fn already warmed up)."""
    t0 = time.perf_counter()
    fn()
    one = time.perf_counter() - t0
    return max(1, math.ceil(batch_s / max(one, 1e-8)))


def time_batch(fn, k: int) -> float:
    """Seconds per call of one batch of ``k`` calls."""
    t0 = time.perf_counter()
    for _ in range(k):
        fn()
    return (time.perf_counter() - t0) / k


def batched_s(fn, rounds: int, budget_s: float, batch_s: float = BATCH_S) -> float:
    """Median seconds per call over ``rounds`` batches of at least ``batch_s`` each, after one
    warm-up call (fewer batches, but at least 3 or ``rounds``, once ``budget_s`` is spent)."""
    fn()
    k = batch_size(fn, batch_s)
    times = []
    t_end = time.perf_counter() + budget_s
    for _ in range(rounds):
        times.append(time_batch(fn, k))
        if time.perf_counter() > t_end and len(times) >= min(3, rounds):
            break
    return statistics.median(times)


def _q_vector(result) -> np.ndarray:
    return np.concatenate([np.asarray(v, dtype=float) for _, v in sorted(result.q.items())]
                          or [np.zeros(0)])


# -- the two tables --------------------------------------------------------------------------

def speed_row(case: Case, repeats: int, budget_s: float, rounds: int = ROUNDS) -> dict:
    """The speed-table numbers of one case: ``ms`` (Python solver), ``iterations``, ``states``
    (Python solver; None for exact), ``ms_c`` (backend c), ``us_compiled`` (compiled solve alone;
    None where it falls back or for exact), ``compiled`` ("solved", "fallback", "model error",
    "no plan" or None for exact), ``compiled_iterations``, ``backend_c_dq`` (max |q| difference
    of backend c against the Python solver)."""
    ms = median_ms(case.python, max(1, repeats), budget_s)
    res = case.python()
    row = {"ms": ms, "iterations": getattr(res, "iterations", None),
           "states": None if case.exact else count_states(case.python),
           "ms_c": None, "us_compiled": None, "compiled": None, "compiled_iterations": None,
           "backend_c_dq": None}
    if case.exact:
        return row
    rc = case.backend_c()
    if rc.converged != res.converged:
        row["backend_c_dq"] = math.inf
    elif res.converged:
        a, b = _q_vector(res), _q_vector(rc)
        row["backend_c_dq"] = float(np.max(np.abs(a - b))) if a.size == b.size else math.inf
    row["ms_c"] = 1e3 * batched_s(case.backend_c, rounds, budget_s)
    plan = case.plan()
    if plan is None:
        row["compiled"] = "no plan"
        return row
    status = plan.run()
    row["compiled"] = {library.SOLVED: "solved", library.NO_EQUILIBRIUM: "no equilibrium",
                       library.MODEL_ERROR: "model error"}.get(status, f"status {status}")
    if status == library.SOLVED:
        row["compiled_iterations"] = int(plan.answer.iterations)
        row["us_compiled"] = 1e6 * batched_s(plan.run, rounds, budget_s)
    return row


def lapack_row(scene, factory, rounds: int = ROUNDS, budget_s: float = 10.0,
               plan=None) -> dict:
    """The compiled solve of one (scene, model) with the plan as prepared (or ``plan``, prepared
    by the caller) and with LAPACK off on it (``min_size`` = ``LAPACK_OFF``; restored
    afterwards), timed in alternating batches:
    ``ndof``, ``lapack_used`` (the prepared plan factorizes with LAPACK), ``us_lapack``,
    ``us_builtin``, ``ratio`` (built-in / LAPACK), ``q_rel_diff`` (max |dq| / max |q|),
    ``agree`` (q_rel_diff <= Q_RTOL)."""
    if plan is None:
        plan = prepare(scene, model_factory=factory)
    if plan is None:
        raise RuntimeError("no compiled plan for this scene")
    lap = plan.problem.settings
    saved = lap.lapack_min_size
    n = plan.q.size

    def solved(label):
        status = plan.run()
        if status != library.SOLVED:
            raise RuntimeError(f"compiled solve ({label}) returned status {status}")
        return plan.q.copy()

    try:
        q_lapack = solved("as prepared")
        k_lapack = batch_size(plan.run)
        lap.lapack_min_size = LAPACK_OFF
        q_builtin = solved("LAPACK off")
        k_builtin = batch_size(plan.run)
        t_lapack, t_builtin = [], []
        t_end = time.perf_counter() + budget_s
        for _ in range(rounds):
            lap.lapack_min_size = saved
            t_lapack.append(time_batch(plan.run, k_lapack))
            lap.lapack_min_size = LAPACK_OFF
            t_builtin.append(time_batch(plan.run, k_builtin))
            if time.perf_counter() > t_end and len(t_lapack) >= min(3, rounds):
                break
    finally:
        lap.lapack_min_size = saved
    diff = float(np.max(np.abs(q_lapack - q_builtin)) / max(np.max(np.abs(q_lapack)), 1e-300))
    us_l, us_b = 1e6 * statistics.median(t_lapack), 1e6 * statistics.median(t_builtin)
    return {"ndof": int(n), "lapack_used": bool(plan.problem.lapack.potrf) and n >= saved,
            "us_lapack": us_l, "us_builtin": us_b, "ratio": us_b / us_l,
            "q_rel_diff": diff, "agree": diff <= Q_RTOL}


def speed_table(case_list: list[Case], repeats_scale: float = 1.0, budget_s: float = 10.0,
                progress=None) -> dict[str, dict]:
    out = {}
    rounds = max(3, int(ROUNDS * repeats_scale))
    for i, case in enumerate(case_list):
        if progress:
            progress(f"speed {i + 1}/{len(case_list)}: {case.name}")
        out[case.name] = speed_row(case, max(3, int(case.reps * repeats_scale)), budget_s, rounds)
    return out


def lapack_table(rows, repeats_scale: float = 1.0, budget_s: float = 10.0,
                 progress=None) -> dict[str, dict]:
    out = {}
    rounds = max(3, int(ROUNDS * repeats_scale))
    for i, (sname, mname, scene, factory) in enumerate(rows):
        if progress:
            progress(f"LAPACK {i + 1}/{len(rows)}: {sname} {mname}")
        out[f"{sname} {mname}"] = lapack_row(scene, factory, rounds, budget_s)
    return out


# -- the page --------------------------------------------------------------------------------

def _cpu_model() -> str | None:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return None


def machine() -> dict:
    return {"cores": os.cpu_count(), "cpu": _cpu_model(),
            "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "unset"),
            "lapack_min_size": library.LAPACK_MIN_SIZE}


def _num(x, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def render_markdown(speed: dict, lapack: dict, command: str = COMMAND,
                    elapsed: float | None = None, mach: dict | None = None) -> str:
    mach = mach or machine()
    took = "" if elapsed is None else f" in {elapsed:.0f} s"
    cpu = f" ({mach['cpu']})" if mach.get("cpu") else ""
    L = ["# Solver speed", "",
         f"Written by `{command}`{took}.",
         f"Machine: {mach['cores']} logical cores{cpu}; "
         f"OPENBLAS_NUM_THREADS={mach['OPENBLAS_NUM_THREADS']}.",
         "Timings are from one run (medians; on a busy machine expect some noise between runs).",
         "",
         "## Python solver, backend c and the compiled solve", "",
         "Time per solve (equilibrium + compliance of the output points). *Python solver*: "
         "`flexgen.equilibrium.solve(scene, model_factory=...)` (models built inside the call), "
         "median of single calls after a warm-up; the API row is `flexgen.solve(scene)` (the "
         "scene's own scm3 model plus the validity check; its compiled solve is "
         "`prepare(scene)`, the same plan as finger scm3); exact is "
         "`models.exact.solve_exact` (Python only). *backend c*: the same call with "
         "`backend=\"c\"`. *compiled solve*: `plan.run()` of "
         "`flexgen.compiled.solver.prepare(scene, model_factory=...)` alone, the scene flattened "
         f"once. The two compiled timings are medians over batches of calls lasting at least "
         f"{BATCH_S * 1e3:g} ms each, reported per call. *iters*, *states*: Newton iterations "
         "and state evaluations of one Python solve.", "",
         "| case | Python solver (ms) | backend c (ms) | compiled solve (us) | iters | states |",
         "|---|---:|---:|---:|---:|---:|"]
    fallbacks = []
    for name, r in speed.items():
        if r["compiled"] is None:
            comp = "-"
        elif r["us_compiled"] is None:
            comp = r["compiled"]
            fallbacks.append(name)
        else:
            comp = f"{r['us_compiled']:.1f}"
        L.append(f"| {name} | {r['ms']:.3f} | {_num(r['ms_c'], '.3f')} | {comp} | "
                 f"{_num(r['iterations'], 'd')} | {_num(r['states'], 'd')} |")
    notes = []
    if fallbacks:
        notes.append("*fallback*: `plan.run()` does not return SOLVED for "
                     + ", ".join(fallbacks) + ": the C solver hands the scene back (see "
                     "docs/compiled-solver.md for when). backend c then runs the Python solver, "
                     "so its time there is the Python solver's plus the C attempt.")
    dq = [r["backend_c_dq"] for r in speed.values() if r["backend_c_dq"] is not None]
    if dq:
        notes.append(f"The backends agree: the largest difference of a coordinate of q between "
                     f"backend c and the Python solver over these cases is {max(dq):.1e}.")
    if notes:
        L += ["", " ".join(notes)]
    L += ["", "## LAPACK against the built-in factorizations", "",
          "The compiled solve of the n-element chain with the plan as prepared (SciPy's LAPACK "
          f"from {mach.get('lapack_min_size', library.LAPACK_MIN_SIZE)} coordinates on: "
          "`library.LAPACK_MIN_SIZE`) and with LAPACK switched off on that plan "
          f"(`plan.problem.settings.lapack_min_size = 10**9`: the built-in Cholesky and LU), timed in "
          "alternating batches. *max rel. q diff*: max |q_LAPACK - q_built-in| / max |q|.", "",
          "| scene | model | coordinates | LAPACK (us) | built-in (us) | built-in / LAPACK | "
          "max rel. q diff |",
          "|---|---|---:|---:|---:|---:|---:|"]
    for key, r in lapack.items():
        sname, mname = key.rsplit(" ", 1)
        lap = f"{r['us_lapack']:.1f}" if r["lapack_used"] else f"{r['us_lapack']:.1f} (not used)"
        L.append(f"| {sname} | {mname} | {r['ndof']} | {lap} | {r['us_builtin']:.1f} | "
                 f"{r['ratio']:.2f} | {r['q_rel_diff']:.1e} |")
    if lapack:
        worst = max(r["q_rel_diff"] for r in lapack.values())
        ok = all(r["agree"] for r in lapack.values())
        L += ["", f"Both factorizations give the same q: the largest relative difference is "
              f"{worst:.1e} ({'within' if ok else 'NOT within'} {Q_RTOL:g})."]
        slower = [f"{k} ({r['ndof']} coordinates)" for k, r in lapack.items()
                  if r["lapack_used"] and r["ratio"] < 1.0]
        if slower:
            L[-1] += (" The built-in factorizations are the faster ones for " + ", ".join(slower)
                      + ", where the plan as prepared uses LAPACK.")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=float, default=1.0, help="scale the repeat counts")
    ap.add_argument("--budget", type=float, default=10.0, help="seconds per timing at most")
    ap.add_argument("--json", help="also write the numbers to this file")
    ap.add_argument("--out", help="write the tables as a markdown page to this file")
    args = ap.parse_args(argv)
    argv = sys.argv[1:] if argv is None else list(argv)
    t0 = time.perf_counter()

    def progress(msg):
        print(f"[solver_speed {time.perf_counter() - t0:5.1f} s] {msg}", file=sys.stderr,
              flush=True)

    sc = scenes()
    speed = speed_table(cases(sc), args.repeats, args.budget, progress)
    lapack = lapack_table(lapack_cases(sc), args.repeats, args.budget, progress)
    elapsed = time.perf_counter() - t0
    mach = machine()
    page = render_markdown(speed, lapack, shlex.join([*COMMAND.split(), *argv]), elapsed, mach)
    print(page, end="")
    if args.out:
        Path(args.out).write_text(page)
        progress(f"wrote {args.out}")
    if args.json:
        Path(args.json).write_text(json.dumps({**speed, "lapack": lapack, "machine": mach},
                                              indent=2))
    bad = [k for k, r in lapack.items() if not r["agree"]]
    if bad:
        print(f"LAPACK and built-in q differ by more than {Q_RTOL:g}: {', '.join(bad)}",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
