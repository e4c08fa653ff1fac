"""Tree kinematics of a scene: the world pose, Jacobian and Hessian of any point.

The solver core (chain_solver.c) has its own, faster kinematics; this module gives the scene's
structure (body order, the frame each body moves with, the packing of q) to the problem builder,
the frame poses of an answer (``frame_poses``, ``frame_poses_batch``: what the axial stress and
the curvature estimate's end floor read, in every Result and every study, and what drawings
draw), and a plain product-rule reference of the Jacobian and Hessian to tests.

A scene is a tree of bodies. The base is the world frame. A flexure's root frame is its ``at``
offset in its parent body's frame; its tip frame is the root frame composed with the tip transform
its model gives (``FlexureModel.tip``). A link's frame is its parent flexure's tip frame, so a link
is the same body frame as that flexure's tip, carrying more named points.

All flexures' generalized coordinates are packed into one vector ``q`` in the order the scene
declares the flexures; ``Chain.slices[name]`` is each flexure's part.

Every planar transform is composed with the product rule, so each body frame carries its world pose
``(x, y, angle)``, Jacobian ``(3, ndof)`` and Hessian ``(3, ndof, ndof)`` exactly (to the accuracy
of the flexure models). Composing a parent frame ``P`` with a local transform ``(v, phi)`` whose
derivatives may depend on q::

    r' = r_P + R(th_P) v          th' = th_P + phi
    dr'   = dr_P + S w dth_P + R dv                         (w = R v, S = rotation by +90 deg)
    d2r'  = d2r_P - w dth_P dth_P + S w d2th_P + S R dv dth_P + dth_P S R dv + R d2v

The tendon potential ``T l(q)`` (``l`` the sum of straight segment lengths between the route points)
and its exact gradient and Hessian follow from the points' Jacobians and Hessians by the chain rule.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .models.base import FlexureModel
from .scene import Scene

BASE = "base"


class ChainError(ValueError):
    """A chain that cannot be evaluated (unknown point, missing model, degenerate tendon)."""


@dataclass(frozen=True)
class PointKinematics:
    """World pose ``(x, y, body angle)`` of a point and its derivatives in the packed ``q``."""

    pose: np.ndarray  # (3,)
    J: np.ndarray  # (3, ndof)
    H: np.ndarray  # (3, ndof, ndof)


def _rot(th: float) -> np.ndarray:
    c, s = np.cos(th), np.sin(th)
    return np.array([[c, -s], [s, c]])


def _moved(pose: np.ndarray, v0: float, v1: float, phi: float) -> np.ndarray:
    """The pose of a frame at (v0, v1), turned by phi, in the frame ``pose``: ``_compose``'s
    pose, the same arithmetic, without its derivatives."""
    th = float(pose[2])
    c, s = math.cos(th), math.sin(th)
    return np.array([pose[0] + (c * v0 - s * v1), pose[1] + (s * v0 + c * v1), th + phi])


def _moved_many(pose: np.ndarray, v0: Any, v1: Any, phi: Any) -> np.ndarray:
    """``_moved`` of (m, 3) poses by scalars or (m,) arrays."""
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    return np.column_stack(
        [pose[:, 0] + (c * v0 - s * v1), pose[:, 1] + (s * v0 + c * v1), pose[:, 2] + phi]
    )


def _compose(
    parent: PointKinematics, v, phi: float = 0.0, tip=None, sl: slice | None = None
) -> PointKinematics:
    """Parent frame composed with the local transform (translation v, rotation phi).

    ``tip`` (a TipKinematics with J (3, k), H (3, k, k)) gives the local transform's derivatives
    in the coordinates ``sl`` of the packed q (rows x, y, angle; zero outside ``sl``), or None for
    a constant transform. Written out per row on the (few) nonzero blocks: the arrays are tiny and
    numpy's per-call overhead dominates.
    """
    pp = parent.pose
    th = float(pp[2])
    c, s = math.cos(th), math.sin(th)
    v0, v1 = float(v[0]), float(v[1])
    wx, wy = c * v0 - s * v1, s * v0 + c * v1  # w = R v; S w = (-wy, wx)
    pose = np.array([pp[0] + wx, pp[1] + wy, th + phi])
    J = parent.J.copy()
    H = parent.H.copy()
    Jth, Hth = parent.J[2], parent.H[2]
    moving = bool(Jth.any())  # the parent's angle depends on q
    curved = bool(Hth.any())
    if moving:
        J[0] -= wy * Jth
        J[1] += wx * Jth
    if moving and curved:
        JJ = np.multiply.outer(Jth, Jth)
        H[0] += -wy * Hth - wx * JJ
        H[1] += wx * Hth - wy * JJ
    elif moving:
        JJ = np.multiply.outer(Jth, Jth)
        H[0] -= wx * JJ
        H[1] -= wy * JJ
    elif curved:
        H[0] -= wy * Hth
        H[1] += wx * Hth
    if tip is not None:
        tJ, tH = np.asarray(tip.J, dtype=float), np.asarray(tip.H, dtype=float)
        RJ0 = c * tJ[0] - s * tJ[1]  # R dv (rows x, y) on the block sl
        RJ1 = s * tJ[0] + c * tJ[1]
        J[0, sl] += RJ0
        J[1, sl] += RJ1
        J[2, sl] += tJ[2]
        if moving:  # S R dv dth^T + its transpose
            for a, row in ((0, -RJ1), (1, RJ0)):
                X = np.multiply.outer(row, Jth)  # (k, n)
                H[a, sl, :] += X
                H[a, :, sl] += X.T
        H[0, sl, sl] += c * tH[0] - s * tH[1]
        H[1, sl, sl] += s * tH[0] + c * tH[1]
        H[2, sl, sl] += tH[2]
    return PointKinematics(pose, J, H)


class Chain:
    """Kinematics and potential energy of a scene's tree of flexures and links.

    ``models`` maps every flexure name to its ``FlexureModel``.
    """

    def __init__(self, scene: Scene, models: Mapping[str, FlexureModel]):
        self.scene = scene
        self.flexures = {f.name: f for f in scene.flexures}
        self.links = {l.name: l for l in scene.links}
        missing = [name for name in self.flexures if name not in models]
        if missing:
            raise ChainError(f"no model for flexure {missing[0]!r}")
        self.models = {name: models[name] for name in self.flexures}
        self.names: tuple[str, ...] = tuple(self.flexures)
        self.slices: dict[str, slice] = {}
        start = 0
        for name in self.names:
            n = int(self.models[name].n_dof)
            self.slices[name] = slice(start, start + n)
            start += n
        self.ndof = start
        self._order = self._body_order()
        self._children: dict[str, list[str]] | None = None
        self._resolved: dict[str, tuple[str, tuple[float, float]]] = {}
        self._frame_of = {BASE: BASE}
        for body in self._order:
            parent = self.body_parent(body)
            assert parent is not None  # _order holds flexures and links: they have parents
            self._frame_of[body] = body if body in self.flexures else self._frame_of[parent]
        self._flex_order = [b for b in self._order if b in self.flexures]

    # ---- scene structure ------------------------------------------------------------------

    def body_parent(self, body: str) -> str | None:
        if body == BASE:
            return None
        if body in self.flexures:
            return self.flexures[body].parent
        if body in self.links:
            return self.links[body].parent
        raise ChainError(f"unknown body {body!r}")

    def _body_order(self) -> list[str]:
        """Flexures and links, every body after its parent (cycles and unknown parents raise).
        Iterative: a chain thousands of bodies deep needs no recursion."""
        order: list[str] = []
        placed: set[str] = {BASE}
        for start in list(self.flexures) + list(self.links):
            trail: list[str] = []  # start, its parent, ... up to a placed body
            on_trail: set[str] = set()
            body = start
            while body not in placed:
                if body in on_trail:
                    cycle = trail[trail.index(body) :] + [body]
                    raise ChainError(f"the scene's bodies form a cycle: {' -> '.join(cycle)}")
                parent = self.body_parent(body)
                if parent != BASE and parent not in self.flexures and parent not in self.links:
                    raise ChainError(f"body {body!r} has unknown parent {parent!r}")
                trail.append(body)
                on_trail.add(body)
                assert parent is not None  # flexures and links have parents
                body = parent
            for b in reversed(trail):  # parents first
                order.append(b)
                placed.add(b)
        return order

    @property
    def flexure_order(self) -> list[str]:
        """The flexures, every one after the flexure (if any) whose tip frame carries its root."""
        return list(self._flex_order)

    def frame_of(self, body: str) -> str:
        """The frame a body moves with: its own for a flexure, its parent flexure's for a link,
        ``"base"`` for the base and links on it."""
        return self._frame_of[body]

    def resolve_point(self, ref: str) -> tuple[str, tuple[float, float]]:
        """``"<body>.<point>"`` -> (body, point coordinates in the body's frame); the scene's
        resolver, so unknown points raise its one-line SceneError."""
        return self.scene.resolve_point(ref)

    def children(self, body: str) -> list[str]:
        if self._children is None:
            kids: dict[str, list[str]] = {}
            for b in self._order:
                kids.setdefault(self.body_parent(b) or BASE, []).append(b)
            self._children = kids
        return list(self._children.get(body, ()))

    # ---- packing --------------------------------------------------------------------------

    def split(self, q: np.ndarray) -> dict[str, np.ndarray]:
        q = np.asarray(q, dtype=float)
        return {name: q[sl].copy() for name, sl in self.slices.items()}

    def pack(self, parts: Mapping[str, Sequence[float]]) -> np.ndarray:
        q = np.zeros(self.ndof)
        for name, values in parts.items():
            if name not in self.slices:
                raise ChainError(f"unknown flexure {name!r}")
            q[self.slices[name]] = np.asarray(values, dtype=float)
        return q

    def zeros(self) -> np.ndarray:
        return np.zeros(self.ndof)

    # ---- kinematics -----------------------------------------------------------------------

    def _check_q(self, q) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        if q.shape != (self.ndof,):
            raise ChainError(f"q has shape {q.shape}, expected ({self.ndof},)")
        return q

    def frames(self, q) -> dict[str, PointKinematics]:
        """World pose, Jacobian and Hessian of every body frame at ``q`` (computed afresh: a
        Chain keeps no state of an evaluation, so one Problem's chain may serve any caller)."""
        return self._frames_and_roots(self._check_q(q))[0]

    def _frames_and_roots(self, q: np.ndarray, derivatives: bool = True) -> tuple[dict, dict]:
        """Every body frame and every flexure's root frame at ``q``: PointKinematics (pose,
        Jacobian, Hessian), or with ``derivatives`` False their poses only (``frame_poses``)."""
        n = self.ndof
        base = (
            PointKinematics(np.zeros(3), np.zeros((3, n)), np.zeros((3, n, n)))
            if derivatives
            else np.zeros(3)
        )
        frames: dict[str, Any] = {BASE: base}
        roots: dict[str, Any] = {}
        for body in self._order:
            parent_name = self.body_parent(body)
            assert parent_name is not None  # _order holds flexures and links: they have parents
            parent = frames[parent_name]
            if body in self.links:
                frames[body] = parent
                continue
            flex = self.flexures[body]
            ax, ay, ath = (float(v) for v in flex.at)
            sl = self.slices[body]
            tk = self.models[body].tip(q[sl])
            tp = np.asarray(tk.pose, dtype=float)
            root: Any
            if derivatives:
                root = _compose(parent, (ax, ay), ath)
                frames[body] = _compose(root, (tp[0], tp[1]), float(tp[2]), tk, sl)
            else:
                root = _moved(parent, ax, ay, ath)
                frames[body] = _moved(root, float(tp[0]), float(tp[1]), float(tp[2]))
            roots[body] = root
        return frames, roots

    def frame_poses(self, q) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """The world pose (x, y, angle) of every body frame and of every flexure's root frame at
        ``q``: ``frames``' poses, the same numbers, without their Jacobians and Hessians, which
        a drawing does not read (3 n^2 numbers a frame: 54 MB each on a 512-flexure chain,
        where flexgen plot ran out of memory; review)."""
        return self._frames_and_roots(self._check_q(q), derivatives=False)

    def frame_poses_batch(self, Q) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """``frame_poses`` of many answers at once: ``Q`` (m, ndof) packed coordinates, every
        pose (m, 3). A model's ``tip_poses`` (m, k) -> (m, 3) where it has one (a study's
        stresses: one vectorised call per flexure), else its ``tip`` per answer."""
        Q = np.asarray(Q, dtype=float).reshape(-1, self.ndof)
        frames: dict[str, np.ndarray] = {BASE: np.zeros((Q.shape[0], 3))}
        roots: dict[str, np.ndarray] = {}
        for body in self._order:
            parent_name = self.body_parent(body)
            assert parent_name is not None
            parent = frames[parent_name]
            if body in self.links:
                frames[body] = parent
                continue
            flex = self.flexures[body]
            model, Qf = self.models[body], Q[:, self.slices[body]]
            batch = getattr(model, "tip_poses", None)
            tips = (
                batch(Qf)
                if batch is not None
                else np.array([np.asarray(model.tip(q).pose, dtype=float) for q in Qf])
            ).reshape(-1, 3)
            ax, ay, ath = (float(v) for v in flex.at)
            root = _moved_many(parent, ax, ay, ath)
            roots[body] = root
            frames[body] = _moved_many(root, tips[:, 0], tips[:, 1], tips[:, 2])
        return frames, roots

    def _resolve(self, ref: str) -> tuple[str, tuple[float, float]]:
        got = self._resolved.get(ref)
        if got is None:
            body, xy = self.resolve_point(ref)
            got = self._resolved[ref] = (body, (float(xy[0]), float(xy[1])))
        return got

    def _point_in(self, frames: dict[str, PointKinematics], ref: str) -> PointKinematics:
        body, xy = self._resolve(ref)
        frame = frames[body]
        return frame if xy == (0.0, 0.0) else _compose(frame, xy)

    def point(self, ref: str, q) -> PointKinematics:
        """World pose ``(x, y, body angle)``, J (3, ndof), H (3, ndof, ndof) of
        ``"<body>.<point>"`` at ``q``."""
        return self._point_in(self.frames(q), ref)

    def pose(self, ref: str, q) -> np.ndarray:
        return self.point(ref, q).pose.copy()

    # ---- energy ---------------------------------------------------------------------------

    def energy(self, q) -> float:
        q = self._check_q(q)
        return float(sum(self.models[n].energy(q[sl]) for n, sl in self.slices.items()))

    def energy_gradient(self, q) -> np.ndarray:
        q = self._check_q(q)
        g = np.zeros(self.ndof)
        for n, sl in self.slices.items():
            g[sl] = self.models[n].energy_gradient(q[sl])
        return g

    def energy_hessian(self, q) -> np.ndarray:
        """Block-diagonal Hessian of the total elastic energy."""
        q = self._check_q(q)
        K = np.zeros((self.ndof, self.ndof))
        for n, sl in self.slices.items():
            K[sl, sl] = self.models[n].energy_hessian(q[sl])
        return K

    # ---- tendons --------------------------------------------------------------------------

    def tendon_length(self, route: Sequence[str], q) -> tuple[float, np.ndarray, np.ndarray]:
        """Length l of a route of straight segments, with its gradient and Hessian in q."""
        frames = self.frames(q)
        pts = [self._point_in(frames, ref) for ref in route]
        owners = [self.frame_of(self._resolve(ref)[0]) for ref in route]
        n = self.ndof
        length, grad, hess = 0.0, np.zeros(n), np.zeros((n, n))
        for k in range(len(pts) - 1):
            a, b = pts[k], pts[k + 1]
            dx = float(b.pose[0] - a.pose[0])
            dy = float(b.pose[1] - a.pose[1])
            rho = math.hypot(dx, dy)
            if owners[k] == owners[k + 1]:
                # both ends on one rigid body: a constant length, nothing on q (the core's rule)
                length += rho
                continue
            if rho == 0.0:
                raise ChainError(f"tendon segment {route[k]!r} -> {route[k + 1]!r} has zero length")
            ux, uy = dx / rho, dy / rho
            Jx = b.J[0] - a.J[0]
            Jy = b.J[1] - a.J[1]
            length += rho
            grad += ux * Jx + uy * Jy
            # (I - u u^T) / rho = n n^T / rho with n = (-uy, ux) the unit normal
            m = ux * Jy - uy * Jx
            hess += np.multiply.outer(m, m / rho)
            hess += ux * (b.H[0] - a.H[0]) + uy * (b.H[1] - a.H[1])
        return length, grad, hess

    def tendon_potential(self, q, scale: float = 1.0) -> tuple[float, np.ndarray, np.ndarray]:
        """Sum over the scene's tendons of ``scale * T * l(q)``, with gradient and Hessian."""
        n = self.ndof
        V, g, H = 0.0, np.zeros(n), np.zeros((n, n))
        for tendon in self.scene.tendons:
            T = scale * float(tendon.tension)
            if T == 0.0:
                continue
            l, gl, hl = self.tendon_length(tendon.route, q)
            V += T * l
            g += T * gl
            H += T * hl
        return V, g, 0.5 * (H + H.T)

    # ---- plots ----------------------------------------------------------------------------

    def shapes(self, q, num: int = 64) -> dict[str, np.ndarray]:
        """Each flexure's centreline in the world frame, (num, 2), root first."""
        q = self._check_q(q)
        roots = self.frame_poses(q)[1]
        out = {}
        for name, sl in self.slices.items():
            root = roots[name]
            local = np.asarray(self.models[name].shape(q[sl], num), dtype=float)
            out[name] = root[:2] + local @ _rot(root[2]).T
        return out


__all__ = ["Chain", "ChainError", "PointKinematics"]
