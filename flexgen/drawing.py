"""Drawings of a scene: the mechanism as bodies, and its equilibrium under a result.

``plot(scene, result=None, ax=None)`` (``flexgen.plot``) draws on a matplotlib Axes and returns
it (a new pyplot figure when no Axes is given; nothing is written or shown), for a notebook;
``draw(scene, result, path)`` writes the drawing of a solved scene to a PNG, SVG or PDF file
(``flexgen plot``). What is drawn:

- rigid links as bodies: a filled outline (``geometry.outline``) through the link's frame origin
  (its parent flexure's tip), its named points and the roots of its child flexures, with its
  name, so a link that has no length (a child flexure whose ``at`` was left out) is seen as one;
- the base as a hatched block through its points and the clamped roots;
- flexures: the unloaded centrelines dashed; the loaded ones coloured by stress, bending plus
  axial where the width is known (or by curvature when a section is unknown) from ``result.flexures``, with a colour bar and the
  largest value marked;
- tendons along their route, dead loads as arrows to a scale the legend states (moments as curved
  arrows), and the compliance ellipse of every output point.

A compliance ellipse is the set of displacements ``C f`` of its point under a force of fixed
magnitude ``F`` in every direction: semi-axes ``F * major`` and ``F * minor`` along the
eigenvectors of the 2x2 compliance. ``F`` is chosen so that the largest ellipse is a tenth of the
drawing; the legend states it.

matplotlib is imported only when drawing; without it ``draw`` raises ``PlotError`` saying how to
install it. The file is written to a temporary name in its folder and renamed, so a failed write
(a full disk) leaves nothing behind and an existing file is replaced whole; an existing folder,
symbolic link, FIFO or other non-regular file at the path is refused (``check_output``).
"""

from __future__ import annotations

import math
import os
import stat
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .geometry import Geometry, as_solved, loaded, outline, unloaded
from .models import registry
from .outfiles import folder_problem, write_all
from .result import Result
from .scene import BASE, Scene, as_scene

SUFFIXES = (".png", ".svg", ".pdf")
INSTALL_HINT = (
    "flexgen plot needs matplotlib: pip install 'flexgen[plot]' (or pip install matplotlib)"
)


class PlotError(ValueError):
    """A plot that cannot be drawn or written where asked: one line naming why."""


def check_output(
    path: str | os.PathLike[str], suffixes: tuple[str, ...] = SUFFIXES, option: str = "-o"
) -> Path:
    """The plot path if a plot may be written there: a .png, .svg or .pdf name (or one of
    ``suffixes``: `flexgen sweep --out` checks its table the same way) whose folder exists (or
    can be created) and that is not an existing folder, symbolic link, FIFO or other non-regular
    file. PlotError naming ``option`` otherwise; nothing is written."""
    ends = " or ".join([", ".join(suffixes[:-1]), suffixes[-1]] if len(suffixes) > 1 else suffixes)
    if not os.fspath(path):  # Path("") is ".", which would read as a folder (review)
        raise PlotError(f"{option}: give a file name ending in {ends}")
    path = Path(path)
    if path.name.lower() in suffixes:  # ".png" is a name without a suffix (review)
        raise PlotError(
            f"{option}: give a name before the {path.name} extension, got {str(path)!r}"
        )
    if path.suffix.lower() not in suffixes:
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
    problem = folder_problem(path.parent)
    if problem is not None:
        raise PlotError(f"{option}: cannot write {str(path)!r}: {problem}")
    return path


def _text(s: str) -> str:
    """A name as matplotlib text: control characters escaped, ``$`` not read as mathtext."""
    if not s.isprintable():
        s = "".join(c if c.isprintable() else repr(c)[1:-1] for c in s)
    return s.replace("$", r"\$")


def _save(fig, path: Path) -> None:
    """``fig`` into ``path``, whole or not at all (flexgen/outfiles.py: a temporary file in the
    same folder, then a rename; WriteFailed, an OSError, if that fails)."""

    def write(tmp: Path) -> None:
        with warnings.catch_warnings():
            # a name's characters missing from the font are drawn as boxes, not warned about
            warnings.filterwarnings("ignore", message="Glyph .* missing from")
            fig.savefig(tmp, format=path.suffix[1:].lower(), dpi=130)

    write_all([(path, write)])


