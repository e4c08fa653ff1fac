"""`flexgen plot SCENE -o FILE.png|svg`: draw the unloaded and loaded scene with its compliance
ellipses (flexgen/plot.py). Exit codes as `flexgen solve`: 1 no equilibrium, 2 bad input."""

from __future__ import annotations

import sys
from pathlib import Path

from flexgen.commands.common import UsageError
from flexgen.commands.solve import add_model_options, solve_args

SUFFIXES = (".png", ".svg")


def register(sub) -> None:
    p = sub.add_parser(
        "plot",
        help="draw a solved scene with its compliance ellipses (PNG/SVG)",
        description=(
            "Solve a scene and draw it as the paper's Fig. 7: unloaded (dashed) and loaded "
            "shapes of "
            "every flexure, rigid links, tendons, load arrows, and the compliance ellipses of the "
            "output points (scaled to be visible; the legend gives the scale)."
        ),
    )
    add_model_options(p)
    p.add_argument(
        "-o",
        "--output",
        required=True,
        type=Path,
        metavar="FILE",
        help="output file; the suffix picks the format: .png or .svg",
    )
    p.set_defaults(run=run)


def run(args) -> int:
    if args.output.suffix.lower() not in SUFFIXES:
        raise UsageError(f"-o: the plot file must end in .png or .svg, got {str(args.output)!r}")
    scene, result, exact = solve_args(args)
    if not result.converged:
        reason = " ".join(str(result.reason or "not converged").split())
        print(f"flexgen: no equilibrium: {reason}", file=sys.stderr)
        return 1
    from flexgen.plot import draw

    print(draw(scene, result, args.output, exact_solution=exact))
    return 0
