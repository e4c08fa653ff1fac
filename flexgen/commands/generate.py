"""`flexgen generate`: emit flexure kernels (NumPy modules, C99 sources), or with --scene a
self-contained C solver of one mechanism for a controller."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from flexgen.codegen.spec import BACKENDS, DEFAULT_TOL, FAMILIES, MAX_MODES, KernelSpec
from flexgen.codegen.spec import DEFAULT_RANGE_DEG as RANGE
from flexgen.commands.common import ExamplesFormatter, UsageError, integer, output_path

LANGS = tuple(BACKENDS)  # each with its config (codegen/spec.py) and emitter (codegen/generate.py)


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
        help="emit flexure kernels (NumPy, C99), or a scene's C solver (--scene)",
        description=(
            "Emit the kernel of one flexure: tip pose, Jacobian and Hessian in closed form. "
            "Without "
            f"--modes, regenerates the checked-in set (scm1..scm{MAX_MODES} polynomial at 90 "
            f"degrees, Gauss kernels for 1..{MAX_MODES} modes certified on 180 degrees, and local "
            f"Gauss kernels for 1..{MAX_MODES} modes, which certify their error at each q). With --check, writes nothing and exits 1 naming the files in "
            "--out that differ from a fresh generation. With --scene, emits instead a "
            "self-contained C99 solver of that mechanism for a controller: NAME.h, NAME.c, "
            "NAME_example.c, CMakeLists.txt and NAME.mk (docs/controller.md)."
        ),
        epilog=(
            "examples:\n"
            "  flexgen generate --modes 4 --out mykernels\n"
            "  flexgen generate --modes 4 --kernel local --prefix arm --lang c --out mykernels\n"
            "  flexgen generate --scene examples/two_link_finger.toml --out finger_controller"
        ),
        formatter_class=ExamplesFormatter,
    )
    gen.add_argument(
        "--scene",
        type=Path,
        metavar="SCENE.toml",
        help="emit the C solver of this scene (its loads and tensions become inputs; geometry, "
        "stiffness, models and solver settings constants) into --out",
    )
    gen.add_argument(
        "--prefix",
        metavar="NAME",
        help="prefix of every emitted file and external C symbol (--scene: default the scene "
        "file's stem; kernels: NAME_scmN_evaluate, so that they link beside the shipped ones)",
    )
    gen.add_argument(
        "--float",
        dest="single",
        action="store_true",
        help="--scene: the single-precision twin (its accuracy is stated in NAME.h)",
    )
    gen.add_argument("--modes", type=integer(), help=f"Legendre curvature modes N (1..{MAX_MODES})")
    gen.add_argument(
        "--kernel",
        choices=FAMILIES,
        help="(default poly) poly: cos/sin as a Chebyshev polynomial on the range (closed-form "
        "polynomial in q); gauss: Gauss-Legendre quadrature, any angle; local: "
        "Gauss-Legendre quadrature with few nodes whose in_range(q) certifies the error "
        "at each q",
    )
    gen.add_argument(
        "--range",
        type=float,
        dest="range_deg",
        metavar="DEG",
        help="angle range in degrees: poly kernels are valid on |phi| <= DEG "
        f"(default {RANGE['poly']:g}, must be < 180); gauss kernels certify their bound there "
        f"(default {RANGE['gauss']:g}); local kernels take the nodes that certify the "
        f"constant-curvature arc of this bend (default {RANGE['local']:g})",
    )
    how = gen.add_mutually_exclusive_group()
    how.add_argument("--degree", type=integer(), help="poly: interpolation degree of cos and sin")
    how.add_argument(
        "--tol",
        type=float,
        help="poly: bound on the cos/sin error on the range, and on the pose error with "
        "double rounding; gauss: bound on the pose error (not with --nodes); local: the pose "
        "error certified at each q (J: 10x, H: 100x) "
        f"(default {DEFAULT_TOL:g}, units of the flexure length)",
    )
    gen.add_argument("--nodes", type=integer(), help="gauss, local: number of quadrature nodes")
    gen.add_argument(
        "--lang",
        type=_langs,
        default=LANGS,
        metavar="LIST",
        help="comma-separated backends: numpy,c (default both)",
    )
    gen.add_argument(
        "--out",
        type=output_path,
        help="output folder (default: ./generated for kernels, ./NAME for --scene, under the "
        "current folder; a kernel of your own is never written into the package's shipped "
        "kernels, which in an editable checkout are its ./generated)",
    )
    gen.add_argument(
        "--check",
        action="store_true",
        help="write nothing; exit 1 and name the stale files if --out differs",
    )
    gen.set_defaults(run=run)


def run(args) -> int:
    if args.scene is not None:
        return _run_scene(args)
    if args.single:
        raise UsageError("--float needs --scene (the kernels always have a float variant)")
    return _run_kernels(args)


def _run_scene(args) -> int:
    from flexgen.codegen.controller import check_prefix, controller_files, default_prefix
    from flexgen.codegen.render import stale_files, write_files
    from flexgen.outfiles import check_writable

    given = [
        f"--{n}"
        for n in ("modes", "kernel", "degree", "nodes", "tol")
        if getattr(args, n) is not None
    ]
    if args.range_deg is not None:
        given.append("--range")
    if tuple(args.lang) != tuple(LANGS):  # the controller is C (found by review: ignored)
        given.append("--lang")
    if given:
        raise UsageError(f"{', '.join(given)}: not used with --scene (the scene chooses models)")
    # the prefix checked first (its error is the one line, before --out's), and without
    # --prefix worded for the scene file's name, which it then comes from
    if args.prefix is not None:
        prefix = check_prefix(args.prefix)
    else:
        prefix = check_prefix(default_prefix(args.scene), args.scene)
    out = args.out if args.out is not None else Path(prefix)
    if not args.check:
        check_writable(out)
    start = time.perf_counter()
    files = controller_files(args.scene, args.prefix, args.single)
    if args.check:
        stale = stale_files(files, out)
        if stale:
            print(f"flexgen: stale in {out}: {' '.join(stale)}", file=sys.stderr)
            return 1
        print(f"{len(files)} files in {out} are up to date", file=sys.stderr)
        return 0
    written = write_files(files, out)  # said once written: a failed write is the only line
    print(
        f"{args.scene}: {len(files)} files ({time.perf_counter() - start:.1f} s)", file=sys.stderr
    )
    for path in written:
        print(path)
    return 0


def _refuse_the_shipped_folder(out: Path) -> None:
    """A kernel of one's own is not written into the package's shipped kernels (in an editable
    checkout, ./generated at its root *is* them: review, `flexgen generate --modes 4 --range 60`
    there replaced the shipped scm4 and the core was stale); only the checked-in set is
    regenerated there (`make regen`)."""
    from flexgen.kernels import GENERATED

    folders = [Path()] + [Path(c.folder) for c in BACKENDS.values()]
    shipped = {(GENERATED / f).resolve() for f in folders}
    # out itself, or a language's folder in it (a symbolic link into the shipped set: review)
    if any((out / f).resolve() in shipped for f in folders):
        raise UsageError(
            f"--out: {out} is, or links into, flexgen's shipped kernels (flexgen.generated), "
            "and a kernel of your own there would replace one of them: give another folder "
            "(`make regen` regenerates the shipped set)"
        )


def _run_kernels(args) -> int:
    from flexgen.codegen.generate import CHECKED_IN, generate_files
    from flexgen.codegen.render import stale_files, write_files
    from flexgen.outfiles import check_writable

    out = args.out if args.out is not None else Path("generated")
    if not args.check:
        check_writable(out)
        for folder in sorted({out / BACKENDS[lang].folder for lang in args.lang}):
            # each language's folder too (review: a read-only out/c or a file named out/numpy
            # failed at the first write, exit 1 with the system's words)
            check_writable(folder)
    elif out.exists() and not out.is_dir():  # as without --check (it said "stale in", exit 1)
        raise UsageError(f"--out: {out} is not a folder")
    if args.modes is None:
        # the checked-in set has its own kernels, ranges and tolerances: an option for one
        # kernel is a mistake here, not something to ignore
        given = [
            f"--{n}"
            for n, v in (
                ("kernel", args.kernel),
                ("degree", args.degree),
                ("nodes", args.nodes),
                ("range", args.range_deg),
                ("tol", args.tol),
            )
            if v is not None
        ]
        if given:
            raise UsageError(
                f"{', '.join(given)}: need --modes (without it, the checked-in set "
                "is regenerated as it is)"
            )
        specs = CHECKED_IN
    else:
        tol = DEFAULT_TOL if args.tol is None else args.tol
        kernel = "poly" if args.kernel is None else args.kernel
        if kernel == "gauss" and args.nodes is not None and args.tol is not None:
            # as poly's --degree with --tol: the nodes fix the bound (it was ignored silently)
            raise UsageError(
                "--tol: not allowed with --nodes for --kernel gauss (the nodes fix its error "
                "bound; without --nodes, the fewest nodes that meet --tol)"
            )
        specs = (KernelSpec(args.modes, kernel, args.range_deg, args.degree, args.nodes, tol),)
    if not args.check and (args.modes is not None or args.prefix is not None):
        _refuse_the_shipped_folder(out)
    files: dict[str, str] = {}
    for i, spec in enumerate(specs, 1):
        start = time.perf_counter()
        new = generate_files(spec, args.lang, _kernel_prefix(args.prefix))
        if not args.check:  # before its progress line: the error is the one line
            _check_case_clash(new, out, "--out" if args.prefix is None else "--prefix")
        files |= new
        if len(specs) > 1:  # progress through the shipped set (minutes); one kernel: no line
            print(
                f"[{i}/{len(specs)}] {', '.join(sorted(new))} "
                f"({time.perf_counter() - start:.1f} s)",
                file=sys.stderr,
            )
    if args.check:
        stale = stale_files(files, out)
        if stale:
            print(
                f"flexgen: stale in {out}: {' '.join(stale)} (the same command without --check "
                "rewrites them; in a checkout, `make regen`)",
                file=sys.stderr,
            )
            return 1
        print(f"{len(files)} files in {out} are up to date", file=sys.stderr)
        return 0
    for path in write_files(files, out):
        print(path)
    return 0


def _check_case_clash(files: dict[str, str], out: Path, option: str) -> None:
    """UsageError if out already holds a file whose name differs from one to be written only
    in case (`--prefix Arm` beside arm_scm2.h): their macros and header guard, upper case,
    would be the same, and a case-insensitive file system would take one for the other. As
    for controllers (docs/controller.md), prefixes must differ in more than case."""
    for rel in sorted(files):
        path = out / rel
        if not path.parent.is_dir():
            continue
        for other in sorted(p.name for p in path.parent.iterdir()):
            if other != path.name and other.lower() == path.name.lower():
                raise UsageError(
                    f"{option}: {path.name} and the {other} in {path.parent} differ only in "
                    "case (they would share macros and header guard); use a prefix that "
                    "differs in more than case"
                )


def _kernel_prefix(prefix: str | None) -> str:
    if prefix is None:
        return ""
    from flexgen.codegen.controller import check_prefix

    return check_prefix(prefix)