def _model_label(result: Result) -> str:
    """The flexures' model names (``registry.label``), each once: "cc", "scm3, fem16"."""
    return ", ".join(dict.fromkeys(registry.label(info) for info in result.model.values()))


def _xy(v: np.ndarray | Sequence[float]) -> tuple[float, float]:
    """The first two entries of a point or pose as the (x, y) pair matplotlib's xy takes."""
    return (float(v[0]), float(v[1]))


FIGSIZE = (8.0, 6.0)
# fractions of the drawing's size: the half-width added around a rigid body's points, the longest
# load arrow, the largest compliance ellipse's semi-major axis
BODY_MARGIN, ARROW_LENGTH, ELLIPSE_SIZE = 0.012, 0.18, 0.1
LINK_FACE, LINK_EDGE, BASE_FACE = "#dbe4f0", "#44546a", "0.85"
COLOURMAP = "viridis"


def _require_matplotlib() -> None:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise PlotError(INSTALL_HINT) from None


def _with_unit(name: str, unit: str) -> str:
    return f"{name} [{unit}]" if unit else name


@dataclass
class Colouring:
    """What the loaded flexures are coloured by: the outer fibres' |stress| (bending, plus axial
    where the strip's area is known) when every flexure's section is known, else |curvature| (from ``result.flexures``, ``FlexureStress`` per flexure)."""

    label: str  # colour bar label, with its unit
    symbol: str  # for the marker of the largest value
    unit: str
    along: dict[str, tuple[np.ndarray, np.ndarray]]  # flexure -> (s / L, |value|)
    peak: tuple[str, float, float]  # (flexure, s / L, value) of the largest value


def colouring(scene: Scene, result: Result | None) -> Colouring | None:
    """How to colour ``result``'s flexures; None when it has no stress data for every flexure."""
    data = result.flexures if result is not None else None
    if not data or any(data.get(f.name) is None for f in scene.flexures):
        return None
    entries = {f.name: data[f.name] for f in scene.flexures}
    by_stress = all(e.stress is not None for e in entries.values())
    axial = by_stress and any(
        getattr(e, "axial_stress", None) is not None for e in entries.values()
    )
    along = {}
    for f in scene.flexures:
        e = entries[f.name]
        values = (e.outer_stress() if axial else e.stress) if by_stress else e.curvature
        along[f.name] = (
            np.asarray(e.s, float) / f.length,
            np.abs(np.asarray(values, float)),
        )
    peak_of = {n: _largest(e, by_stress) for n, e in entries.items()}
    name = max(peak_of, key=lambda n: peak_of[n])
    peak = (name, float(entries[name].at), peak_of[name])
    if by_stress:
        unit = scene.unit_of("stress")
        label = "|bending + axial stress|" if axial else "|bending stress|"
        return Colouring(_with_unit(label, unit), "|σ|", unit, along, peak)
    unit = scene.unit_of("curvature")
    return Colouring(_with_unit("|curvature|", unit), "|κ|", unit, along, peak)


def _largest(e: Any, by_stress: bool) -> float:
    """A flexure's largest |stress| (or |curvature|), as its FlexureStress states it."""
    value = e.max_stress if by_stress else e.max_curvature
    if value is None:  # a stress profile without its maximum: the profile's own
        value = float(np.max(np.abs(np.asarray(e.stress, float))))
    return abs(float(value))


