"""Draw a solved scene (as the paper's Fig. 7): unloaded (dashed) and loaded shapes of every
flexure, rigid links (lines from the link's frame origin to its points), tendons, load arrows and
the compliance ellipses of the output points.

A compliance ellipse is the set of displacements ``C f`` of its point under a force of fixed
magnitude ``F`` in every direction: semi-axes ``F * major`` and ``F * minor`` along the
eigenvectors of the 2x2 compliance. ``F`` is chosen so that the largest ellipse is a fifth of the
drawing; the legend states it.

matplotlib (Agg, no pyplot) is imported only when drawing; without it ``draw`` raises
``PlotError`` saying how to install it. The file is written to a temporary name in its folder and
renamed, so a failed write (a full disk) leaves nothing behind and an existing file is replaced
whole; an existing folder, symbolic link, FIFO or other non-regular file at the path is refused
(``check_output``).
"""

from __future__ import annotations

import math
import os
import stat
import tempfile
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from .result import Result
from .scene import BASE, Scene

SUFFIXES = (".png", ".svg")
INSTALL_HINT = (
    "flexgen plot needs matplotlib: pip install 'flexgen[plot]' (or pip install matplotlib)"
)


class PlotError(ValueError):
    """A plot that cannot be drawn or written where asked: one line naming why."""


def check_output(
    path: str | os.PathLike[str], suffixes: tuple[str, ...] = SUFFIXES, option: str = "-o"
) -> Path:
    """The plot path if a plot may be written there: a .png or .svg name (or one of
    ``suffixes``) whose folder exists (or can be created) and that is not an existing folder,
    symbolic link, FIFO or other non-regular file. PlotError naming ``option`` otherwise;
    nothing is written."""
    path = Path(path)
    if path.suffix.lower() not in suffixes:
        ends = " or ".join(suffixes)
        raise PlotError(f"{option}: the file must end in {ends}, got {str(path)!r}")
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        info = None
    except OSError as e:
        raise PlotError(f"{option}: cannot write {str(path)!r}: {e.strerror or e}") from None
    if info is not None:
        if stat.S_ISLNK(info.st_mode):
            raise PlotError(f"{option}: {str(path)!r} is a symbolic link; give the file itself")
        if stat.S_ISDIR(info.st_mode):
            raise PlotError(f"{option}: {str(path)!r} is a folder")
        if not stat.S_ISREG(info.st_mode):
            raise PlotError(f"{option}: {str(path)!r} is not a regular file")
    probe = path.parent
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise PlotError(f"{option}: cannot write {str(path)!r}: {str(probe)!r} is not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise PlotError(f"{option}: cannot write {str(path)!r}: {str(probe)!r} is not writable")
    return path


def _text(s: str) -> str:
    """A name as matplotlib text: control characters escaped, ``$`` not read as mathtext."""
    if not s.isprintable():
        s = "".join(c if c.isprintable() else repr(c)[1:-1] for c in s)
    return s.replace("$", r"\$")


def _save(fig, path: Path) -> None:
    """``fig`` into ``path``: a temporary file in the same folder, then a rename (removed again
    if anything fails)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    try:
        with os.fdopen(fd, "wb") as handle, warnings.catch_warnings():
            # a name's characters missing from the font are drawn as boxes, not warned about
            warnings.filterwarnings("ignore", message="Glyph .* missing from")
            fig.savefig(handle, format=path.suffix[1:].lower(), dpi=130)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


@dataclass
class Geometry:
    """World geometry of a scene in one configuration."""

    frames: dict[str, np.ndarray]  # body -> (x, y, angle) of its frame (links: parent's tip)
    roots: dict[str, np.ndarray]  # flexure -> (x, y, angle) of its root frame
    shapes: dict[str, np.ndarray]  # flexure -> (num, 2) centreline, root first

    def point(self, scene: Scene, ref: str) -> np.ndarray:
        body, (px, py) = scene.resolve_point(ref)
        x, y, th = self.frames[body]
        c, s = math.cos(th), math.sin(th)
        return np.array([x + c * px - s * py, y + s * px + c * py])


def _compose(a, x, y, th) -> np.ndarray:
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * x - s * y, a[1] + s * x + c * y, a[2] + th])


def _with_links(scene: Scene, frames: dict) -> dict:
    for link in scene.links:
        frames[link.name] = frames[link.parent]
    return frames


def _roots(scene: Scene, frames: dict) -> dict:
    return {f.name: _compose(frames[f.parent], *f.at) for f in scene.flexures}


def unloaded(scene: Scene, num: int = 2) -> Geometry:
    """Every flexure straight along its root frame."""
    frames: dict[str, np.ndarray] = {BASE: np.zeros(3)}
    roots, shapes = {}, {}
    for f in scene.flexure_order():
        parent = f.parent if scene.body_kind(f.parent) != "link" else scene.link(f.parent).parent
        root = _compose(frames[parent], *f.at)
        roots[f.name] = root
        frames[f.name] = _compose(root, f.length, 0.0, 0.0)
        t = np.linspace(0.0, f.length, num)[:, None]
        shapes[f.name] = root[:2] + t * np.array([math.cos(root[2]), math.sin(root[2])])
    return Geometry(_with_links(scene, frames), roots, shapes)


def loaded(scene: Scene, result: Result, exact_solution=None, num: int = 64) -> Geometry:
    """The equilibrium geometry: from the result's q through the chain models (the scene must be
    the one solved, overrides applied), or from the exact solver's solution."""
    if exact_solution is not None:
        frames = {BASE: np.zeros(3)}
        frames.update({n: np.asarray(v, float) for n, v in exact_solution.tip_frames.items()})
        frames = _with_links(scene, frames)
        shapes = {n: np.asarray(v, float) for n, v in exact_solution.shapes.items()}
        return Geometry(frames, _roots(scene, frames), shapes)
    from .chain import Chain
    from .models.registry import build_models

    scene = _as_solved(scene, result)
    chain = Chain(scene, build_models(scene))
    q = chain.pack(result.q)
    frames = {b: np.asarray(k.pose, float) for b, k in chain.frames(q).items()}
    return Geometry(frames, _roots(scene, frames), chain.shapes(q, num))


