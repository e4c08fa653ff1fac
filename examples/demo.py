"""The demo (`make demo`): every example scene with every model, beside the exact elastica and the
paper's published numbers; the two-link finger's compliance ellipses (the analogue of the paper's
Table 1); its drawings under out/demo/ (untracked: the demo leaves the docs as they are;
``--drawings``, ``make drawings``: only the drawings, into docs/, where the docs show them).

Every number comes from the public API, ``flexgen.solve(path, model=..., modes=...)``, i.e. the
same as ``flexgen solve <scene> --model <kind> [--modes N | --elements N] --json``; the "source"
column names that command. "exact" is the elastica shooting solver (``--model exact``); "paper"
rows are the numbers printed in the paper (Bisshopp & Drucker's table for the tip-load case).
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import flexgen  # noqa: E402
from flexgen.api import as_scene, override, solve_scene  # noqa: E402
from flexgen.drawing import draw  # noqa: E402

EX = ROOT / "examples"
DOCS = ROOT / "docs"
DEMO_OUT = ROOT / "out" / "demo"  # untracked (.gitignore): a fresh clone stays clean after the demo
# (label, --model, --modes, --elements)
MODELS = [
    ("cc", "cc", None, None),
    ("prb", "prb", None, None),
    ("scm3", "scm", 3, None),
    ("scm5", "scm", 5, None),
    ("fem16", "fem", None, 16),
    ("exact", "exact", None, None),
]


def command(scene: str, model, modes, elements) -> str:
    cmd = f"flexgen solve examples/{scene} --model {model}"
    return (
        cmd
        + (f" --modes {modes}" if modes else "")
        + (f" --elements {elements}" if elements else "")
    )


def solve_all(scene: str, point: str):
    rows = {}
    for label, model, modes, elements in MODELS:
        res = flexgen.solve(EX / scene, model=model, modes=modes, elements=elements)
        if not res.converged:
            raise SystemExit(f"{scene} with {label}: no equilibrium: {res.reason}")
        rows[label] = (res.points[point], command(scene, model, modes, elements))
    return rows


def header(title: str) -> None:
    print(f"\n== {title}")


def rectangular_elastica() -> None:
    header(
        "rectangular elastica (examples/rectangular_elastica.toml): axial tip load "
        "P = K(1/sqrt2)^2 = 3.4375929, EI = L = 1; the tip turns to 90 deg"
    )
    rows = solve_all("rectangular_elastica.toml", "beam.tip")
    ex = rows["exact"][0].pose
    print(
        f"  closed form: x = 0.456947, y = 0.762760; exact solver: x = {ex[0]:.6f}, "
        f"y = {ex[1]:.6f}, angle = {math.degrees(ex[2]):.4f} deg"
    )
    print(
        f"  {'model':<6} {'x':>9} {'y':>9} {'angle':>9} {'x err':>9} {'y err':>9} {'ang err':>9}  source"
    )
    for label, (p, src) in rows.items():
        x, y, th = p.pose
        print(
            f"  {label:<6} {x:9.6f} {y:9.6f} {math.degrees(th):8.4f}° "
            f"{100 * abs(x - ex[0]) / ex[0]:8.3f}% {100 * abs(y - ex[1]) / ex[1]:8.3f}% "
            f"{abs(math.degrees(th - ex[2])):8.3f}°  {src}"
        )
    print(
        f"  {'paper':<6} {'':>9} {'':>9} {'':>9} {'0.26%':>9} {'0.02%':>9} {'0.07°':>9}  "
        "the paper's 3-mode model (compare scm3)"
    )


def arc() -> None:
    header(
        "90-degree arc (examples/arc_moment.toml): pure tip moment pi/2, EI = L = 1; "
        "tip compliance eigenvalues"
    )
    rows = solve_all("arc_moment.toml", "beam.tip")
    paper = {"cc": "0.2178 / 0", "scm3": "0.2876 / 0.0069", "fem16": "0.2873 / 0.0069"}
    print("  closed form (model-notes.md): 0.2876591 / 0.0068858")
    print(f"  {'model':<6} {'major':>9} {'minor':>9}  {'paper':>16}  source")
    for label, (p, src) in rows.items():
        e = p.ellipse
        print(
            f"  {label:<6} {e['major']:9.6f} {e['minor']:9.6f}  {paper.get(label, ''):>16}  {src}"
        )


def tip_load() -> None:
    header(
        "cantilever, tip load alpha = 2 (examples/cantilever_tip_load.toml): "
        "Bisshopp & Drucker x/L = 0.83936, deflection/L = 0.49346, angle 0.78175 rad"
    )
    rows = solve_all("cantilever_tip_load.toml", "beam.tip")
    ex = rows["exact"][0].pose
    print(f"  {'model':<6} {'x':>9} {'-y':>9} {'-angle':>9} {'|dpos|/L':>9}  source")
    for label, (p, src) in rows.items():
        x, y, th = p.pose
        err = math.hypot(x - ex[0], y - ex[1])
        print(f"  {label:<6} {x:9.5f} {-y:9.5f} {-th:9.5f} {err:9.1e}  {src}")
    print(
        f"  {'table':<6} {0.83936:9.5f} {0.49346:9.5f} {0.78175:9.5f} {'':>9}  "
        "Bisshopp & Drucker (1945)"
    )


def finger() -> None:
    scene = flexgen.load_scene(EX / "two_link_finger.toml")
    load = scene.loads[0]
    header(
        f"two-link finger (examples/two_link_finger.toml): tendon at "
        f"{scene.tendons[0].tension:g} N, {math.hypot(*load.force):g} N on {load.point}"
    )
    rows = solve_all("two_link_finger.toml", "fingertip.pad")
    ex = rows["exact"][0].pose
    print(f"  {'model':<6} {'pad x mm':>9} {'pad y mm':>9} {'angle':>9} {'|dpos| mm':>9}  source")
    for label, (p, src) in rows.items():
        x, y, th = p.pose
        print(
            f"  {label:<6} {1e3 * x:9.4f} {1e3 * y:9.4f} {math.degrees(th):8.3f}° "
            f"{1e3 * math.hypot(x - ex[0], y - ex[1]):9.4f}  {src}"
        )

    header(
        "finger compliance ellipses (the analogue of the paper's Table 1): semi-axes in mm/N, "
        "major-axis angle in degrees"
    )
    base = as_scene(EX / "two_link_finger.toml")
    slack = replace(base, tendons=tuple(replace(t, tension=0.0) for t in base.tendons))
    print(
        f"  {'tendon':<7} {'model':<6} "
        + " ".join(f"{ref + ' major':>19} {'minor':>8} {'angle':>7}" for ref in base.outputs)
        + "  source"
    )
    for tname, sc in (("slack", slack), ("10 N", base)):
        for label, model, modes, elements in (MODELS[2], MODELS[4], MODELS[5]):
            res, _ = solve_scene(override(sc, model, modes, elements))
            cells = []
            for ref in base.outputs:
                e = res.points[ref].ellipse
                cells.append(
                    f"{1e3 * e['major']:19.4f} {1e3 * e['minor']:8.5f} "
                    f"{math.degrees(e['angle']):7.2f}"
                )
            src = command("two_link_finger.toml", model, modes, elements)
            if tname == "slack":
                src += " (tension set to 0)"
            print(f"  {tname:<7} {label:<6} " + " ".join(cells) + f"  {src}")


def shown(path: Path) -> Path:
    """``path`` as printed: relative to the repository when inside it."""
    return path.relative_to(ROOT) if path.is_relative_to(ROOT) else path


def plots(folder: Path) -> None:
    header(f"plots (flexgen plot <scene> -o {shown(folder)}/<name>.png, scm3 as in the scenes)")
    names = {
        "rectangular_elastica": "rectangular_elastica",
        "arc_moment": "arc_moment",
        "cantilever_tip_load": "cantilever_tip_load",
        "two_link_finger": "finger",
    }
    for stem, out in names.items():
        sc = as_scene(EX / f"{stem}.toml")
        res, exact = solve_scene(sc)
        print(f"  {shown(draw(sc, res, folder / f'{out}.png', exact))}")
    sc = as_scene(EX / "two_link_finger.toml")
    sc = replace(sc, tendons=tuple(replace(t, tension=0.0) for t in sc.tendons))
    res, _ = solve_scene(sc)
    print(
        f"  {shown(draw(sc, res, folder / 'finger_slack.png', title=f'{sc.name}, tendon slack (scm3)'))}"
        "  (tendon slack)"
    )


def main() -> int:
    start = time.perf_counter()
    if sys.argv[1:] == ["--drawings"]:  # `make drawings`: only the drawings under docs/
        plots(DOCS)
        return 0
    print(
        "flexgen demo: every example scene with cc, prb, scm3, scm5, fem16 and the exact "
        "elastica, beside the paper's numbers"
    )
    rectangular_elastica()
    arc()
    tip_load()
    finger()
    DEMO_OUT.mkdir(parents=True, exist_ok=True)
    plots(DEMO_OUT)
    print(f"\ndone in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