def _arc_fraction(shape: np.ndarray) -> np.ndarray:
    """s / L of each point of a drawn centreline (its points need not be evenly spaced)."""
    seg = np.hypot(*np.diff(shape, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    return s / s[-1] if s[-1] > 0 else s


def _size(scene: Scene, geometries: list[Geometry]) -> float:
    pts = [s for g in geometries for s in g.shapes.values()]
    pts += [g.body_points(scene, lk.name) for g in geometries for lk in scene.links]
    pts += [geometries[0].body_points(scene, BASE)]
    return float(np.max(np.ptp(np.vstack(pts).reshape(-1, 2), axis=0))) or 1.0


# what the drawing reads of a result, whatever it is (a Result or an object that looks like one)
RESULT_FIELDS = ("scene", "converged", "reason", "solver", "model", "q", "points")
# how far (relative to the scene's size; rad for angles) a result's output poses may be from
# this scene's equilibrium solved again from the result: far below what a drawing shows, far
# above what the solver's tolerance leaves
SAME_POSE = 1e-6


def _check_args(result: Any, title: Any) -> None:
    """TypeError naming the parameter for a ``result`` or ``title`` of the wrong type (they
    would fail deep in the drawing with an AttributeError)."""
    if result is not None and not all(hasattr(result, name) for name in RESULT_FIELDS):
        raise TypeError(
            f"result: expected a flexgen Result (flexgen.solve(scene)), got {type(result).__name__}"
        )
    if title is not None and not isinstance(title, str):
        raise TypeError(f"title: must be a string or None, got {type(title).__name__}")


def _check_result(scene: Scene, result: Result) -> None:
    """PlotError for a result without an equilibrium or of a scene of another name or other
    flexures (``_check_same`` then tells scenes of one name apart)."""
    if not result.converged:
        raise PlotError(f"no equilibrium to draw: {result.reason}")
    names = {f.name for f in scene.flexures}
    if result.scene != scene.name or set(result.model) != names:
        raise PlotError(
            f"the result is of scene {result.scene!r} (flexures {', '.join(result.model)}), "
            f"not of {scene.name!r}; pass the scene that was solved"
        )


def _check_same(scene: Scene, result: Result, exact_solution: Any = None) -> None:
    """PlotError unless ``result`` is an equilibrium of ``scene`` as given. A Result names its
    scene but keeps neither the scene nor a fingerprint of it, and the drawing puts the result's
    shapes, poses and ellipses over this scene's links, loads and tendons; so the scene is solved
    again from the result's q (Newton from an equilibrium: a few iterations; an exact result:
    the exact solution the drawing solves anyway) and the output poses compared: another load,
    tension, geometry or output set moves them."""
    if result.solver == "exact":
        poses = {ref: list(p) for ref, p in exact_solution.poses.items()}
    else:
        from .solver import Solver

        again = Solver(as_solved(scene, result)).solve(q0=result.q)
        if not again.converged:  # cannot tell (e.g. settings of its own): draw it as given
            return
        poses = {ref: p.pose for ref, p in again.points.items()}
    given = {ref: p.pose for ref, p in result.points.items()}
    if set(poses) != set(given):
        raise PlotError(
            f"result: its output points ({', '.join(given)}) are not those of scene "
            f"{scene.name!r} ({', '.join(poses)}); pass the scene that was solved"
        )
    size = sum(f.length for f in scene.flexures)
    for ref, pose in poses.items():
        x, y, angle = given[ref][:3]
        off = max(math.hypot(x - pose[0], y - pose[1]) / size, abs(angle - pose[2]))
        if not off <= SAME_POSE:
            raise PlotError(
                f"result: not an equilibrium of scene {scene.name!r} as given ({ref!r} is at "
                f"({x:.6g}, {y:.6g}) in it, ({pose[0]:.6g}, {pose[1]:.6g}) solved here): it is "
                "of a scene with other loads, tensions or geometry; pass the scene that was "
                "solved (a Solver's answer under other inputs: the scene with those inputs, "
                "scene.with_value('load.0.force', [fx, fy]) or 'tendon.0.tension', which also "
                "draws its load arrows to scale)"
            )


def _exact_solution(scene: Scene, result: Result) -> Any:
    """The exact solver's solution of ``scene`` for an exact-model result (a Result keeps only
    the root loads of the exact solver, not the shapes), by the path ``flexgen.solve`` takes:
    its cross-check may solve again at shorter steps and take the buckled branch, which a plain
    ``solve_exact`` misses (review: such results were refused as "of another scene"); None for a
    chain-model result."""
    if result.solver != "exact":
        return None
    from . import exact_result

    return exact_result.solve(scene)[1]


def plot(
    scene: Scene | Mapping[str, Any] | str | os.PathLike[str],
    result: Result | None = None,
    ax: Any = None,
    *,
    title: str | None = None,
) -> Any:
    """Draw ``scene`` (a Scene, dict or TOML path) on ``ax`` and return the Axes: unloaded when
    ``result`` is None (the mechanism as written: links, base, flexures, tendons, loads), else at
    ``result``'s equilibrium (``flexgen.solve`` of this scene) over the unloaded shape. Without
    ``ax`` a new pyplot figure is made (``plt.show()`` or a notebook displays it); nothing is
    written or shown here. An exact-model result is solved again for its shapes (a Result keeps
    only the root loads of the exact solver)."""
    _check_args(result, title)
    sc = as_scene(scene)
    _require_matplotlib()
    from matplotlib.axes import Axes

    if ax is not None and not isinstance(ax, Axes):
        raise TypeError(f"ax: expected a matplotlib Axes or None, got {type(ax).__name__}")
    exact = None
    if result is not None:
        _check_result(sc, result)
        exact = _exact_solution(sc, result)
        _check_same(sc, result, exact)
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=FIGSIZE, layout="constrained")
    draw_on(ax, sc, result, exact, title)
    return ax


def draw(scene: Scene, result: Result, path, exact_solution=None, title: str | None = None) -> Path:
    """Draw ``scene`` at ``result``'s equilibrium into ``path`` (.png, .svg or .pdf); returns the
    path. No pyplot: a Figure of its own, whatever backend the caller uses."""
    path = check_output(path)
    _check_args(result, title)
    _check_result(scene, result)
    if exact_solution is None:
        exact_solution = _exact_solution(scene, result)
    _check_same(scene, result, exact_solution)
    _require_matplotlib()
    from matplotlib.figure import Figure

    fig = Figure(figsize=FIGSIZE, layout="constrained")
    draw_on(fig.add_subplot(), scene, result, exact_solution, title)
    _save(fig, path)
    return path


def draw_on(ax, scene: Scene, result: Result | None, exact_solution=None, title=None) -> None:
    """Every artist of the drawing on ``ax`` (see the module docstring). Artists a reader may
    look for carry a gid: "base", "link:NAME", "link-unloaded:NAME", "link-name:NAME",
    "flexure:NAME", "flexure-unloaded:NAME", "tendon:I", "load:I:force", "load:I:moment", "ellipse:POINT", "peak"."""
    from matplotlib.lines import Line2D

    g0 = unloaded(scene)
    g1 = loaded(scene, result, exact_solution) if result is not None else None
    shown = g1 if g1 is not None else g0  # where links, tendons and loads are drawn
    size = _size(scene, [g0] + ([g1] if g1 is not None else []))
    handles: list[Any] = []
    _base(ax, scene, g0, BODY_MARGIN * size, handles)
    if g1 is not None:
        _links(ax, scene, g0, BODY_MARGIN * size, unloaded_outline=True)
    _links(ax, scene, shown, BODY_MARGIN * size, unloaded_outline=False)
    if scene.links:
        handles.append(_patch_handle(LINK_FACE, LINK_EDGE, "rigid links"))
    # the unloaded flexures: dashed under a loaded shape, solid when they are the drawing
    style: dict[str, Any] = (
        dict(color="C0", lw=2.4) if g1 is None else dict(color="0.55", ls="--", lw=1.2)
    )
    for name, shape in g0.shapes.items():
        ax.plot(shape[:, 0], shape[:, 1], **style, zorder=2, gid=f"flexure-unloaded:{name}")
    if g1 is None:
        handles.append(Line2D([], [], **style, label="flexures (unloaded)"))
    else:
        handles.append(Line2D([], [], **style, label="unloaded flexures"))
        handles += _loaded_flexures(ax, g1, colouring(scene, result))
    handles += _tendons(ax, scene, shown)
    handles += _loads(ax, scene, shown, size)
    if result is not None:
        handles += _ellipses(ax, result, size, scene.unit_of("force"))
    length = scene.unit_of("length")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.set_xlabel(_with_unit("x", length))
    ax.set_ylabel(_with_unit("y", length))
    state = f"{_model_label(result)}" if result is not None else "unloaded"
    ax.set_title(_text(title or f"{scene.name} ({state})"))
    # below the Axes: inside, "best" still covers links or labels of a mechanism that fills it
    ax.legend(
        handles=handles,
        fontsize=8,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.09),
        frameon=False,
    )


