"""`flexgen sweep SCENE --vary KEY=START:STOP:COUNT|V1,V2,... ...`: a design study (flexgen/sweep.py).

Exit codes: 0 the study ran (cases without an equilibrium are rows with their reason, even
when no case has one: the summary line on stderr counts them); 1 the
work failed (a scheduler that cannot be reached, a full disk: the message names the file, and
nothing the run created is left behind) or an optional dependency is missing (Parquet without
pyarrow, --plot without matplotlib, --scheduler without dask: checked before anything is
solved); 2 bad input: an unknown key, two keys naming one value, COUNT < 1, a value the scene
refuses, an output that cannot be written, a --scheduler address that cannot be one (all
checked before anything is solved).
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path
from typing import Any

from flexgen.commands.common import (
    ExamplesFormatter,
    UsageError,
    integer,
    output_file,
    printable,
    require_extra,
)
from flexgen.outfiles import write_all
from flexgen.sweep_plan import CHUNK_SIZE, DISTRIBUTIONS, plan

TABLES = (".parquet", ".csv")
EXAMPLE = """\
examples:
  flexgen sweep examples/two_link_finger.toml \\
      --vary tendon.0.tension=0:10:11 --vary load.0.force.1=0:-1:5 --out finger.parquet
  flexgen sweep examples/two_link_finger.toml \\
      --vary flexure.proximal.thickness=0.2e-3,0.25e-3,0.3e-3 --vary tendon.0.tension=0:5:6
  flexgen sweep examples/two_link_finger.toml --samples 1000 --seed 1 \\
      --vary flexure.proximal.thickness=normal:0.25e-3:0.01e-3 --plot tolerance.png

KEY is a dotted path into the scene by names and indices: flexure.proximal.thickness,
flexure.0.length, load.0.force.1 (the y force of the first [[load]]), load.0.moment,
tendon.0.tension, model.modes, link.middle.points.pad.0. Values are plain numbers in the
scene's units (a scene with units = {length = "mm"} takes thickness=0.2:0.4:3 in mm). One row
per case; columns in docs/sweep.md; the table's units are the scene's."""


def register(sub) -> None:
    p = sub.add_parser(
        "sweep",
        help="a design study: a grid or Monte-Carlo sample of a scene's values, one row per case",
        description=(
            "Solve a scene for every case of a study: several --vary KEY=START:STOP:COUNT (or "
            "KEY=V1,V2,...) make a full factorial grid (rows in the order of the keys, the first slowest); with "
            "--samples N, --vary KEY=normal:MEAN:SD or KEY=uniform:LOW:HIGH draw N Monte-Carlo "
            "cases (--seed makes them reproducible). Prints the table as CSV, or writes it with "
            "--out; progress on stderr."
        ),
        epilog=EXAMPLE,
        formatter_class=ExamplesFormatter,
    )
    p.add_argument("scene", metavar="SCENE", help="scene file (TOML; see docs/scene.md)")
    p.add_argument(
        "--vary",
        action="append",
        required=True,
        metavar="KEY=SPEC",
        help="a varied key: KEY=START:STOP:COUNT (COUNT values from START to STOP), "
        "KEY=V1,V2,... (these values), or with --samples KEY=normal:MEAN:SD or "
        "KEY=uniform:LOW:HIGH; plain numbers in the scene's units; repeat for more keys",
    )
    p.add_argument("--samples", type=integer(1), metavar="N", help="Monte-Carlo: N cases")
    p.add_argument(
        "--seed",
        type=integer(0),
        metavar="S",
        help="Monte-Carlo: the random seed, so that a rerun draws the same cases (without it "
        "every run draws others)",
    )
    p.add_argument(
        "--out",
        type=output_file,
        metavar="FILE",
        help="write the table to FILE.parquet (needs pyarrow) or FILE.csv (default: CSV on stdout)",
    )
    p.add_argument(
        "--plot",
        type=output_file,
        metavar="FILE",
        help="draw the study (.png, .svg or .pdf): outputs against one key, heatmaps for two, "
        "histograms for Monte-Carlo",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on a Dask cluster (tcp://host:8786; needs pip install 'flexgen[cluster]')",
    )
    p.add_argument(
        "--workers",
        type=integer(1),
        metavar="N",
        help="processes on this machine: N as asked (at most one per chunk of --chunk-size "
        "cases: a study of one chunk runs in this process), 1 this process only (default: every "
        "core, or this process when a probe finds the study shorter than starting the workers)",
    )
    p.add_argument(
        "--chunk-size",
        type=integer(1),
        metavar="N",
        default=CHUNK_SIZE,
        help=f"cases per chunk (a task; its first case solves cold, the rest warm-start from a "
        f"neighbour): part of the study's definition (default {CHUNK_SIZE}); smaller chunks "
        f"spread a short study of slow cases over more workers",
    )
    p.add_argument(
        "--no-estimate",
        dest="estimate",
        action="store_false",
        help="skip the error estimate (its column is empty; about 20 %% faster without the stress columns: docs/sweep.md, Speed)",
    )
    p.add_argument(
        "--no-stress",
        dest="stress",
        action="store_false",
        help="skip the flexures' stress and safety factor (their columns are empty)",
    )
    p.set_defaults(run=run)


def parse_vary(items: list[str], monte_carlo: bool) -> dict[str, Any]:
    """``--vary`` texts as flexgen.sweep's ``vary``; UsageError naming the key otherwise."""
    vary: dict[str, Any] = {}
    for item in items:
        key, sep, spec = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise UsageError(f"--vary: expected KEY=START:STOP:COUNT, got {item!r}")
        if key in vary:
            raise UsageError(f"--vary {key}: given twice")
        if ":" not in spec:  # the values themselves (one, or several separated by commas)
            if monte_carlo:
                raise UsageError(
                    f"--vary {key}: with --samples, give normal:MEAN:SD or uniform:LOW:HIGH"
                )
            vary[key] = [_float(key, v) for v in spec.split(",")]
            continue
        parts = spec.split(":")
        if len(parts) != 3:
            raise UsageError(
                f"--vary {key}: expected START:STOP:COUNT, V1,V2,..., normal:MEAN:SD or "
                f"uniform:LOW:HIGH, "
                f"got {spec!r}"
            )
        head = parts[0].strip()
        if head.isalpha() and head not in DISTRIBUTIONS:
            raise UsageError(
                f"--vary {key}: {head!r} is neither a number nor a distribution "
                f"({', '.join(DISTRIBUTIONS)})"
            )
        if head in DISTRIBUTIONS:
            if not monte_carlo:
                raise UsageError(f"--vary {key}: a distribution ({head}) needs --samples N")
            vary[key] = (head, _float(key, parts[1]), _float(key, parts[2]))
            continue
        if monte_carlo:
            raise UsageError(
                f"--vary {key}: with --samples, give normal:MEAN:SD or uniform:LOW:HIGH"
            )
        try:
            if "_" in parts[2]:  # int() reads "1_0" too
                raise ValueError
            count = int(parts[2])
        except ValueError:
            raise UsageError(f"--vary {key}: COUNT must be an integer, got {parts[2]!r}") from None
        if count < 1:
            raise UsageError(f"--vary {key}: COUNT must be >= 1, got {count}")
        vary[key] = (_float(key, parts[0]), _float(key, parts[1]), count)
    return vary


