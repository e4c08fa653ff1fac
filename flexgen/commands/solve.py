"""`flexgen solve SCENE`: equilibrium, stability and compliance ellipses of a scene.

Exit codes: 0 an equilibrium was found; 1 none was found (one line on stderr with the reason;
with --json the object with "converged": false and "reason" still goes to stdout); 2 bad input
(raised as SceneError or UsageError, reported by flexgen/cli.py, which with --json also prints
the object of a scene that could not be solved).

``add_model_options`` and ``solve_args`` are shared with `flexgen plot`.
"""

from __future__ import annotations

import sys

from flexgen.commands.common import ExamplesFormatter, UsageError, integer, printable, tolerance
from flexgen.models.registry import MODEL_KINDS
from flexgen.scene import MAX_ELEMENTS, MAX_MODES


def add_model_options(p) -> None:
    """SCENE, --model, --modes, --elements: the arguments `solve` and `plot` share."""
    p.add_argument("scene", metavar="SCENE", help="scene file (TOML; see docs/scene.md)")
    p.add_argument(
        "--model",
        choices=MODEL_KINDS,
        metavar="KIND",
        help="model of every flexure, overriding the scene's [model] and per-flexure "
        "kinds: scm (smooth curvature, Legendre modes), cc (constant curvature, "
        "= scm with 1 mode), prb (pseudo-rigid-body 1R), fem (chain of rigid "
        "elements and torsion springs), exact (elastica by shooting; slow)",
    )
    p.add_argument(
        "--modes",
        type=integer(1, MAX_MODES),
        metavar="N",
        help="scm: Legendre curvature modes of every flexure (overrides the scene; "
        f"1..{MAX_MODES} with the checked-in kernels)",
    )
    p.add_argument(
        "--elements",
        type=integer(1, MAX_ELEMENTS),
        metavar="N",
        help=f"fem: rigid elements per flexure, 1..{MAX_ELEMENTS} (overrides the scene)",
    )
    p.add_argument(
        "--tol",
        type=tolerance,
        dest="tolerance",
        metavar="T",
        help="choose per scm flexure the fewest modes (and the kernel) whose error "
        "estimate on the output poses and compliances is <= T (relative, in (0, 1); not with "
        "--modes or --elements); the result reports the choice and the estimate "
        "(docs/selection.md)",
    )


# extra argparse dests forwarded to flexgen.api.solve_scene
OPTION_NAMES = ["tolerance"]


def solve_args(args):
    """Load the scene, apply the command-line overrides and solve:
    ``(scene, Result, exact SceneSolution or None)``. Bad input raises SceneError/UsageError."""
    from flexgen.api import (
        as_scene,
        override,
        replaced_tolerance_note,
        solve_scene,
        unused_count_message,
    )
    from flexgen.kernels import KernelNotFound
    from flexgen.models.registry import ModelError

    if getattr(args, "tolerance", None) is not None and (args.modes or args.elements):
        raise UsageError("--tol chooses the modes itself: give either --tol or --modes/--elements")
    scene = as_scene(args.scene)
    kinds = (f.model.kind for f in scene.flexures)
    refusal = unused_count_message(args.model, args.modes, args.elements, kinds, flag="--")
    if refusal is not None:  # e.g. --model cc --modes 3 would solve one mode silently
        raise UsageError(refusal)
    given = scene
    scene = override(scene, args.model, args.modes, args.elements)
    options = {
        name: getattr(args, name) for name in OPTION_NAMES if getattr(args, name, None) is not None
    }
    try:
        result, exact = solve_scene(scene, **options)
    except (ModelError, KernelNotFound) as exc:  # e.g. --modes 12: no such kernel
        raise UsageError(" ".join(str(exc).split())) from None
    if options.get("tolerance") is None:
        note = replaced_tolerance_note(given, scene, args.model, args.modes)
        if note is not None:
            result.notes.append(note)
    return scene, result, exact


def register(sub) -> None:
    p = sub.add_parser(
        "solve",
        help="solve a scene: loaded shape, stability, compliance ellipses",
        description=(
            "Solve a scene (flexures, rigid links, dead loads, tendons) by load continuation "
            "from the unloaded state, and report each output point's pose and compliance (the "
            "table: its ellipse; --json: the 2x2 and the 3x3 compliance3) with their error "
            "estimates, and each flexure's largest "
            "curvature, strain and stress, where it is, their error estimate and the safety "
            "factor against the scene's strengths (when the scene gives a section), in the "
            "scene's units. Without --json: a table. Exit codes: 0 equilibrium found, 1 no "
            "equilibrium "
            "(reason on stderr), 2 bad input (one line on stderr naming the key). With --json, stdout "
            'holds the JSON object in every case: "converged": false and "reason" when there is '
            "no answer."
        ),
        epilog=(
            "examples:\n"
            "  flexgen solve examples/two_link_finger.toml\n"
            "  flexgen solve examples/two_link_finger.toml --json > answer.json\n"
            "  flexgen solve examples/cantilever_tip_load.toml --model fem --elements 32\n"
            "  flexgen solve examples/steel_finger.toml --tol 1e-4"
        ),
        formatter_class=ExamplesFormatter,
    )
    add_model_options(p)
    p.add_argument(
        "--json",
        action="store_true",
        help="print the result as one JSON object (the fields of the public contract, "
        'plus "reason" when not converged)',
    )
    p.set_defaults(run=run)


def run(args) -> int:
    _, result, _ = solve_args(args)
    print(result.to_json(indent=2) if args.json else printable(result.table()))
    if not result.converged:
        print(f"flexgen: no equilibrium: {one_line(result.reason)}", file=sys.stderr)
        return 1
    return 0


def one_line(reason) -> str:
    """A failure reason as one printable line."""
    return printable(" ".join(str(reason or "not converged").split()))
