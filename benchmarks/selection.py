"""Honesty of the mode selection (`flexgen select`, `--tol`, `[model] tolerance`), measured.

    python benchmarks/selection.py [--seeds 0,1,2,3,4] [--tols 1e-2,1e-4,1e-6,1e-8]

For every scene of ``flexgen_tools.honesty.honesty_suite(seed)`` (cantilevers under tip forces and
moments of several magnitudes and directions, two-flexure chains with links, chains driven by a
tendon; bends up to about 90 degrees) and every tolerance T it runs the selection, solves the scene
with ``models.exact.solve_exact`` and prints a markdown table per T:

- covered: the share of cases whose true error (against exact) is <= the estimate;
- worst true/estimate: the largest ratio (the requirement: never more than 10);
- cheapest: the share of cases (that met T, with some flexure above one mode) where one mode fewer
  on any single flexure would NOT have met T against exact;
- reached: the share of cases where T could be met at all (8 polynomial / 6 Gauss modes at most);
- true <= T: of the cases that reached T, the share whose true error is within T.

Error: per output point, max(|position error| / L_p, |angle error|, ||C - C_exact||_2 /
||C_exact||_2), L_p the summed length of the flexures between the base and the point; the largest
over the points.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))  # flexgen_tools from this checkout


def main(argv=None) -> int:
    from flexgen_tools import honesty

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1,2,3,4")
    ap.add_argument("--tols", default="1e-2,1e-4,1e-6,1e-8")
    ap.add_argument("--verbose", action="store_true", help="one line per case on stderr")
    args = ap.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
    tols = [float(t) for t in args.tols.split(",") if t.strip()]

    t0 = time.perf_counter()
    scenes = []
    for seed in seeds:
        scenes += [(f"s{seed} {label}", sc) for label, sc in honesty.honesty_suite(seed)]

    def progress(c):
        if args.verbose:
            flag = ""
            if c.true_error > c.estimate + honesty.REFERENCE_NOISE:
                flag = "  <-- true > estimate (beyond the reference's noise)"
            elif c.true_error > c.estimate:
                flag = "  (true > estimate, within the reference's noise)"
            if c.cheapest is False:
                flag += "  (one mode fewer also meets T)"
            print(
                f"{c.label:28s} T={c.tol:.0e} modes={c.modes} est={c.estimate:.2e} "
                f"true={c.true_error:.2e}{flag}",
                file=sys.stderr,
            )

    cases = honesty.honesty_cases(scenes, tols, progress=progress)
    rates = honesty.honesty_rates(cases)
    elapsed = time.perf_counter() - t0

    print(f"{len(scenes)} scenes (seeds {args.seeds}), {len(cases)} cases, {elapsed:.1f} s\n")
    print(
        f"| T | cases | covered (true <= estimate + {honesty.REFERENCE_NOISE:g}) "
        "| worst true/estimate | cheapest | reached "
        "| true <= T (reached) | mean total modes |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for tol, r in rates.items():
        print(
            f"| {tol:.0e} | {r['cases']} | {100 * r['covered']:.1f} % | {r['worst_ratio']:.2f} "
            f"| {100 * r['cheapest']:.1f} % (of {r['checked']}) | {100 * r['reached']:.1f} % "
            f"| {100 * r['true_within_tol']:.1f} % | {r['mean_modes']:.2f} |"
        )
    ok = all(
        r["covered"] >= 0.95 and r["worst_ratio"] <= 10 and r["cheapest"] >= 0.90
        for r in rates.values()
    )
    print(
        f"\nrequirement (covered >= 95 %, worst <= 10x, cheapest >= 90 % for every T): "
        f"{'met' if ok else 'NOT met'}"
    )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