def _float(key: str, text: str) -> float:
    try:
        if "_" in text:  # Python's float() reads "1_000"; a scene's TOML and units do not
            raise ValueError
        return float(text)
    except ValueError:
        raise UsageError(
            f"--vary {key}: expected a plain number, read in the scene's units as its own plain "
            f"numbers are, got {text!r}"
        ) from None


def run(args) -> int:
    from flexgen.drawing import PlotError, check_output

    out, plot = args.out, args.plot
    try:  # every output problem before the solve: nothing is solved for a file not written
        if out is not None:
            check_output(out, TABLES, "--out")
        if plot is not None:
            check_output(plot, option="--plot")
    except PlotError as exc:
        raise UsageError(str(exc)) from None
    if out is not None and out.suffix.lower() == ".parquet":
        require_extra(
            "pyarrow", "--out: writing Parquet needs pyarrow: pip install 'flexgen[parquet]'"
        )
    if plot is not None:
        require_extra("matplotlib", "--plot needs matplotlib: pip install 'flexgen[plot]'")
    if args.seed is not None and args.samples is None:
        raise UsageError("--seed: only with --samples N (a grid draws nothing)")
    vary = parse_vary(args.vary, args.samples is not None)

    from flexgen.scene import load_scene
    from flexgen.sweep import WorkerDied, own_process, sweep

    own_process()  # this command's workers ignore Ctrl-C from birth: flexgen/_forkserver_preload.py

    scene = load_scene(args.scene)
    plan(scene, vary, args.samples, args.seed)  # bad keys and values: exit 2 before a client
    try:
        client = None if args.scheduler is None else _client(args.scheduler)
    except SchedulerError as exc:
        print(f"flexgen: {printable(str(exc))}", file=sys.stderr)
        return 1
    start = time.perf_counter()
    try:
        df = sweep(
            scene,
            vary,
            samples=args.samples,
            seed=args.seed,
            workers=args.workers,
            client=client,
            progress=True,
            estimate=args.estimate,
            stress=args.stress,
            chunk_size=args.chunk_size,
        )
    except WorkerDied as exc:
        print(f"flexgen: {exc}", file=sys.stderr)
        return 1
    finally:
        if client is not None:
            client.close()
    failed = int((~df["converged"]).sum())
    print(
        f"sweep: {len(df)} case{'' if len(df) == 1 else 's'}, {failed} without an equilibrium, "
        f"{time.perf_counter() - start:.1f} s",
        file=sys.stderr,
    )

    def draw(path: Path) -> None:
        from flexgen.sweep_plot import draw_study

        draw_study(df, list(vary), args.samples is not None, path, scene.units)

    write_outputs(df, out, plot, draw)  # a WriteFailed (a full disk): the CLI's exit 1
    if out is None:
        # data, not text for a reader: UTF-8 whatever the terminal's encoding (the CLI escapes
        # what stdout cannot write, which would change a column's name: review)
        reconfigure = getattr(sys.stdout, "reconfigure", None)
        if reconfigure is not None:
            reconfigure(encoding="utf-8", errors="strict")
        df.to_csv(sys.stdout, index=False)
    else:
        print(printable(str(out)))
    return 0


