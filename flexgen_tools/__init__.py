"""Tools that measure flexgen, never imported by the runtime.

The runtime package ``flexgen`` solves scenes; this package measures it and is imported only by
the tests, the scripts under ``benchmarks/`` and, lazily, by the commands ``flexgen bench`` and
``flexgen stability`` (``flexgen/commands/bench.py``, ``flexgen/commands/stability.py``):

    flexgen_tools.bench      accuracy against speed of every model (``flexgen bench``)
    flexgen_tools.stability  load sweeps, each answer against its error estimate, buckling
                             loads (``flexgen stability``)
    flexgen_tools.honesty    the seeded suite that measures the mode selection (flexgen.select)
                             against the exact elastica (benchmarks/selection.py, the tests)
    flexgen_tools.estimate_honesty
                             every answer's error estimate against the exact elastica
                             (benchmarks/estimate.py --honesty, tests/test_estimate.py)
    flexgen_tools.timing     how a solve is timed: through ``flexgen.solve``, a prepared
                             ``Solver.solve()``, the bare core call

Some tools read files of the repository (``examples/``, ``benchmarks/``), which a wheel does not
install: they then stop with ``NeedsCheckout``, a one-line message.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import flexgen

# the folder above this package: a source checkout's root, or site-packages in an installed wheel
REPO = Path(__file__).resolve().parents[1]


class NeedsCheckout(RuntimeError):
    """A tool needs files of a source checkout of flexgen that this installation does not have."""


def is_checkout(root: Path) -> bool:
    """Is ``root`` a source checkout of the flexgen being measured: flexgen's pyproject.toml and
    the imported ``flexgen`` package beside each other? (In site-packages a folder such as
    ``benchmarks/`` may belong to any other distribution.)"""
    try:
        with open(root / "pyproject.toml", "rb") as f:
            name = tomllib.load(f).get("project", {}).get("name")
    except (OSError, tomllib.TOMLDecodeError):
        return False
    return name == "flexgen" and (root / "flexgen").resolve() == Path(flexgen.__file__).parent


def repo_path(relative: str, what: str = "this tool") -> Path:
    """``REPO / relative`` of a source checkout, or NeedsCheckout (one line) if REPO is not one
    (an installed wheel) or the file is not there."""
    path = REPO / relative.rstrip("/")
    if not (is_checkout(REPO) and path.exists()):
        raise NeedsCheckout(
            f"{what} needs a source checkout of flexgen ({relative} is not "
            f"installed with the package): run it from a clone of the repository"
        )
    return path
