"""Time per solve (equilibrium + compliance) of the chain solver on a few fixed cases.

    python benchmarks/solver_speed.py [--repeats N] [--json OUT]

Cases: the two-flexure finger (examples/two_link_finger.toml) with scm3 (auto kernel, as
``flexgen bench`` times it), the same through ``flexgen.solve`` (the scene's own scm3 model,
plus the validity check every API solve runs), fem16, fem64 and exact
(``models.exact.solve_exact``); the 90-degree arc (scm3) and the rectangular elastica (scm3;
buckling: the path crosses the bifurcation and ends on the post-buckled branch). Reported: median milliseconds per solve over
``repeats`` calls after one warm-up call, plus the Newton iterations and the state evaluations
per solve. Single-threaded BLAS is recommended (OPENBLAS_NUM_THREADS=1), as in ``flexgen bench``.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from flexgen.models.fem import FEMModel          # noqa: E402
from flexgen.models.scm import SCMModel          # noqa: E402
from flexgen.scene import load_scene             # noqa: E402
from flexgen.equilibrium import System, solve          # noqa: E402


def scm3(f):
    return SCMModel(f.length, f.EI, 3, "auto", name=f.name)


def fem(n):
    return lambda f: FEMModel(f.length, f.EI, n)


def cases():
    ex = REPO / "examples"
    finger = load_scene(ex / "two_link_finger.toml")
    arc = load_scene(ex / "arc_moment.toml")
    elastica = load_scene(ex / "rectangular_elastica.toml")

    def exact(scene):
        from flexgen.models.exact import solve_exact
        return lambda: solve_exact(scene)

    def api(scene):
        import flexgen
        return lambda: flexgen.solve(scene)

    return [
        ("finger scm3", lambda: solve(finger, model_factory=scm3), 200),
        ("finger scm3 API+validity", api(finger), 200),
        ("finger fem16", lambda: solve(finger, model_factory=fem(16)), 100),
        ("finger fem64", lambda: solve(finger, model_factory=fem(64)), 30),
        ("finger exact", exact(finger), 5),
        ("arc scm3", lambda: solve(arc, model_factory=scm3), 300),
        ("elastica scm3 (buckling)", lambda: solve(elastica, model_factory=scm3), 100),
    ]


def count_states(fn) -> int:
    """State evaluations of one call (System.state calls)."""
    orig = System.state
    n = [0]

    def counting(self, q, lam):
        n[0] += 1
        return orig(self, q, lam)

    System.state = counting
    try:
        fn()
    finally:
        System.state = orig
    return n[0]


def median_ms(fn, repeats: int, budget_s: float) -> float:
    fn()     # warm-up (kernel import, caches)
    times = []
    t_end = time.perf_counter() + budget_s
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
        if time.perf_counter() > t_end and len(times) >= 5:
            break
    return 1e3 * statistics.median(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=float, default=1.0, help="scale the repeat counts")
    ap.add_argument("--budget", type=float, default=10.0, help="seconds per case at most")
    ap.add_argument("--json", help="also write the numbers to this file")
    args = ap.parse_args(argv)
    out = {}
    print(f"{'case':<28} {'ms/solve':>9} {'iters':>6} {'states':>7}")
    for name, fn, reps in cases():
        ms = median_ms(fn, max(3, int(reps * args.repeats)), args.budget)
        res = fn()
        iters = getattr(res, "iterations", None)
        states = count_states(fn) if "exact" not in name else None   # API: incl. validity
        out[name] = {"ms": ms, "iterations": iters, "states": states}
        print(f"{name:<28} {ms:>9.3f} {'' if iters is None else iters:>6} "
              f"{'' if states is None else states:>7}")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