def _as_solved(scene: Scene, result: Result) -> Scene:
    """The scene with each flexure's modes as the result has them (--tol chooses them)."""
    flexures = []
    for f in scene.flexures:
        modes = result.model.get(f.name, {}).get("modes")
        if modes is not None and modes != f.model.modes:
            f = replace(f, model=replace(f.model, modes=modes, tolerance=None))
        flexures.append(f)
    return replace(scene, flexures=tuple(flexures))


def _model_label(result: Result) -> str:
    labels = []
    for spec in result.model.values():
        kind = spec.get("kind", "?")
        extra = spec.get("modes", spec.get("elements"))
        labels.append(f"{kind}{extra}" if kind in ("scm", "fem") and extra else kind)
    return ", ".join(dict.fromkeys(labels))


def _xy(v: np.ndarray | Sequence[float]) -> tuple[float, float]:
    """The first two entries of a point or pose as the (x, y) pair matplotlib's xy takes."""
    return (float(v[0]), float(v[1]))


def draw(scene: Scene, result: Result, path, exact_solution=None, title: str | None = None) -> Path:
    """Draw ``scene`` at ``result``'s equilibrium into ``path`` (.png or .svg); returns the path."""
    path = check_output(path)
    if not result.converged:
        raise PlotError(f"no equilibrium to draw: {result.reason}")
    try:
        import matplotlib
    except ImportError:
        raise PlotError(INSTALL_HINT) from None

    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Ellipse

    g0 = unloaded(scene)
    g1 = loaded(scene, result, exact_solution)
    pts = np.vstack(
        [s for g in (g0, g1) for s in g.shapes.values()]
        + [
            g.point(scene, r)
            for g in (g0, g1)
            for l in scene.links
            for r in (f"{l.name}.{p}" for p in l.points)
        ]
        + [g0.point(scene, f"base.{p}") for p in scene.base_points]
    ).reshape(-1, 2)
    size = float(np.max(np.ptp(pts, axis=0))) or 1.0

    fig = Figure(figsize=(7.5, 6.0), layout="constrained")
    ax = fig.add_subplot()
    handles = []
    unloaded_style: dict[str, Any] = dict(color="0.6", ls="--", lw=1.2)
    loaded_style: dict[str, Any] = dict(color="C0", ls="-", lw=2.2)
    for g, style, label in ((g0, unloaded_style, "unloaded"), (g1, loaded_style, "loaded")):
        for shape in g.shapes.values():
            ax.plot(shape[:, 0], shape[:, 1], **style)
        for link in scene.links:
            o = g.frames[link.name][:2]
            for p in link.points:
                xy = g.point(scene, f"{link.name}.{p}")
                ax.plot(
                    [o[0], xy[0]],
                    [o[1], xy[1]],
                    color="0.2" if g is g1 else "0.7",
                    ls=style["ls"],
                    lw=1.5 if g is g1 else 1.0,
                )
        handles.append(Line2D([], [], **style, label=f"{label} flexures"))
    if scene.links:
        handles.append(Line2D([], [], color="0.2", lw=1.5, label="rigid links (loaded)"))
    roots = [g1.roots[f.name][:2] for f in scene.flexures if f.parent == BASE]
    if roots:
        r = np.array(roots)
        ax.plot(r[:, 0], r[:, 1], "ks", ms=7)
        handles.append(Line2D([], [], color="k", marker="s", ls="", label="clamped roots"))
    for t in scene.tendons:
        route = np.array([g1.point(scene, ref) for ref in t.route])
        ax.plot(route[:, 0], route[:, 1], color="C3", lw=1.2, marker=".", ms=6)
    if scene.tendons:
        tensions = ", ".join(f"{t.tension:g}" for t in scene.tendons)
        handles.append(
            Line2D([], [], color="C3", lw=1.2, marker=".", label=f"tendon (tension {tensions})")
        )

    fmax = max((math.hypot(*ld.force) for ld in scene.loads), default=0.0)
    for ld in scene.loads:
        xy = g1.point(scene, ld.point)
        f = np.asarray(ld.force, float)
        if fmax > 0 and np.any(f):
            tail = xy - 0.18 * size * f / fmax
            ax.annotate(
                "",
                xy=_xy(xy),
                xytext=_xy(tail),
                arrowprops=dict(arrowstyle="-|>", color="C2", lw=1.8),
            )
        if ld.moment:
            sgn = 1.0 if ld.moment > 0 else -1.0
            a, b = xy + 0.05 * size * np.array([1, -sgn]), xy + 0.05 * size * np.array([1, sgn])
            ax.annotate(
                "",
                xy=_xy(b),
                xytext=_xy(a),
                arrowprops=dict(
                    arrowstyle="-|>", color="C2", lw=1.5, connectionstyle=f"arc3,rad={sgn * 0.9}"
                ),
            )
            ax.annotate(
                f"M = {ld.moment:.4g}",
                _xy(xy),
                xytext=(10, 16),
                textcoords="offset points",
                color="C2",
                fontsize=8,
            )
    if scene.loads:
        handles.append(
            Line2D(
                [],
                [],
                color="C2",
                lw=1.8,
                marker=">",
                label="dead loads" + (f" (largest force {fmax:.3g})" if fmax > 0 else ""),
            )
        )

    majors = [
        p.ellipse["major"]
        for p in result.points.values()
        if math.isfinite(p.ellipse["major"]) and p.ellipse["major"] > 0
    ]
    if majors:
        F = 0.1 * size / max(majors)
        for ref, point in result.points.items():
            e = point.ellipse
            if not (math.isfinite(e["major"]) and e["major"] > 0):
                continue
            ax.add_patch(
                Ellipse(
                    _xy(point.pose),
                    2 * F * e["major"],
                    2 * F * max(e["minor"], 0.0),
                    angle=math.degrees(e["angle"]),
                    fill=False,
                    color="C1",
                    lw=1.6,
                )
            )
            ax.plot(*point.pose[:2], "o", color="C1", ms=3)
            ax.annotate(
                _text(ref),
                _xy(point.pose),
                xytext=(6, -12),
                textcoords="offset points",
                fontsize=8,
                color="C1",
            )
        handles.append(
            Line2D(
                [],
                [],
                color="C1",
                lw=1.6,
                label=(
                    f"compliance ellipses: displacement under a force of {F:.3g}"
                    f"{'' if scene.units is None else ' ' + scene.units.force} in every direction"
                ),
            )
        )
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.5)
    # the scene's units (docs/scene.md, Units); none given: any consistent set, unlabelled
    unit = f" [{scene.units.length}]" if scene.units is not None else ""
    ax.set_xlabel(f"x{unit}")
    ax.set_ylabel(f"y{unit}")
    ax.set_title(_text(title or f"{scene.name} ({_model_label(result)})"))
    ax.legend(handles=handles, fontsize=8, loc="best")
    _save(fig, path)
    return path
