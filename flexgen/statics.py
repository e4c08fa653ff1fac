"""The force each flexure transmits at an equilibrium, from the statics of the tree.

A flexure carries, through every section, the resultant of the external forces on everything
beyond its tip (the bodies it holds up, its own tip frame included): the scene's dead loads
(world frame) and the tendons' pulls at their route points. A tendon under tension T, straight
between route points, pulls each point towards its neighbours along the route:
T (u_prev + u_next) at an inner point, T u at an end (u the unit vector to the neighbour). Pulls
between two points beyond a flexure cancel in its sum, as internal forces do.

The axial force at arc length s of the flexure is that resultant along the tangent there,
N(s) = F . t(s) (tension positive), t(s) at the world angle root + the model's own tangent angle
(``tangent_angle``). ``flexgen.stress`` turns it into the axial stress N / A.

``StaticsPlan`` holds what is constant (which points load which flexures), found once per
scene (``Problem.statics``); the chain models get the points' world positions from
``chain.Chain.frame_poses`` at the answer;
the exact solver has the transmitted force among its unknowns (``SceneSolution.root_loads``), so
the two are independent routes to the same number (tests/test_axial_stress.py).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .scene import BASE, Scene


class StaticsPlan:
    """What the statics of a scene need, found once (the scene is constant; the loads,
    tensions and pose vary per answer): every loaded or routed point's body and local
    coordinates, and which flexures hold it (the membership matrix)."""

    def __init__(self, scene: Scene):
        self.flexures = [f.name for f in scene.flexures]
        index = {name: i for i, name in enumerate(self.flexures)}
        refs = [ld.point for ld in scene.loads]
        self.routes: list[list[int]] = []  # per tendon, its route as rows of ``refs``
        for tendon in scene.tendons:
            self.routes.append([len(refs) + k for k in range(len(tendon.route))])
            refs.extend(tendon.route)
        self.bodies = []
        self.local = np.zeros((len(refs), 2))
        self.member = np.zeros((len(refs), len(self.flexures)))
        for row, ref in enumerate(refs):
            body, xy = scene.resolve_point(ref)
            self.bodies.append(body)
            self.local[row] = xy
            for name in flexures_holding(scene, body):
                self.member[row, index[name]] = 1.0
        self.nloads = len(scene.loads)
        self.EI = np.array([f.EI for f in scene.flexures], dtype=float)

    def positions(self, frames: Mapping[str, Any]) -> np.ndarray:
        """(..., points, 2) world positions of the plan's points in the body frames ``frames``
        ({body: (..., 3) x, y, angle}: one answer, or a leading axis of many)."""
        if not self.bodies:
            lead = np.shape(next(iter(frames.values())))[:-1]
            return np.zeros((*lead, 0, 2))
        pose = np.stack([np.asarray(frames[b], dtype=float) for b in self.bodies], axis=-2)
        c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
        x, y = self.local[:, 0], self.local[:, 1]
        return np.stack([pose[..., 0] + c * x - s * y, pose[..., 1] + s * x + c * y], axis=-1)

    def point_forces(self, positions: np.ndarray, loads: Any, tensions: Any) -> np.ndarray:
        """(..., points, 2) world force at each point: its dead load (``loads`` (..., nloads,
        3): fx, fy, moment) or its tendon's pull (``tensions`` (..., ntendons)), at the
        ``positions`` (``positions``)."""
        out = np.zeros(positions.shape)
        if self.nloads:
            lead = positions.shape[:-2]
            out[..., : self.nloads, :] = np.asarray(loads, dtype=float).reshape(
                *lead, self.nloads, 3
            )[..., :2]
        tensions = np.asarray(tensions, dtype=float)
        for t, route in enumerate(self.routes):
            d = np.diff(positions[..., route, :], axis=-2)  # segment k: point k -> k + 1
            n = np.hypot(d[..., 0], d[..., 1])[..., None]
            u = np.divide(d, n, out=np.zeros_like(d), where=n > 0.0)
            pull = np.zeros(d.shape[:-2] + (len(route), 2))
            pull[..., :-1, :] += u  # towards the next point
            pull[..., 1:, :] -= u  # towards the previous one
            out[..., route, :] += tensions[..., t, None, None] * pull
        return out

    def transmitted(self, frames: Mapping[str, Any], loads: Any, tensions: Any) -> np.ndarray:
        """(..., flexures, 2): each flexure's transmitted world force (scene order)."""
        forces = self.point_forces(self.positions(frames), loads, tensions)
        return np.einsum("...pk,pf->...fk", forces, self.member)

    def end_moments(
        self, frames: Mapping[str, Any], roots: Mapping[str, Any], loads: Any, tensions: Any
    ) -> np.ndarray:
        """(flexures, 2): the bending moment each flexure carries at its root and at its tip
        (scene order; counter-clockwise): the moments about that end of the forces beyond it
        and the dead loads' own moments, so EI kappa there by equilibrium. ``frames`` and
        ``roots`` of one answer (``chain.Chain.frame_poses``)."""
        positions = self.positions(frames)
        forces = self.point_forces(positions, loads, tensions)
        couples = np.zeros(len(positions))
        if self.nloads:
            couples[: self.nloads] = np.asarray(loads, dtype=float).reshape(self.nloads, 3)[:, 2]
        out = np.zeros((len(self.flexures), 2))
        for j, name in enumerate(self.flexures):
            rows = self.member[:, j] > 0.0
            for k, end in enumerate((roots[name], frames[name])):
                d = positions[rows] - np.asarray(end, dtype=float)[:2]
                f = forces[rows]
                out[j, k] = float(
                    np.sum(d[:, 0] * f[:, 1] - d[:, 1] * f[:, 0]) + couples[rows].sum()
                )
        return out


