"""Tools that measure flexgen, never imported by the runtime.

The runtime package ``flexgen`` solves scenes; this package measures it and is imported only by
the tests, the scripts under ``benchmarks/`` and, lazily, by the commands ``flexgen bench`` and
``flexgen stability`` (``flexgen/commands/bench.py``, ``flexgen/commands/stability.py``):

    flexgen_tools.bench      accuracy against speed of every model (``flexgen bench``)
    flexgen_tools.stability  load sweeps, each answer against its error estimate, buckling
                             loads (``flexgen stability``)
    flexgen_tools.honesty    the seeded suite that measures the mode selection (flexgen.select)
                             against the exact elastica (benchmarks/selection.py, the tests)
    flexgen_tools.timing     how a solve is timed: through ``flexgen.solve``, a prepared
                             ``Solver.solve()``, the bare core call

Some tools read files of the repository (``examples/``, ``benchmarks/``), which a wheel does not
install: they then stop with ``NeedsCheckout``, a one-line message.
"""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


class NeedsCheckout(RuntimeError):
    """A tool needs files of a source checkout of flexgen that this installation does not have."""


def repo_path(relative: str, what: str = "this tool") -> Path:
    """``REPO / relative``, or NeedsCheckout (one line) if it is not there (an installed wheel)."""
    path = REPO / relative.rstrip("/")
    if not path.exists():
        raise NeedsCheckout(
            f"{what} needs a source checkout of flexgen ({relative} is not "
            f"installed with the package): run it from a clone of the repository"
        )
    return path
