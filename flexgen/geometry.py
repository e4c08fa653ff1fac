"""World geometry of a scene for drawings: body frames, flexure roots and centrelines, unloaded or
at a result's equilibrium, and the outlines of rigid bodies (links and the base).

A body outline is the convex hull of the points that belong to it (a link: its frame origin, its
named points and the roots of its child flexures; the base: its points and the clamped roots),
widened by a margin so that a body of one point or of collinear points is still an area.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .models.registry import as_reported
from .result import Result
from .scene import BASE, Scene


@dataclass
class Geometry:
    """World geometry of a scene in one configuration."""

    frames: dict[str, np.ndarray]  # body -> (x, y, angle) of its frame (links: parent's tip)
    roots: dict[str, np.ndarray]  # flexure -> (x, y, angle) of its root frame
    shapes: dict[str, np.ndarray]  # flexure -> (num, 2) centreline, root first

    def point(self, scene: Scene, ref: str) -> np.ndarray:
        body, (px, py) = scene.resolve_point(ref)
        return self.local(body, px, py)

    def local(self, body: str, px: float, py: float) -> np.ndarray:
        """World (x, y) of the point (px, py) of ``body``'s frame."""
        x, y, th = self.frames[body]
        c, s = math.cos(th), math.sin(th)
        return np.array([x + c * px - s * py, y + s * px + c * py])

    def body_points(self, scene: Scene, body: str) -> np.ndarray:
        """(n, 2) world points that make up a rigid body (a link or the base): see the module
        docstring. The base also gets a point behind each clamped root, so the clamp has depth
        in the drawing even with no base points."""
        pts = [self.local(body, *xy) for xy in scene.body_points(body).values()]
        children = [c for c in scene.children(body) if scene.body_kind(c) == "flexure"]
        pts += [self.roots[c][:2] for c in children]
        if body == BASE:
            for c in children:
                r = self.roots[c]
                back = 0.15 * scene.flexure(c).length
                pts.append(r[:2] - back * np.array([math.cos(r[2]), math.sin(r[2])]))
        else:
            pts.append(self.frames[body][:2])
        return np.array(pts, dtype=float).reshape(-1, 2)


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
    the one solved; the result's model kinds, modes and elements are applied), or from the exact
    solver's solution."""
    if exact_solution is not None:
        frames = {BASE: np.zeros(3)}
        frames.update({n: np.asarray(v, float) for n, v in exact_solution.tip_frames.items()})
        frames = _with_links(scene, frames)
        shapes = {n: np.asarray(v, float) for n, v in exact_solution.shapes.items()}
        return Geometry(frames, _roots(scene, frames), shapes)
    from .chain import Chain
    from .models.registry import build_models

    scene = as_solved(scene, result)
    chain = Chain(scene, build_models(scene))
    q = chain.pack(result.q)
    frames = chain.frame_poses(q)[0]
    return Geometry(frames, _roots(scene, frames), chain.shapes(q, num))


def as_solved(scene: Scene, result: Result) -> Scene:
    """The scene with each flexure's model as the result reports it (``--model``, ``--modes``,
    ``--elements`` and ``--tol`` change them), so that its q rebuilds the same shapes."""
    flexures = []
    for f in scene.flexures:
        model = as_reported(f.model, result.model.get(f.name, {}))
        flexures.append(f if model is f.model else replace(f, model=model))
    return replace(scene, flexures=tuple(flexures))


def convex_hull(points: np.ndarray) -> np.ndarray:
    """The convex hull of (n, 2) points, counter-clockwise (Andrew's monotone chain)."""
    pts = sorted({(float(x), float(y)) for x, y in points})
    if len(pts) <= 2:
        return np.array(pts, dtype=float).reshape(-1, 2)

    def cross(o, a, b) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    upper: list = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1], dtype=float)


def outline(points: np.ndarray, margin: float, corners: int = 12) -> np.ndarray:
    """The hull of ``points`` widened by ``margin`` (rounded corners): a closed area even for
    one point or collinear points."""
    a = np.linspace(0.0, 2 * math.pi, corners, endpoint=False)
    ring = margin * np.column_stack([np.cos(a), np.sin(a)])
    return convex_hull((points[:, None, :] + ring[None, :, :]).reshape(-1, 2))
