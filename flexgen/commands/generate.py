"""`flexgen generate`: emit flexure kernels (NumPy modules, C99 sources) into generated/."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from flexgen.codegen.spec import FAMILIES, KernelSpec
from flexgen.commands.common import UsageError, integer

LANGS = ("numpy", "c")


def _langs(text: str) -> tuple[str, ...]:
    langs = tuple(x.strip() for x in text.split(",") if x.strip())
    bad = [x for x in langs if x not in LANGS]
    if bad or not langs:
        raise argparse.ArgumentTypeError(
            f"unknown language {', '.join(bad) or repr(text)} (choose from {', '.join(LANGS)})"
        )
    return langs


def register(sub) -> None:
    gen = sub.add_parser(
        "generate",
        help="emit flexure kernels (NumPy modules, C99 sources)",
        description=(
            "Emit the kernel of one flexure: tip pose, Jacobian and Hessian in closed form. "
            "Without "
            "--modes, regenerates the checked-in set (scm1..scm8 polynomial at 90 degrees, Gauss "
            "kernels for 1..6 modes). With --check, writes nothing and exits 1 naming the files in "
            "--out that differ from a fresh generation."
        ),
    )
    gen.add_argument("--modes", type=integer(), help="Legendre curvature modes N (1..8)")
    gen.add_argument(
        "--kernel",
        default="poly",
        choices=FAMILIES,
        help="poly: cos/sin as a Chebyshev polynomial on the range (closed-form "
        "polynomial in q); gauss: Gauss-Legendre quadrature, any angle",
    )
    gen.add_argument(
        "--range",
        type=float,
        dest="range_deg",
        metavar="DEG",
        help="angle range in degrees: poly kernels are valid on |phi| <= DEG "
        "(default 90, must be < 180); gauss kernels certify their bound there "
        "(default 180)",
    )
    how = gen.add_mutually_exclusive_group()
    how.add_argument("--degree", type=integer(), help="poly: interpolation degree of cos and sin")
    how.add_argument(
        "--tol",
        type=float,
        default=1e-10,
        help="poly: bound on the cos/sin error on the range; gauss: bound on the "
        "pose error (default 1e-10, units of the flexure length)",
    )
    gen.add_argument("--nodes", type=integer(), help="gauss: number of quadrature nodes")
    gen.add_argument(
        "--lang",
        type=_langs,
        default=LANGS,
        metavar="LIST",
        help="comma-separated backends: numpy,c (default both)",
    )
    gen.add_argument(
        "--out",
        type=Path,
        default=Path("generated"),
        help="output folder (default: ./generated under the current folder; the "
        "kernels shipped inside the package are never overwritten)",
    )
    gen.add_argument(
        "--check",
        action="store_true",
        help="write nothing; exit 1 and name the stale files if --out differs",
    )
    gen.set_defaults(run=run)


def run(args) -> int:
    from flexgen.codegen.generate import CHECKED_IN, generate_files
    from flexgen.codegen.render import stale_files, write_files

    if args.modes is None:
        if args.degree or args.nodes or args.range_deg is not None:
            raise UsageError("--degree, --nodes and --range need --modes")
        specs = CHECKED_IN
    else:
        specs = (
            KernelSpec(args.modes, args.kernel, args.range_deg, args.degree, args.nodes, args.tol),
        )
    files: dict[str, str] = {}
    for i, spec in enumerate(specs, 1):
        start = time.perf_counter()
        new = generate_files(spec, args.lang)
        files |= new
        print(
            f"[{i}/{len(specs)}] {', '.join(sorted(new))} ({time.perf_counter() - start:.1f} s)",
            file=sys.stderr,
        )
    if args.check:
        stale = stale_files(files, args.out)
        if stale:
            print(
                f"flexgen: stale in {args.out}: {' '.join(stale)} (run `make regen`)",
                file=sys.stderr,
            )
            return 1
        print(f"{len(files)} files in {args.out} are up to date", file=sys.stderr)
        return 0
    for path in write_files(files, args.out):
        print(path)
    return 0