def scene_loads(scene: Scene) -> tuple[list[list[float]], list[float]]:
    """The scene's own loads (rows fx, fy, moment) and tensions, as a Solver is given them."""
    return (
        [[float(ld.force[0]), float(ld.force[1]), float(ld.moment)] for ld in scene.loads],
        [float(t.tension) for t in scene.tendons],
    )


def flexures_holding(scene: Scene, body: str) -> list[str]:
    """The flexures between ``body`` and the base, nearest first (a flexure's own tip frame is
    beyond it: a point on flexure f loads f)."""
    out = []
    while body != BASE:
        if scene.body_kind(body) == "flexure":
            out.append(body)
        parent = scene.body_parent(body)
        assert parent is not None
        body = parent
    return out


Poses = tuple[Mapping[str, Any], Mapping[str, Any]]  # chain.Chain.frame_poses: frames, roots


def chain_statics(
    plan: StaticsPlan, poses: Poses, loads: Any, tensions: Any
) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """({flexure: transmitted world force}, {flexure: world angle of its root frame}) of a chain
    model's answer (``poses``: ``chain.Chain.frame_poses`` at its q; ``loads`` and
    ``tensions`` those it was solved under, scene order)."""
    frames, roots = poses
    forces = plan.transmitted(frames, loads, tensions)
    return (
        dict(zip(plan.flexures, forces)),
        {name: float(pose[2]) for name, pose in roots.items()},
    )


def end_curvatures(
    plan: StaticsPlan, poses: Poses, loads: Any, tensions: Any
) -> dict[str, tuple[float, float]]:
    """{flexure: (kappa at its root, kappa at its tip)} of a chain model's answer (``poses``
    as ``chain_statics``) by equilibrium, M / EI (``StaticsPlan.end_moments``): what its
    curvature profile must meet at both ends, whatever the model (flexgen.estimate's curvature
    floor)."""
    kappa = plan.end_moments(*poses, loads, tensions) / plan.EI[:, None]
    return {name: (float(k[0]), float(k[1])) for name, k in zip(plan.flexures, kappa)}


def axial_force(force: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """N = F . t at the world tangent angles ``angle`` (tension positive)."""
    return float(force[0]) * np.cos(angle) + float(force[1]) * np.sin(angle)
