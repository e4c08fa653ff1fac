"""The error estimate of every chain-model answer (flexgen.estimate): its cost and its honesty.

    python benchmarks/estimate.py            # cost: the estimate against the compiled solve
    python benchmarks/estimate.py --honesty  # coverage against the exact elastica (seeds 0-2)

Cost, per example scene and model, best of --repeat rounds of --number calls each, one process:

- solve:     ``Solver.run()``, the compiled solve (the core call, answer left in the workspace);
- estimate:  ``solver.estimator().estimate(solver)`` on that answer: one core call
             (``fg_estimate``: Newton on the richer model from the answer, the per-point
             differences), the richer model's solve where Newton does not converge (cc, prb
             under large loads), the margins;
- ratio:     estimate / solve;
- Result:    ``Solver.solve()`` and ``Solver.solve(estimate=True)`` (with the Result built).

Honesty: ``flexgen_tools.estimate_honesty`` (what tests/test_estimate.py asserts).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import flexgen  # noqa: E402

MODELS = (
    ("scm3", {}),
    ("scm5", {"modes": 5}),
    ("cc", {"model": "cc"}),
    ("prb", {"model": "prb"}),
    ("fem16", {"model": "fem", "elements": 16}),
)


def best(f, number: int, repeat: int) -> float:
    f()
    out = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            f()
        out = min(out, (time.perf_counter() - t0) / number)
    return out


def cost(number: int, repeat: int) -> None:
    print(
        f"{'scene':<22} {'model':<6} {'solve us':>9} {'estimate us':>12} {'ratio':>7} "
        f"{'Result us':>10} {'+estimate us':>13}"
    )
    ratios = []
    for path in sorted((ROOT / "examples").glob("*.toml")):
        for label, kw in MODELS:
            s = flexgen.Solver(path, **kw)
            s.run()
            est = s.estimator()
            t_run = best(s.run, number, repeat)
            t_est = best(lambda: est.estimate(s), number, repeat)  # noqa: B023
            t_res = best(s.solve, number, repeat)
            t_res_est = best(lambda: s.solve(estimate=True), number, repeat)  # noqa: B023
            ratios.append(t_est / t_run)
            print(
                f"{path.stem:<22} {label:<6} {t_run * 1e6:>9.1f} {t_est * 1e6:>12.1f} "
                f"{t_est / t_run:>6.0%} {t_res * 1e6:>10.1f} {t_res_est * 1e6:>13.1f}"
            )
    ratios.sort()
    print(
        f"estimate / compiled solve: median {ratios[len(ratios) // 2]:.0%}, "
        f"min {ratios[0]:.0%}, max {ratios[-1]:.0%} ({len(ratios)} cases)"
    )


def honesty(seeds: list[int], verbose: bool) -> None:
    from flexgen_tools.estimate_honesty import estimate_cases, estimate_rates, estimate_scenes
    from flexgen_tools.honesty import REFERENCE_NOISE

    scenes = []
    for k, seed in enumerate(seeds):
        got = estimate_scenes(seed)
        scenes += got if k == 0 else got[4:]  # the examples once
    t0 = time.perf_counter()
    cases = estimate_cases(scenes)
    r = estimate_rates(cases)
    if verbose:
        for c in cases:
            print(
                f"{c.scene:<32} {c.model:<6} estimate {c.estimate:9.2e} true {c.true_error:9.2e} "
                f"true/estimate {c.ratio:6.3f}{'  warned' if c.warned else ''}",
                file=sys.stderr,
            )
    w = r["worst"]
    print(
        f"{len(scenes)} scenes (seeds {', '.join(map(str, seeds))}), {r['answers']} answers, "
        f"{time.perf_counter() - t0:.1f} s"
    )
    print(
        f"covered (every point's true pose error <= its estimate, compliance error <= its "
        f"estimate + the reference's noise {REFERENCE_NOISE:g}): {r['covered']:.1%}; "
        f"whole answer (true <= error_estimate + that noise): {r['covered_whole']:.1%}"
    )
    print(
        f"worst true/estimate: {r['worst_ratio']:.3f} ({w.scene}, {w.model}); over the errors "
        f"the reference resolves: {r['worst_resolved_ratio']:.3f}"
    )
    print(
        f"above 10x the estimate: {len(r['above_10x_unwarned'])} without a warning, "
        f"{len(r['above_10x_warned'])} with one"
    )
    wk = r["worst_curvature"]
    print(
        f"stress (every flexure's max |curvature|, so strain and stress, within its "
        f"error_estimate + that noise): {r['curvature_covered']:.1%}; worst true/estimate "
        f"{r['worst_curvature_ratio']:.3f} ({wk.scene}, {wk.model})"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--honesty", action="store_true")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--number", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=7)
    a = ap.parse_args()
    if a.honesty:
        honesty([int(s) for s in a.seeds.split(",")], a.verbose)
    else:
        cost(a.number, a.repeat)


if __name__ == "__main__":
    main()