def _patch_handle(face, edge, label, hatch=None):
    from matplotlib.patches import Patch

    return Patch(facecolor=face, edgecolor=edge, hatch=hatch, label=label)


def _base(ax, scene: Scene, g: Geometry, margin: float, handles: list) -> None:
    from matplotlib.patches import Polygon

    pts = g.body_points(scene, BASE)
    if not len(pts):
        return
    poly = Polygon(
        outline(pts, margin),
        closed=True,
        facecolor=BASE_FACE,
        edgecolor="0.3",
        hatch="////",
        lw=1.0,
        zorder=1,
        gid="base",
    )
    ax.add_patch(poly)
    handles.append(_patch_handle(BASE_FACE, "0.3", "base (clamped roots)", hatch="////"))


def _links(ax, scene: Scene, g: Geometry, margin: float, unloaded_outline: bool) -> None:
    """Each link as a filled body with its name, or (``unloaded_outline``) as the dashed outline
    of where it was before loading."""
    from matplotlib.patches import Polygon

    for link in scene.links:
        pts = g.body_points(scene, link.name)
        if unloaded_outline:
            ax.add_patch(
                Polygon(
                    outline(pts, margin),
                    closed=True,
                    fill=False,
                    edgecolor="0.6",
                    ls="--",
                    lw=0.9,
                    zorder=1,
                    gid=f"link-unloaded:{link.name}",
                )
            )
            continue
        ax.add_patch(
            Polygon(
                outline(pts, margin),
                closed=True,
                facecolor=LINK_FACE,
                edgecolor=LINK_EDGE,
                lw=1.2,
                alpha=0.9,
                zorder=1.5,
                gid=f"link:{link.name}",
            )
        )
        named = np.array([g.local(link.name, *xy) for xy in link.points.values()]).reshape(-1, 2)
        ax.plot(named[:, 0], named[:, 1], ".", color=LINK_EDGE, ms=4, zorder=3)
        centre = pts.mean(axis=0)
        ax.text(
            *_xy(centre),
            _text(link.name),
            ha="center",
            va="center",
            fontsize=8,
            color=LINK_EDGE,
            zorder=6,
            gid=f"link-name:{link.name}",
            bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.7),
        )


