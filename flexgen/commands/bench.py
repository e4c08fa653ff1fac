"""`flexgen bench`: accuracy against speed of every model on a fixed suite (docs/accuracy-vs-speed)."""
from __future__ import annotations

import sys
from pathlib import Path

from flexgen.commands.common import REPO, integer


def register(sub) -> None:
    p = sub.add_parser("bench", help="accuracy against speed of every model on a fixed suite",
                       description=(
        "Solve the examples and a seeded set of random chains and trees with every model (cc, "
        "prb, scm2..6 with the poly and the gauss kernel, fem 4..64, exact); measure pose and "
        "compliance errors against exact; time per solve three ways (the Python solver, "
        "backend=\"c\" through the Python API, the compiled solve alone) and ns per C kernel "
        "call; check that both backends agree; write accuracy-vs-speed.png (log-log, Pareto "
        "fronts) and accuracy-vs-speed.md into --out. About 75 s on 2 cores; set "
        "OPENBLAS_NUM_THREADS=1 (make bench-models does) for stable timings."))
    p.add_argument("--quick", action="store_true",
                   help="a few scenes and models (for the tests; well under a minute)")
    p.add_argument("--out", type=Path, default=REPO / "docs", help="output folder (default docs/)")
    p.add_argument("--random", type=integer(1), default=None, metavar="N",
                   help="number of random scenes (default 20, quick 1)")
    p.set_defaults(run=run)


def run(args) -> int:
    from flexgen.bench import run_bench
    data = run_bench(quick=args.quick, out=args.out, n_random=args.random)
    tg = data.targets
    print(f"wrote {args.out / 'accuracy-vs-speed.md'} and {args.out / 'accuracy-vs-speed.png'} "
          f"({data.elapsed:.0f} s)")
    nan = float("nan")
    for timing, label in (("time", "Python solver"), ("time_cs", "compiled solve")):
        suffix = {"time": "", "time_cs": "_cs"}[timing]
        print(f"{label}: finger scm3 {tg[f'finger_scm3{suffix}_s'] * 1e3:.3f} ms per solve; "
              f"exact/scm3 {tg[f'exact_ratio{suffix}']:.0f}x; fem/scm at equal accuracy "
              f"(smooth) {tg.get(f'equal_smooth_{timing}_ratio', nan):.1f}x, (suite) "
              f"{tg.get(f'equal_suite_{timing}_ratio', nan):.1f}x", file=sys.stderr)
    return 0
