"""Scene model: a planar mechanism of rigid bodies joined by flexures, with loads and tendons.

A scene is loaded from TOML (``load_scene``) or a plain dict (``scene_from_dict``) and validated
into immutable dataclasses. Every validation error is a ``SceneError`` whose message names the
offending key and value in one line. See ``../shared/scene-format.md`` and ``docs/scene.md``.

Frames: the base frame is the world frame. A flexure's root frame is ``at`` in its parent body's
frame; its tip frame follows from its deformation. A link's frame is its parent flexure's tip
frame. Every flexure has the point ``"<flexure>.tip"`` = (0, 0) in its tip frame.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

MODEL_KINDS = ("scm", "cc", "prb", "fem", "exact")
KERNELS = ("auto", "poly", "gauss")


class SceneError(ValueError):
    """An invalid scene; the message is one line naming the bad key and value."""


@dataclass(frozen=True)
class ModelSpec:
    kind: str = "scm"            # one of MODEL_KINDS
    modes: int = 3               # scm: Legendre curvature modes
    elements: int = 16           # fem: rigid elements per flexure
    kernel: str = "auto"         # scm: "poly", "gauss" or "auto" (poly while in range)
    tolerance: float | None = None   # choose modes per flexure to meet this accuracy


@dataclass(frozen=True)
class Flexure:
    name: str
    parent: str                  # body name: "base", a link, or another flexure (its tip frame)
    at: tuple[float, float, float]  # root frame (x, y, angle) in the parent's frame
    length: float
    EI: float
    model: ModelSpec


@dataclass(frozen=True)
class Link:
    name: str
    parent: str                  # a flexure name: the link's frame is that flexure's tip frame
    points: Mapping[str, tuple[float, float]]


@dataclass(frozen=True)
class Load:
    point: str                   # "<body>.<point>"
    force: tuple[float, float]
    moment: float = 0.0


@dataclass(frozen=True)
class Tendon:
    tension: float
    route: tuple[str, ...]       # point references, at least two


@dataclass(frozen=True)
class Scene:
    name: str
    model: ModelSpec
    base_points: Mapping[str, tuple[float, float]]
    flexures: tuple[Flexure, ...]
    links: tuple[Link, ...] = ()
    loads: tuple[Load, ...] = ()
    tendons: tuple[Tendon, ...] = ()
    outputs: tuple[str, ...] = field(default=())