def _loaded_flexures(ax, g: Geometry, colour: Colouring | None) -> list:
    """The loaded centrelines: one colour, or coloured along their length with a colour bar and
    the largest value marked."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import Normalize
    from matplotlib.lines import Line2D

    if colour is None:
        for name, shape in g.shapes.items():
            ax.plot(shape[:, 0], shape[:, 1], color="C0", lw=2.4, zorder=4, gid=f"flexure:{name}")
        return [Line2D([], [], color="C0", lw=2.4, label="loaded flexures")]
    norm = Normalize(0.0, colour.peak[2] or 1.0)
    lines = None
    for name, shape in g.shapes.items():
        t = _arc_fraction(shape)
        mid = 0.5 * (t[1:] + t[:-1])
        s_rel, values = colour.along[name]
        segments = np.stack([shape[:-1], shape[1:]], axis=1)
        # round caps close the wedges butt caps leave between the segments of a curve (the
        # background showed through them as stripes: review)
        lines = LineCollection(
            list(segments),
            cmap=COLOURMAP,
            norm=norm,
            lw=3.0,
            zorder=4,
            gid=f"flexure:{name}",
            capstyle="round",
        )
        lines.set_array(np.interp(mid, s_rel, values))
        ax.add_collection(lines)
    if lines is not None:
        ax.figure.colorbar(lines, ax=ax, label=colour.label, shrink=0.85, pad=0.02)
    name, at, value = colour.peak
    shape = g.shapes[name]
    t = _arc_fraction(shape)
    x, y = np.interp(at, t, shape[:, 0]), np.interp(at, t, shape[:, 1])
    ax.plot([x], [y], "o", mfc="red", mec="black", ms=7, zorder=7, gid="peak")
    # the label towards the middle of the drawing, so that it stays inside the Axes
    middle = np.mean(np.vstack(list(g.shapes.values())), axis=0)
    right, up = x <= middle[0], y <= middle[1]
    unit = f" {colour.unit}" if colour.unit else ""
    ax.annotate(
        f"max {colour.symbol} = {value:.4g}{unit}\n({_text(name)}, s/L = {at:.2f})",
        (float(x), float(y)),
        xytext=(8 if right else -8, 8 if up else -8),
        textcoords="offset points",
        ha="left" if right else "right",
        va="bottom" if up else "top",
        fontsize=8,
        color="darkred",
        # under the flexures (4): its box must not hide the stress it points at (review)
        zorder=3.5,
        bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="none", alpha=0.8),
    )
    return [
        Line2D([], [], color="C0", lw=3.0, label=f"loaded flexures, coloured by {colour.label}")
    ]


def _tendons(ax, scene: Scene, g: Geometry) -> list:
    from matplotlib.lines import Line2D

    for i, t in enumerate(scene.tendons):
        route = np.array([g.point(scene, ref) for ref in t.route])
        ax.plot(
            route[:, 0],
            route[:, 1],
            color="C3",
            lw=1.2,
            marker=".",
            ms=6,
            zorder=5,
            gid=f"tendon:{i}",
        )
    if not scene.tendons:
        return []
    force = scene.unit_of("force")
    tensions = ", ".join(f"{t.tension:g}" for t in scene.tendons) + (f" {force}" if force else "")
    return [Line2D([], [], color="C3", lw=1.2, marker=".", label=f"tendon (tension {tensions})")]


def _loads(ax, scene: Scene, g: Geometry, size: float) -> list:
    """Forces as arrows to one scale (the longest ``ARROW_LENGTH`` of the drawing; the legend
    states the scale), moments as curved arrows with their value."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyArrowPatch

    fmax = max((math.hypot(*ld.force) for ld in scene.loads), default=0.0)
    scale = ARROW_LENGTH * size / fmax if fmax > 0 else 0.0  # drawing length per unit force
    for i, ld in enumerate(scene.loads):
        xy = g.point(scene, ld.point)
        f = np.asarray(ld.force, float)
        if scale and np.any(f):
            # to scale from tail to tip: no shrinking at the ends (matplotlib's default takes
            # 2 points off each: review, the longest arrow read 10 % short, a fifth of it 50 %),
            # and the head smaller on a short arrow, which it would otherwise be all of
            share = math.hypot(*f) / fmax
            ax.add_patch(
                FancyArrowPatch(
                    _xy(xy - scale * f),
                    _xy(xy),
                    arrowstyle="-|>",
                    mutation_scale=14 * min(1.0, 3.0 * share),
                    shrinkA=0,
                    shrinkB=0,
                    color="C2",
                    lw=1.8,
                    zorder=6,
                    gid=f"load:{i}:force",
                )
            )
        if ld.moment:
            sgn = 1.0 if ld.moment > 0 else -1.0
            r = 0.05 * size
            a, b = xy + r * np.array([1, -sgn]), xy + r * np.array([1, sgn])
            ax.add_patch(
                FancyArrowPatch(
                    _xy(a),
                    _xy(b),
                    arrowstyle="-|>",
                    mutation_scale=12,
                    connectionstyle=f"arc3,rad={sgn * 0.9}",
                    color="C2",
                    lw=1.5,
                    zorder=6,
                    gid=f"load:{i}:moment",
                )
            )
            moment = scene.unit_of("moment")
            ax.annotate(
                f"M = {ld.moment:.4g}{' ' + moment if moment else ''}",
                _xy(xy),
                xytext=(10, 16),
                textcoords="offset points",
                color="C2",
                fontsize=8,
            )
    if not scene.loads:
        return []
    label = "dead loads"
    if fmax > 0:
        length, force = scene.unit_of("length"), scene.unit_of("force")
        label += (
            f": an arrow {scale * fmax:.3g}{' ' + length if length else ''} long is a force of "
            f"{fmax:.3g}{' ' + force if force else ''}"
        )
    return [Line2D([], [], color="C2", lw=1.8, marker=">", label=label)]


def _ellipses(ax, result: Result, size: float, force: str) -> list:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Ellipse

    majors = [
        p.ellipse["major"]
        for p in result.points.values()
        if math.isfinite(p.ellipse["major"]) and p.ellipse["major"] > 0
    ]
    if not majors:
        return []
    F = ELLIPSE_SIZE * size / max(majors)
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
                zorder=6,
                gid=f"ellipse:{ref}",
            )
        )
        ax.plot(*point.pose[:2], "o", color="C1", ms=3, zorder=6)
        ax.annotate(
            _text(ref),
            _xy(point.pose),
            xytext=(6, -12),
            textcoords="offset points",
            fontsize=8,
            color="C1",
        )
    return [
        Line2D(
            [],
            [],
            color="C1",
            lw=1.6,
            label=(
                f"compliance ellipses: displacement under a force of {F:.3g}"
                f"{' ' + force if force else ''} in every direction"
            ),
        )
    ]