def _client(address: str) -> Any:
    """A dask.distributed Client of the scheduler at ``address``: UsageError (exit 2) for an
    address that cannot be one, SchedulerError (exit 1) for one that cannot be reached."""
    require_extra(
        "distributed", "--scheduler needs dask.distributed: pip install 'flexgen[cluster]'"
    )
    from distributed import Client

    _check_address(address)
    # Client's timeout bounds the connection, not the handshake after it: a port that accepts
    # and stays silent (the dashboard's, 8787, for the scheduler's 8786) blocked for ever
    # (review). So the whole connection runs in a thread of its own, given CONNECT_DEADLINE.
    made: dict[str, Any] = {}

    def connect() -> None:
        try:
            made["client"] = Client(address, timeout=f"{CONNECT_TIMEOUT}s")
        except BaseException as exc:  # handed to the main thread below
            made["error"] = exc

    thread = threading.Thread(target=connect, name="flexgen-connect", daemon=True)
    thread.start()
    thread.join(CONNECT_DEADLINE)
    if thread.is_alive():
        raise SchedulerError(
            f"--scheduler: no Dask scheduler answered at {address!r} in {CONNECT_DEADLINE:g} s "
            "(is it the scheduler's port, 8786 by default, not the dashboard's?)"
        )
    exc = made.get("error")
    if exc is None:
        return made["client"]
    if isinstance(exc, ValueError):  # what the check above leaves to the scheme's own backend
        raise UsageError(f"--scheduler: not a scheduler address {address!r}: {exc}") from None
    if isinstance(exc, OSError | TimeoutError):
        raise SchedulerError(f"--scheduler: cannot reach {address!r}: {exc}") from None
    if isinstance(exc, Exception):  # a reply that is no Dask scheduler's, a scheme not set up
        hint = (
            "; tls needs a security context: flexgen.sweep(..., client=Client(address, "
            "security=...)) in Python"
            if address.startswith("tls://")
            else ""
        )
        raise SchedulerError(
            f"--scheduler: no Dask scheduler at {address!r}, or the handshake failed "
            f"({type(exc).__name__}: {' '.join(str(exc).split())[:200]}){hint}"
        ) from None
    raise exc  # a KeyboardInterrupt, SystemExit: as they came


def _check_address(address: str) -> None:
    """UsageError for an address Dask cannot read: an unknown scheme, or a host-and-port scheme
    (tcp, tls, ws, wss) without a port number in 1-65535. Dask itself reports these as a
    ValueError (or an AssertionError for 'tcp://host') from deep inside the Client."""
    from distributed.comm import get_address_host_port, parse_address
    from distributed.comm.registry import backends

    try:
        scheme, _ = parse_address(address)
        if scheme not in backends:
            raise ValueError(f"unknown scheme {scheme!r} (known: {', '.join(sorted(backends))})")
        if scheme in HOST_PORT_SCHEMES:
            _, port = get_address_host_port(address)
            if not 0 < port < 65536:
                raise ValueError(f"port {port} is not in 1-65535")
    except ValueError as exc:
        raise UsageError(
            f"--scheduler: not a scheduler address {address!r} ({exc}); give tcp://HOST:PORT"
        ) from None


HOST_PORT_SCHEMES = ("tcp", "tls", "ws", "wss")
# the Client's own connection timeout, and the deadline of the whole connection (handshake
# included) after which --scheduler gives up (s)
CONNECT_TIMEOUT, CONNECT_DEADLINE = 10.0, 20.0


class SchedulerError(Exception):
    """The scheduler given could not be reached (exit 1: the input may be right)."""


# -- the output files -------------------------------------------------------------------------


def write_outputs(df: Any, out: Path | None, plot: Path | None, draw: Any) -> None:
    """The table into ``out`` and the plot (``draw(path)``) into ``plot``, either None: all or
    nothing (flexgen/outfiles.py; WriteFailed names the file that failed)."""
    targets = [(out, _table_writer(df)), (plot, draw)]
    write_all([(target, write) for target, write in targets if target is not None])


def _table_writer(df: Any) -> Any:
    def write(tmp: Path) -> None:
        if tmp.suffix.lower() == ".parquet":
            df.to_parquet(tmp, index=False)
        else:
            df.to_csv(tmp, index=False)

    return write
