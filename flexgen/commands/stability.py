"""`flexgen stability`: where each model fails under a load sweep (docs/stability.md).

The work is ``flexgen_tools.stability`` (imported here only when the command runs: the runtime
never imports flexgen_tools); it needs a source checkout (examples/)."""

from __future__ import annotations

import sys
from pathlib import Path

from flexgen.commands.common import UsageError, output_path, require_extra


def register(sub) -> None:
    p = sub.add_parser(
        "stability",
        help="load sweeps: where each model fails, buckling loads",
        description=(
            "Sweep a dead load's magnitude (alpha = P L^2/EI up to 20) and direction (0-360 deg) "
            "on a cantilever and on the two-link finger; for every model record converged, kernel"
            " out of range, stable/buckled, error against exact and the answer's error estimate;"
            " check that no answer is wrong beyond its estimate without a warning; report the "
            "first three buckling loads of scm 3..8. "
            "Writes stability-map.png and stability.md into --out. Exit 1 if a silent failure is "
            "found. Needs a source checkout (examples/)."
        ),
    )
    p.add_argument("--quick", action="store_true", help="a small grid and a few models")
    p.add_argument(
        "--out",
        type=output_path,
        default=Path("docs"),
        help="output folder (default docs/ under the current folder; make bench-models writes "
        "the checkout's pages)",
    )
    p.set_defaults(run=run)


def run(args) -> int:
    try:
        from flexgen_tools import NeedsCheckout
        from flexgen_tools.stability import PAGES, run_stability
    except ImportError as exc:
        raise UsageError(
            f"flexgen stability needs the flexgen_tools package of a source checkout ({exc})"
        ) from None
    from flexgen.outfiles import check_writable

    check_writable(args.out, PAGES)  # before minutes of solving, not after
    require_extra(  # its chart
        "matplotlib",
        "flexgen stability draws its chart with matplotlib: pip install 'flexgen[plot]'",
    )
    try:
        data = run_stability(quick=args.quick, out=args.out)
    except NeedsCheckout as exc:
        raise UsageError(str(exc)) from None
    silent = [p for p in data.points if p.silent]
    print(
        f"wrote {args.out / 'stability.md'} and {args.out / 'stability-map.png'} "
        f"({data.elapsed:.0f} s)"
    )
    b5 = next((r for r in data.buckling if r["modes"] == 5), None)
    if b5:
        print(
            "scm5 buckling loads "
            + ", ".join(f"{x:.8g}" for x in b5["loads"])
            + " (rel. errors "
            + ", ".join(f"{x:.1e}" for x in b5["rel"])
            + ")",
            file=sys.stderr,
        )
    if silent:
        print(
            f"flexgen: {len(silent)} silent failures (see {args.out / 'stability.md'})",
            file=sys.stderr,
        )
        return 1
    return 0
