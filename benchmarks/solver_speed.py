"""Time per solve (equilibrium + compliance) of the one solver, the C core, on fixed cases.

    python benchmarks/solver_speed.py [--repeats N] [--budget S] [--json OUT] [--out PAGE.md]

Cases: the two-flexure finger (examples/two_link_finger.toml) with scm3 (auto kernel, the
scene's own model, as ``flexgen bench`` times it), fem16, fem64 and exact; the 90-degree arc
(scm3); the rectangular elastica (scm3; buckling: the path crosses the bifurcation and ends on the
post-buckled branch); the cantilever under a tip load (examples/cantilever_tip_load.toml) with
scm3, fem16, fem32 and fem64. Each case is a Scene every flexure of which has the model
(``flexgen_tools.timing.with_model``).

Speed table, three timings per case (``flexgen_tools.timing``), in alternating batches of calls
lasting at least ``BATCH_S`` each (the median per call over the batches):

- *flexgen.solve*: ``flexgen.solve(scene)`` through the public API, the same Scene object every
  call (its prepared solver comes from the API's cache; the Result, its error estimate and the
  validity check included); exact: ``flexgen.solve`` of the scene with kind "exact" (``models.exact``, Python
  and SciPy), median of single calls, and nothing else;
- *Solver.solve()*: a prepared ``flexgen.Solver``: the core call, the Result and the validity screen;
- *core call*: the bare ``core.lib.fg_solve`` on that solver's problem and workspace;

plus flexgen.solve / core call, the Result's overhead (Solver.solve() - core call), the Newton
iterations and the kernel evaluations per solve (``fg_answer.evaluations``, where the core counts
them).

LAPACK table: the core call of fem16, fem32 and fem64 on the cantilever and on the finger, with
the default settings (SciPy's LAPACK from ``SolverSettings.lapack_min_size`` coordinates on) and
with ``SolverSettings(lapack_min_size=LAPACK_OFF)`` (the core's built-in factorizations), two
prepared solvers timed in alternating batches; the two q must agree to ``Q_RTOL`` (relative).

``--out`` writes both tables as a markdown page (the page is printed to stdout either way;
progress goes to stderr). ``--json``: the numbers; one key per speed case, plus ``"lapack"``
(the LAPACK table, keyed "scene model") and ``"machine"``. Single-threaded BLAS is recommended
(OPENBLAS_NUM_THREADS=1, the default here), as in ``flexgen bench``.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

import flexgen  # noqa: E402
from flexgen import core  # noqa: E402
from flexgen.scene import Scene, load_scene  # noqa: E402
from flexgen.settings import DEFAULT  # noqa: E402
from flexgen.solver import Solver, make_settings  # noqa: E402
from flexgen_tools.timing import core_call, evaluations, time_interleaved, with_model  # noqa: E402

BATCH_S = 2e-3  # a timed batch of calls lasts at least this long
ROUNDS = 21  # batches per timing (scaled by --repeats)
Q_RTOL = 1e-12  # LAPACK and built-in factorizations: max |dq| / max |q|
LAPACK_OFF = 10**9  # SolverSettings.lapack_min_size that switches LAPACK off
COMMAND = "python benchmarks/solver_speed.py"

# the models of the cases, as with_model arguments
scm3 = {"kind": "scm", "modes": 3, "kernel": "auto"}


def fem(n: int) -> dict:
    return {"kind": "fem", "elements": n}


@dataclass
class Case:
    """One row of the speed table: a Scene whose flexures all have the model; ``reps``: single
    calls timed for exact."""

    name: str
    scene: Scene
    reps: int
    exact: bool = False


def chain_case(name: str, scene: Scene, model: dict, reps: int = 0) -> Case:
    """A chain-model case: ``scene`` with ``model`` (e.g. ``scm3``, ``fem(16)``) everywhere."""
    return Case(name, with_model(scene, **model), reps)


def exact_case(name: str, scene: Scene, reps: int) -> Case:
    return Case(name, with_model(scene, "exact"), reps, exact=True)


def scenes() -> dict:
    ex = REPO / "examples"
    if not ex.is_dir():
        raise SystemExit(f"{COMMAND} needs a source checkout of flexgen (examples/)")
    return {
        "finger": load_scene(ex / "two_link_finger.toml"),
        "arc": load_scene(ex / "arc_moment.toml"),
        "elastica": load_scene(ex / "rectangular_elastica.toml"),
        "cantilever": load_scene(ex / "cantilever_tip_load.toml"),
    }


def cases(sc: dict | None = None) -> list[Case]:
    sc = sc or scenes()
    finger, cant = sc["finger"], sc["cantilever"]
    return [
        chain_case("finger scm3", finger, scm3),
        chain_case("finger fem16", finger, fem(16)),
        chain_case("finger fem64", finger, fem(64)),
        exact_case("finger exact", finger, 5),
        chain_case("arc scm3", sc["arc"], scm3),
        chain_case("elastica scm3 (buckling)", sc["elastica"], scm3),
        chain_case("cantilever scm3", cant, scm3),
        chain_case("cantilever fem16", cant, fem(16)),
        chain_case("cantilever fem32", cant, fem(32)),
        chain_case("cantilever fem64", cant, fem(64)),
    ]


def lapack_cases(sc: dict | None = None) -> list[tuple[str, str, Scene, dict]]:
    """(scene label, model label, scene, model) of the LAPACK table."""
    sc = sc or scenes()
    return [(s, f"fem{n}", sc[s], fem(n)) for s in ("cantilever", "finger") for n in (16, 32, 64)]


# -- timing ----------------------------------------------------------------------------------


def median_ms(fn, repeats: int, budget_s: float) -> float:
    """Median milliseconds of single calls (after one warm-up call)."""
    fn()  # warm-up (kernel import, caches)
    times = []
    t_end = time.perf_counter() + budget_s
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
        if time.perf_counter() > t_end and len(times) >= min(5, repeats):
            break
    return 1e3 * statistics.median(times)


# -- the two tables --------------------------------------------------------------------------


def speed_row(case: Case, repeats: int, budget_s: float, rounds: int = ROUNDS) -> dict:
    """The speed-table numbers of one case: ``us_api`` (flexgen.solve), ``us_prepared``
    (Solver.solve()), ``us_core`` (the bare core call), ``api_core`` (us_api / us_core),
    ``overhead_us`` (us_prepared - us_core), ``converged``, ``stable``, ``critical`` (critical
    load factors on the path), ``iterations``, ``evaluations`` (None where the core does not
    count them). exact: ``us_api`` (median of ``repeats`` single calls) and ``converged`` only."""
    sc = case.scene
    if case.exact:
        ms = median_ms(lambda: flexgen.solve(sc), repeats, budget_s)
        r = flexgen.solve(sc)
        return {
            "us_api": 1e3 * ms,
            "us_prepared": None,
            "us_core": None,
            "api_core": None,
            "overhead_us": None,
            "converged": bool(r.converged),
            "stable": bool(r.stable),
            "critical": list(r.critical_load_factors),
            "iterations": None,
            "evaluations": None,
        }
    solver = flexgen.Solver(sc)  # the public class, with its validity screen (as labelled)
    r = solver.solve()
    evals = evaluations(solver)
    t_api, t_prep, t_core = time_interleaved(
        [lambda: flexgen.solve(sc), solver.solve, core_call(solver)],
        rounds=rounds,
        batch_s=BATCH_S,
        budget_s=budget_s,
    )
    return {
        "us_api": 1e6 * t_api,
        "us_prepared": 1e6 * t_prep,
        "us_core": 1e6 * t_core,
        "api_core": t_api / t_core,
        "overhead_us": 1e6 * (t_prep - t_core),
        "converged": bool(r.converged),
        "stable": bool(r.stable),
        "critical": list(r.critical_load_factors),
        "iterations": int(r.iterations),
        "evaluations": evals,
    }


def lapack_solvers(scene: Scene, model: dict) -> tuple[Solver, Solver]:
    """Two prepared solvers of ``scene`` with ``model``: the default settings (LAPACK from
    ``DEFAULT.lapack_min_size`` coordinates on) and LAPACK off (``lapack_min_size`` =
    ``LAPACK_OFF``)."""
    sc = with_model(scene, **model)
    return Solver(sc), Solver(sc, settings=make_settings(lapack_min_size=LAPACK_OFF))


def lapack_row(scene: Scene, model: dict, rounds: int = ROUNDS, budget_s: float = 10.0) -> dict:
    """The core call of one (scene, model) with LAPACK as the defaults use it and with it off,
    timed in alternating batches: ``ndof``, ``lapack_used`` (the default settings factorize
    with LAPACK here), ``us_lapack``, ``us_builtin``, ``ratio`` (built-in / LAPACK),
    ``q_rel_diff`` (max |dq| / max |q|), ``agree`` (q_rel_diff <= Q_RTOL)."""
    on, off = lapack_solvers(scene, model)
    qs = []
    for label, s in (("default settings", on), ("LAPACK off", off)):
        r = s.solve()
        if not r.converged:
            raise RuntimeError(f"no equilibrium ({label}): {r.reason}")
        qs.append(s.workspace.q.copy())
    t_lapack, t_builtin = time_interleaved(
        [core_call(on), core_call(off)], rounds=rounds, batch_s=BATCH_S, budget_s=budget_s
    )
    q_lapack, q_builtin = qs
    n = q_lapack.size
    diff = float(np.max(np.abs(q_lapack - q_builtin)) / max(np.max(np.abs(q_lapack)), 1e-300))
    us_l, us_b = 1e6 * t_lapack, 1e6 * t_builtin
    return {
        "ndof": int(n),
        "lapack_used": bool(core.lapack()) and n >= on.settings.lapack_min_size,
        "us_lapack": us_l,
        "us_builtin": us_b,
        "ratio": us_b / us_l,
        "q_rel_diff": diff,
        "agree": diff <= Q_RTOL,
    }


def speed_table(
    case_list: list[Case], repeats_scale: float = 1.0, budget_s: float = 10.0, progress=None
) -> dict[str, dict]:
    out = {}
    rounds = max(3, int(ROUNDS * repeats_scale))
    for i, case in enumerate(case_list):
        if progress:
            progress(f"speed {i + 1}/{len(case_list)}: {case.name}")
        out[case.name] = speed_row(case, max(1, int(case.reps * repeats_scale)), budget_s, rounds)
    return out


def lapack_table(
    rows, repeats_scale: float = 1.0, budget_s: float = 10.0, progress=None
) -> dict[str, dict]:
    out = {}
    rounds = max(3, int(ROUNDS * repeats_scale))
    for i, (sname, mname, scene, model) in enumerate(rows):
        if progress:
            progress(f"LAPACK {i + 1}/{len(rows)}: {sname} {mname}")
        out[f"{sname} {mname}"] = lapack_row(scene, model, rounds, budget_s)
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
    return {
        "cores": os.cpu_count(),
        "cpu": _cpu_model(),
        "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "unset"),
        "lapack_min_size": DEFAULT.lapack_min_size,
    }


def _num(x, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def render_markdown(
    speed: dict,
    lapack: dict,
    command: str = COMMAND,
    elapsed: float | None = None,
    mach: dict | None = None,
) -> str:
    mach = mach or machine()
    took = "" if elapsed is None else f" in {elapsed:.0f} s"
    cpu = f" ({mach['cpu']})" if mach.get("cpu") else ""
    counted = any(r["evaluations"] is not None for r in speed.values())
    L = [
        "# Solver speed",
        "",
        f"Written by `{command}`{took}.",
        f"Machine: {mach['cores']} logical cores{cpu}; "
        f"OPENBLAS_NUM_THREADS={mach['OPENBLAS_NUM_THREADS']}.",
        "Timings are from one run (medians; on a busy machine expect some noise between runs).",
        "",
        "## flexgen.solve, a prepared Solver and the bare core call",
        "",
        "Time per solve (equilibrium + compliance of the output points) of the one solver, the "
        "C core (`flexgen/compiled/chain_solver.c`, the extension `flexgen._core`), each case a "
        "scene every flexure of which has the model. *flexgen.solve*: `flexgen.solve(scene)` "
        "through the public API, the same Scene object every call, so its prepared solver comes "
        "from the API's cache (the Result, its error estimate and the validity check included); "
        "exact is "
        '`flexgen.solve` with kind "exact" (`models.exact`, Python and SciPy; median of single '
        "calls). *Solver.solve()*: a prepared `flexgen.Solver` (the core call, the Result and the validity screen). "
        "*core call*: the bare `core.lib.fg_solve(problem, work, iwork, answer)` on that "
        "solver's problem and workspace. The three are timed in alternating batches of calls "
        f"lasting at least {BATCH_S * 1e3:g} ms each (median per call). *API / core*: "
        "flexgen.solve / core call; *Result overhead*: Solver.solve() - core call. *iters*: "
        "Newton iterations of one solve; *evaluations*: "
        + (
            "`fg_answer.evaluations` of one solve (as the core counts them)."
            if counted
            else "not reported (this core does not count them: `fg_answer.evaluations` is missing)."
        ),
        "",
        "| case | flexgen.solve (us) | Solver.solve() (us) | core call (us) | API / core | "
        "Result overhead (us) | iters | evaluations |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    notes = []
    for name, r in speed.items():
        if not r["converged"]:
            notes.append(name)
        api = _num(r["us_api"], ".1f" if r["us_api"] is None or r["us_api"] < 1e4 else ".0f")
        L.append(
            f"| {name} | {api} | {_num(r['us_prepared'], '.1f')} | "
            f"{_num(r['us_core'], '.1f')} | "
            f"{'-' if r['api_core'] is None else format(r['api_core'], '.1f') + 'x'} | "
            f"{_num(r['overhead_us'], '.1f')} | {_num(r['iterations'], 'd')} | "
            f"{_num(r['evaluations'], 'd')} |"
        )
    if notes:
        L += [
            "",
            "**No equilibrium** for " + ", ".join(notes) + " (the times are those of the "
            "failed solve).",
        ]
    buckled = [
        f"{name}: {', '.join(f'{x:.4g}' for x in r['critical'])}"
        for name, r in speed.items()
        if r["critical"]
    ]
    if buckled:
        L += [
            "",
            "Critical load factors on the load path (bifurcations crossed, snap-throughs), "
            "a fraction of the scene's loads: " + "; ".join(buckled) + ".",
        ]
    L += [
        "",
        "## LAPACK against the built-in factorizations",
        "",
        "The core call of the n-element chain with the default settings (SciPy's LAPACK from "
        f"{mach.get('lapack_min_size', DEFAULT.lapack_min_size)} coordinates on: "
        "`SolverSettings.lapack_min_size`) and with "
        "`SolverSettings(lapack_min_size=10**9)` (the built-in Cholesky and LU), two prepared "
        "solvers timed in alternating batches. *max rel. q diff*: max |q_LAPACK - "
        "q_built-in| / max |q|.",
        "",
        "| scene | model | coordinates | LAPACK (us) | built-in (us) | built-in / LAPACK | "
        "max rel. q diff |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for key, r in lapack.items():
        sname, mname = key.rsplit(" ", 1)
        lap = f"{r['us_lapack']:.1f}" if r["lapack_used"] else f"{r['us_lapack']:.1f} (not used)"
        L.append(
            f"| {sname} | {mname} | {r['ndof']} | {lap} | {r['us_builtin']:.1f} | "
            f"{r['ratio']:.2f} | {r['q_rel_diff']:.1e} |"
        )
    if lapack:
        worst = max(r["q_rel_diff"] for r in lapack.values())
        ok = all(r["agree"] for r in lapack.values())
        L += [
            "",
            f"Both factorizations give the same q: the largest relative difference is "
            f"{worst:.1e} ({'within' if ok else 'NOT within'} {Q_RTOL:g}).",
        ]
        slower = [
            f"{k} ({r['ndof']} coordinates)"
            for k, r in lapack.items()
            if r["lapack_used"] and r["ratio"] < 1.0
        ]
        if slower:
            L[-1] += (
                " The built-in factorizations are the faster ones for "
                + ", ".join(slower)
                + ", where the default settings use LAPACK."
            )
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
        print(
            f"[solver_speed {time.perf_counter() - t0:5.1f} s] {msg}", file=sys.stderr, flush=True
        )

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
        Path(args.json).write_text(
            json.dumps({**speed, "lapack": lapack, "machine": mach}, indent=2)
        )
    bad = [k for k, r in lapack.items() if not r["agree"]]
    if bad:
        print(
            f"LAPACK and built-in q differ by more than {Q_RTOL:g}: {', '.join(bad)}",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
