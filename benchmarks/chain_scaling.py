"""Time per compiled solve of a chain of n scm3 flexures under a tip force, n = 1 .. 32.

    python benchmarks/chain_scaling.py [--sizes 1,2,4,8,16,32] [--rounds 21]
                                       [--elimination-min-size N]

The chain: n flexures of length 1/n (EI = 1) in a row, each on its parent's tip, a tip force
(0, -2) (the cantilever of examples/cantilever_tip_load.toml cut into n pieces), scm3 with the
"auto" kernel. Timed: the bare core call of a prepared ``flexgen.Solver`` (the fastest,
or with --stat median the median, of ``rounds`` batches of calls lasting at least BATCH_S,
after WARMUP_S of warm-up calls), with the Newton iterations and, where the compiled solver
reports it (``fg_answer.evaluations``), the chain evaluations per solve. The last column is the time relative to n = 1.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import flexgen  # noqa: E402
from flexgen import core  # noqa: E402
from flexgen.scene import scene_from_dict  # noqa: E402
from flexgen.settings import DEFAULT, SolverSettings  # noqa: E402
from flexgen_tools.timing import core_call  # noqa: E402

BATCH_S = 5e-3
STAT = "min"
WARMUP_S = 0.3  # calls before timing (caches, CPU frequency)


def chain_scene(n: int, force=(0.0, -2.0)):
    flex = []
    for i in range(n):
        flex.append(
            {
                "name": f"f{i}",
                "length": 1.0 / n,
                "EI": 1.0,
                "parent": "base" if i == 0 else f"f{i - 1}",
                "at": [0.0, 0.0, 0.0],
            }
        )
    return scene_from_dict(
        {
            "name": f"chain{n}",
            "flexure": flex,
            "load": [{"point": f"f{n - 1}.tip", "force": list(force)}],
            "output": {"points": [f"f{n - 1}.tip"]},
        }
    )


def time_plan(run, rounds: int) -> float:
    status = run()
    if status != core.SOLVED:
        raise SystemExit(f"not solved (core status {status})")
    t_end = time.perf_counter() + WARMUP_S
    while time.perf_counter() < t_end:
        run()
    calls = 1
    while True:
        t0 = time.perf_counter()
        for _ in range(calls):
            run()
        if time.perf_counter() - t0 >= BATCH_S:
            break
        calls *= 2
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(calls):
            run()
        times.append((time.perf_counter() - t0) / calls)
    return min(times) if STAT == "min" else statistics.median(times)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1,2,4,8,16,32")
    ap.add_argument("--rounds", type=int, default=21)
    ap.add_argument(
        "--stat",
        choices=("min", "median"),
        default="min",
        help="of the batches (min: robust to other processes on the machine)",
    )
    ap.add_argument("--out", help="also write the table as a Markdown page to this file")
    ap.add_argument(
        "--elimination-min-size",
        type=int,
        default=DEFAULT.elimination_min_size,
        help="SolverSettings.elimination_min_size (default %(default)s; 1000000000: K always "
        "factorized densely, to time what the elimination order saves)",
    )
    args = ap.parse_args(argv)
    settings = SolverSettings(elimination_min_size=args.elimination_min_size)
    global STAT
    STAT = args.stat
    sizes = [int(s) for s in args.sizes.split(",")]
    base = None
    rows = []
    print(
        f"{'n':>3} {'ndof':>5} {'us/solve':>10} {'iterations':>10} {'evaluations':>11} {'ratio':>7}"
    )
    for n in sizes:
        scene = chain_scene(n)
        solver = flexgen.Solver(scene, modes=3, settings=settings)
        t = time_plan(core_call(solver), args.rounds)
        if base is None:
            base = t
        a = solver.workspace.answer
        row = (n, solver.workspace.q.size, t * 1e6, a.iterations, a.evaluations, t / base)
        rows.append(row)
        print(f"{row[0]:>3} {row[1]:>5} {row[2]:>10.2f} {row[3]:>10} {row[4]:>11} {row[5]:>7.1f}")
    if args.out:
        lines = [
            "# Chain scaling: time per solve against the number of flexures",
            "",
            f"Written by `python benchmarks/chain_scaling.py --out {args.out}` (part of "
            "`make bench`) on this project's shared 2-core machine: a chain of n scm3 flexures "
            "(length 1/n each, EI = 1, in a row) under the tip force (0, -2), the bare core call "
            f"of a prepared `flexgen.Solver`, the {STAT} of {args.rounds} batches. Evaluations: "
            "chain evaluations that evaluated a model per solve, as the core counts them (the unloaded "
            "state, whose kernel values are constants, is not one).",
            "",
            "| n | coordinates | us per solve | Newton iterations | evaluations | time / (n = 1) |",
            "|---|---|---|---|---|---|",
        ]
        lines += [f"| {r[0]} | {r[1]} | {r[2]:.2f} | {r[3]} | {r[4]} | {r[5]:.1f} |" for r in rows]
        Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
