"""Wall-clock time of design studies through the public API (``flexgen.sweep``), one run.

    OPENBLAS_NUM_THREADS=1 python benchmarks/sweep.py

Studies, on the two-link finger (examples/two_link_finger.toml):

- *loads*: 10^4 load cases, tendon tension 0..10 N (100) x pad force 0..-1 N (100), one core
  (``workers=1``): one prepared Solver, each case warm-started from its neighbour; with the
  error estimate and the stress (the defaults), without the stress (``stress=False``), and
  without either. The first study of a fresh
  process pays the session's one-time costs (LAPACK and the kernels load): timed separately.
  For reference, the same cases through a prepared ``flexgen.Solver`` in a Python loop
  (``Solver.solve(loads=, tensions=, estimate=True)``, cold starts, a Result per case).
- *designs*: 20 proximal thicknesses (0.2..0.3 mm) x 20 proximal lengths (15..25 mm) x 10 pad
  forces = 4000 cases, 400 designs: one core, the default (``workers=None``: every core when
  the probe says it pays), and two worker processes forced (the first pool of the session, then
  the kept pool).

Prints a markdown table (the numbers of docs/sweep.md). No limit is asserted anywhere.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import flexgen  # noqa: E402

FINGER = Path(__file__).resolve().parents[1] / "examples" / "two_link_finger.toml"
LOADS = {"tendon.0.tension": (0.0, 10.0, 100), "load.0.force.1": (0.0, -1.0, 100)}
DESIGNS = {
    "flexure.proximal.thickness": (0.2e-3, 0.3e-3, 20),
    "flexure.proximal.length": (0.015, 0.025, 20),
    "load.0.force.1": (0.0, -1.0, 10),
}
MONTE_CARLO = {
    "flexure.proximal.thickness": ("normal", 0.25e-3, 0.01e-3),
    "flexure.distal.length": ("uniform", 0.014, 0.016),
}


def timed(fn) -> tuple[float, object]:
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def main() -> int:
    import pandas  # noqa: F401  (imported before timing: a cost of the session, not the study)

    scene = flexgen.load_scene(FINGER)
    rows: list[tuple[str, float, int]] = []

    def study(label, vary, **kw):
        t, df = timed(lambda: flexgen.sweep(scene, vary, progress=False, **kw))
        rows.append((label, t, int((~df["converged"]).sum())))
        print(f"{label}: {t:.3f} s", file=sys.stderr)
        return df

    study("10^4 load cases, 1 core, first study of the process", LOADS, workers=1)
    for _ in range(2):
        study("10^4 load cases, 1 core (estimate and stress)", LOADS, workers=1)
    study("10^4 load cases, 1 core, stress=False", LOADS, workers=1, stress=False)
    study(
        "10^4 load cases, 1 core, stress=False, estimate=False",
        LOADS,
        workers=1,
        stress=False,
        estimate=False,
    )

    solver = flexgen.Solver(scene)
    tensions = np.linspace(*LOADS["tendon.0.tension"][:2], 100)
    forces = np.linspace(*LOADS["load.0.force.1"][:2], 100)

    def loop():
        for t in tensions:
            for f in forces:
                solver.solve(loads=[[0.0, f, 0.0]], tensions=[t], estimate=True)

    t, _ = timed(loop)
    rows.append(("reference: 10^4 x Solver.solve(estimate=True) in a loop", t, 0))

    study("20 x 20 designs x 10 loads, 1 core", DESIGNS, workers=1)
    study("20 x 20 designs x 10 loads, 1 core, stress=False", DESIGNS, workers=1, stress=False)
    study("20 x 20 designs x 10 loads, default workers (the probe decides)", DESIGNS)
    study("20 x 20 designs x 10 loads, 2 processes, first pool of the session", DESIGNS, workers=2)
    study("20 x 20 designs x 10 loads, 2 processes, pool kept", DESIGNS, workers=2)
    # every sample a design of its own: the scene and its Solver prepared per case
    study(
        "Monte-Carlo, 2000 samples of thickness and length, 1 core",
        MONTE_CARLO,
        workers=1,
        samples=2000,
        seed=1,
    )

    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"
    )
    print()
    print("| study | wall time (s) | cases without an equilibrium |")
    print("|---|---:|---:|")
    for label, t, failed in rows:
        print(f"| {label} | {t:.3f} | {failed} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
