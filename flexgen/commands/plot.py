"""`flexgen plot SCENE -o FILE.png|svg|pdf`: draw the solved scene (flexgen/drawing.py). Exit
codes as `flexgen solve`: 1 no equilibrium (or matplotlib missing, or the file could not be
written: nothing is left behind), 2 bad input (including an output path that is a folder, a
symbolic link, a FIFO, or has another suffix than .png/.svg/.pdf), checked before the solve."""

from __future__ import annotations

import sys

from flexgen.commands.common import (
    ExamplesFormatter,
    UsageError,
    output_file,
    printable,
    require_extra,
)
from flexgen.commands.solve import add_model_options, one_line, solve_args


def register(sub) -> None:
    p = sub.add_parser(
        "plot",
        help="draw a solved scene: links, loads, stress, compliance ellipses (PNG/SVG/PDF)",
        description=(
            "Solve a scene and draw it as the paper's Fig. 7: rigid links as named bodies (an "
            "outline through the link's origin, its points and its child flexures' roots), the "
            "base, unloaded (dashed) and loaded flexures (coloured by stress, bending plus axial, or by "
            "curvature when a section is unknown, the largest value marked), tendons, load "
            "arrows to a scale the legend states, and the compliance ellipses of the output "
            "points (scaled to be visible; the legend gives the scale). Notes about the scene "
            "(e.g. a flexure that starts at its link's origin: a forgotten `at`) are printed "
            "by `flexgen solve`; the answer's warnings (what may make it wrong beyond its "
            "error estimate, a safety factor below 1) are printed on stderr. In Python, flexgen.plot(scene, result) draws on a matplotlib "
            "Axes and returns it (docs/solve.md)."
        ),
        epilog=(
            "examples:\n"
            "  flexgen plot examples/two_link_finger.toml -o finger.png\n"
            "  flexgen plot examples/arc_moment.toml --model exact -o arc.svg"
        ),
        formatter_class=ExamplesFormatter,
    )
    add_model_options(p)
    p.add_argument(
        "-o",
        "--output",
        required=True,
        type=output_file,
        metavar="FILE",
        help="output file; the suffix picks the format: .png, .svg or .pdf",
    )
    p.set_defaults(run=run)


def run(args) -> int:

    from flexgen.drawing import INSTALL_HINT, PlotError, check_output

    try:  # every output problem before the solve: nothing is solved for a plot not written
        check_output(args.output)
    except PlotError as exc:
        raise UsageError(str(exc)) from None
    require_extra("matplotlib", INSTALL_HINT)
    scene, result, exact = solve_args(args)
    if not result.converged:
        print(f"flexgen: no equilibrium: {one_line(result.reason)}", file=sys.stderr)
        return 1
    from flexgen.drawing import draw

    try:
        path = draw(scene, result, args.output, exact_solution=exact)
    except PlotError as exc:
        print(f"flexgen: {one_line(exc)}", file=sys.stderr)
        return 1
    except OSError as exc:  # e.g. a full disk: the temporary file is gone, the target untouched
        where = printable(str(exc.filename or args.output))
        print(f"flexgen: cannot write {where}: {exc.strerror or exc}", file=sys.stderr)
        return 1
    # the drawing cannot say what the answer may get wrong: its warnings as flexgen solve
    # gives them (review: a finger past yield, a load in the wrong units, plotted silently)
    for warning in result.warnings:
        print(f"flexgen: warning: {one_line(warning)}", file=sys.stderr)
    print(printable(str(path)))
    return 0
