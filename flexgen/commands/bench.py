"""`flexgen bench`: accuracy against speed of every model on a fixed suite (docs/accuracy-vs-speed).

The work is ``flexgen_tools.bench`` (imported here only when the command runs: the runtime never
imports flexgen_tools); it needs a source checkout (examples/)."""

from __future__ import annotations

import sys
from pathlib import Path

from flexgen.commands.common import UsageError, integer, output_path, require_extra


def register(sub) -> None:
    p = sub.add_parser(
        "bench",
        help="accuracy against speed of every model on a fixed suite",
        description=(
            "Solve the examples and a seeded set of random chains and trees with every model (cc, "
            "prb, scm2..6 with the poly, the gauss and the local kernel, fem 4..64, exact); measure "
            "pose and compliance errors against exact; time per solve three ways (flexgen.solve through "
            "the API, a prepared Solver.solve(), the bare core call), the kernel evaluations per "
            "solve where the core counts them, and ns per C kernel call; write "
            "accuracy-vs-speed.png (log-log, Pareto fronts) and accuracy-vs-speed.md into --out. "
            "Needs a source checkout (examples/). About a minute on an idle 2-core machine; set "
            "OPENBLAS_NUM_THREADS=1 (make bench-models does) for stable timings."
        ),
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="a few scenes and models (for the tests; well under a minute)",
    )
    p.add_argument(
        "--out",
        type=output_path,
        default=Path("docs"),
        help="output folder (default docs/ under the current folder; make bench-models writes "
        "the checkout's pages)",
    )
    p.add_argument(
        "--random",
        type=integer(1),
        default=None,
        metavar="N",
        help="number of random scenes (default 20, quick 1)",
    )
    p.set_defaults(run=run)


def run(args) -> int:
    try:
        from flexgen_tools import NeedsCheckout
        from flexgen_tools.bench import PAGES, TIMINGS, run_bench, timing_inconsistencies
    except ImportError as exc:
        raise UsageError(
            f"flexgen bench needs the flexgen_tools package of a source checkout ({exc})"
        ) from None
    from flexgen.outfiles import check_writable

    check_writable(args.out, PAGES)  # before minutes of solving, not after
    require_extra(  # its chart
        "matplotlib", "flexgen bench draws its chart with matplotlib: pip install 'flexgen[plot]'"
    )
    try:
        data = run_bench(quick=args.quick, out=args.out, n_random=args.random)
    except NeedsCheckout as exc:
        raise UsageError(str(exc)) from None
    tg = data.targets
    print(
        f"wrote {args.out / 'accuracy-vs-speed.md'} and {args.out / 'accuracy-vs-speed.png'} "
        f"({data.elapsed:.0f} s)"
    )
    nan = float("nan")
    for timing, label in TIMINGS.items():
        print(
            f"{label}: finger scm3 {tg[f'finger_scm3_{timing}'] * 1e6:.1f} us per solve; "
            f"exact/scm3 {tg[f'exact_ratio_{timing}']:.0f}x; fem/scm at equal accuracy "
            f"(smooth) {tg.get(f'equal_smooth_{timing}_ratio', nan):.1f}x, (suite) "
            f"{tg.get(f'equal_suite_{timing}_ratio', nan):.1f}x",
            file=sys.stderr,
        )
    print(
        f"finger scm3: flexgen.solve / core call {tg['finger_api_core_ratio']:.1f}x, "
        f"Solver.solve() - core call {tg['finger_overhead_s'] * 1e6:.1f} us",
        file=sys.stderr,
    )
    busy = timing_inconsistencies(data)
    if busy:
        print(
            f"flexgen: warning: the times of this run are not consistent ({busy[0]}"
            f"{f' and {len(busy) - 1} more' if len(busy) > 1 else ''}): the machine was busy; "
            "run again on an idle machine before quoting them",
            file=sys.stderr,
        )
    return 0
