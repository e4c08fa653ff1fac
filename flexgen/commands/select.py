"""`flexgen select SCENE --tol T`: the fewest modes per flexure that meet T, with their cost.

Prints, per flexure, the chosen modes, the kernel at equilibrium and its share of the error
estimate, then the estimate of the whole answer and the cost of the chosen models (time per solve,
equilibrium + compliance, measured here; op count per call of the C kernels). Exit codes: 0 when
T is met, 1 when it is out of reach (or the scene has no equilibrium), 2 for bad input (including
T <= 0), with a one-line message.
"""

from __future__ import annotations

import sys
from pathlib import Path

from flexgen.codegen.spec import MAX_MODES
from flexgen.commands.common import ExamplesFormatter, integer, printable, tolerance
from flexgen.commands.solve import one_line


def register(sub) -> None:
    p = sub.add_parser(
        "select",
        help="choose the fewest modes per flexure that meet a tolerance",
        description=(
            f"Choose, per flexure, the fewest smooth curvature modes (1..{MAX_MODES}) and the "
            "kernel whose "
            "a-posteriori error estimate on the output points' poses (relative to length) and "
            "compliances (relative, spectral norm) is <= TOL, and print the choice with its "
            "estimate and cost. Exit 1 if TOL is out of reach (the best estimate is printed)."
        ),
        epilog=(
            "examples:\n"
            "  flexgen select examples/two_link_finger.toml --tol 1e-6\n"
            "  flexgen select examples/steel_finger.toml --tol 1e-4 --json"
        ),
        formatter_class=ExamplesFormatter,
    )
    p.add_argument("scene", type=Path, metavar="SCENE", help="scene file (TOML)")
    p.add_argument(
        "--tol",
        type=tolerance,
        required=True,
        metavar="T",
        help="tolerance on the relative error of poses and compliances (a number in (0, 1))",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print the solved Result as JSON (with modes and error estimates)",
    )
    p.add_argument(
        "--repeat",
        type=integer(0, 1000),  # (1e8 timed solves ran on for minutes: review)
        default=5,
        metavar="N",
        help="solves timed for the cost (best of N, default 5, at most 1000; 0 skips timing)",
    )
    p.set_defaults(run=run)


def run(args) -> int:
    from flexgen import select
    from flexgen.scene import load_scene

    scene = load_scene(args.scene)
    sel = select.select_models(scene, args.tol)
    res = sel.result
    if args.json:
        print(res.to_json(indent=2))
    else:
        print(printable(report(scene, sel, args.repeat)))
    if not res.converged:
        print(
            f"flexgen: {printable(str(args.scene))}: no equilibrium: {one_line(res.reason)}",
            file=sys.stderr,
        )
        return 1
    if not sel.reached:
        print(f"flexgen: {one_line(sel.message)}", file=sys.stderr)
        return 1
    return 0


def report(scene, sel, repeat: int = 5) -> str:
    """The human-readable choice: one line per flexure, the total estimate and the cost."""
    from flexgen import select

    lines = [f"scene: {scene.name}    tolerance {sel.tolerance:.3g}"]
    if not sel.choices:
        lines.append(f"  {sel.message}")
        return "\n".join(lines)
    w = max(8, *(len(n) for n in sel.choices))
    lines.append(
        f"  {'flexure':<{w}}  {'modes':>5}  {'kernel':<6}  {'estimate':>9}  "
        f"{'C ops/call':>10}  (rich model)"
    )
    for name, c in sel.choices.items():
        ops = select.kernel_ops(c.modes, c.kernel)
        lines.append(
            f"  {name:<{w}}  {c.modes:>5}  {c.kernel:<6}  {c.error_estimate:>9.2e}  "
            f"{ops if ops is not None else '?':>10}  (scm{c.rich})"
        )
    if sel.reached:
        verdict = f"meets {sel.tolerance:.3g}"
    elif sel.error_estimate <= sel.tolerance:  # a bend past the certified one: no claim
        verdict = f"below {sel.tolerance:.3g}, but not claimed"
    else:
        verdict = f"DOES NOT meet {sel.tolerance:.3g}"
    lines.append(f"  error estimate of the whole answer: {sel.error_estimate:.2e} ({verdict})")
    if repeat > 0 and sel.result.converged:
        t = select.time_per_solve(scene, sel.modes, repeat=repeat)
        lines.append(
            f"  cost: {t * 1e6:.1f} us per solve (equilibrium + compliance, chosen "
            f"models, prepared solver, best of {repeat})"
        )
    lines.append(f"  selection: {sel.solves} solves in {sel.seconds * 1e3:.0f} ms")
    # the answer's own warnings (a tolerance out of reach among them) and notes, as solve's
    lines += [f"  warning: {w}" for w in sel.result.warnings]
    lines += [f"  note: {n}" for n in sel.result.notes]
    return "\n".join(lines)
