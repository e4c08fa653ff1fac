"""How closely a study's rows agree with single solves (the numbers of docs/sweep.md, "Rows
against single solves"), one run:

    python benchmarks/sweep_agreement.py

The two-link finger (examples/two_link_finger.toml) over a 41 x 41 grid of pad forces (-1 to 1 N
in x and in y), ``flexgen.sweep`` on one core (warm starts from neighbours), each row compared
with ``flexgen.solve`` of the same scene (``Scene.with_values``, a cold solve). Prints the worst
pose difference (absolute, scene units), the worst ellipse-axis difference relative to the
major axis, and the worst error-estimate difference (absolute, and over max(1e-6 relative,
1e-9 absolute)). About a minute. Nothing is asserted: tests/test_sweep.py holds its own studies
to the documented bounds.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import flexgen  # noqa: E402


def main() -> None:
    scene = flexgen.load_scene(ROOT / "examples" / "two_link_finger.toml")
    vary = {"load.0.force.0": (-1.0, 1.0, 41), "load.0.force.1": (-1.0, 1.0, 41)}
    df = flexgen.sweep(scene, vary, workers=1)
    pose = axes = est_abs = est_over = 0.0
    for row in df.to_dict("records"):
        r = flexgen.solve(scene.with_values({k: row[k] for k in vary}))
        for ref, p in r.points.items():
            got = np.array([row[f"{ref}.x"], row[f"{ref}.y"], row[f"{ref}.angle"]])
            pose = max(pose, float(np.abs(got - p.pose).max()))
            major = p.ellipse["major"]
            for axis in ("major", "minor"):
                axes = max(axes, abs(row[f"{ref}.{axis}"] - p.ellipse[axis]) / major)
            e = max(p.error_estimate.values())
            d = abs(row[f"{ref}.error_estimate"] - e)
            est_abs = max(est_abs, d)
            est_over = max(est_over, d / max(1e-6 * e, 1e-9))
    print(f"{len(df)} rows of the finger's 41 x 41 pad-force grid against flexgen.solve:")
    print(f"  pose: worst {pose:.2g} (absolute)")
    print(f"  ellipse axes: worst {axes:.2g} of the major axis")
    print(f"  error estimate: worst {est_abs:.2g} absolute, {est_over:.2g} x max(1e-6 rel, 1e-9)")


if __name__ == "__main__":
    main()
