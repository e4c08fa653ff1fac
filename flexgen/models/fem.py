"""Chain of rigid segments joined by torsion springs ("FEM" in the paper).

Discretisation (chosen for O(1/n^2) convergence of the tip pose to the exact elastica): the flexure
of length L is cut into n cells of length h = L/n. Cell i = [i h, (i + 1) h] is lumped into one
torsion spring of stiffness EI/h placed at its midpoint s_i = (i + 1/2) h. The springs are
joined by rigid segments, so there are n + 1 segments of lengths h/2, h, ..., h, h/2 (the two
half-length end segments make the joints the cell midpoints). q[i] is the relative rotation of
joint i; the absolute angle of segment k is phi_k = q[0] + ... + q[k-1] and the tip angle is
sum(q).

Why O(h^2): at equilibrium the joint rotation q[i] = h M(s_i)/EI is the midpoint rule for the
curvature integral over cell i, so phi_k approximates the exact angle at s = k h to O(h^2); each
full segment then integrates (cos phi, sin phi) with the midpoint rule, and the half segments at
the ends contribute O(h^2). (Springs at the cell ends with full-length segments would lose the
half cell at the tip and converge only at O(h).)
"""

from __future__ import annotations

import numpy as np

from .base import TipKinematics, core_tip


class FEMModel:
    kind = "fem"
    CONSTANT_HESSIAN = True  # quadratic energy: energy_hessian does not depend on q

    def __init__(self, length: float, EI: float, elements: int = 16):
        if length <= 0 or EI <= 0:
            raise ValueError(
                f"FEMModel needs length > 0 and EI > 0, got length={length!r}, EI={EI!r}"
            )
        elements = int(elements)
        if elements < 1:
            raise ValueError(f"FEMModel needs elements >= 1, got elements={elements!r}")
        self.length = float(length)
        self.EI = float(EI)
        self.elements = elements
        self.n_dof = elements
        self.h = self.length / elements
        self.spring = self.EI / self.h
        seg = np.full(elements + 1, self.h)
        seg[0] = seg[-1] = 0.5 * self.h
        self.segments = seg  # (n + 1,) segment lengths, root first

    def _angles(self, q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, dtype=float).reshape(self.n_dof)
        return np.concatenate(([0.0], np.cumsum(q)))  # (n + 1,) absolute segment angles

    def core_flexure(self, f) -> np.ndarray:
        """Describe this flexure to the solver core (``fg_flexure`` f, FG_MODEL_FEM); the
        diagonal of the energy Hessian."""
        from ..core import lib

        f.kind, f.length = lib.FG_MODEL_FEM, self.length
        return np.full(self.n_dof, self.spring)

    def tip(self, q: np.ndarray) -> TipKinematics:
        """Tip pose, Jacobian and Hessian: the solver core's own evaluation of this model
        (``fg_flexure_tip``: the n-element chain with its derivatives is written once, in C;
        ``tip_poses`` repeats only its pose, batched, for the frame poses of stresses and
        drawings, tested against this)."""
        return core_tip(self, q)

    def tip_poses(self, Q) -> np.ndarray:
        """(m, 3) tip poses of the rows of ``Q`` (m, elements): the segments' sum, as ``tip``
        (the core's) gives it."""
        Q = np.asarray(Q, dtype=float).reshape(-1, self.n_dof)
        phi = np.concatenate([np.zeros((Q.shape[0], 1)), np.cumsum(Q, axis=1)], axis=1)
        return np.column_stack(
            [np.cos(phi) @ self.segments, np.sin(phi) @ self.segments, phi[:, -1]]
        )

    def energy(self, q: np.ndarray) -> float:
        q = np.asarray(q, dtype=float).reshape(self.n_dof)
        return 0.5 * self.spring * float(q @ q)

    def energy_gradient(self, q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, dtype=float).reshape(self.n_dof)
        return self.spring * q

    def energy_hessian(self, q: np.ndarray) -> np.ndarray:
        return self.spring * np.eye(self.n_dof)

    def curvature(self, q: np.ndarray, s) -> np.ndarray:
        """The curvature the chain stands for. At equilibrium joint i carries
        q[i] = h M(s_i)/EI (module docstring), so q[i]/h is the curvature at the joint
        s_i = (i + 1/2) h. Between joints the profile is linear, and on the half cells at the
        ends it is the line through the two nearest joints, extended: a moment linear in s (a
        tip force, small deflection) is then reproduced exactly, root included, where piecewise
        constant q[i]/h per cell would miss the root's value by a factor 1 - h/(2L). One
        element: the constant q[0]/L."""
        kappa = np.asarray(q, dtype=float).reshape(self.n_dof) / self.h
        s = np.asarray(s, dtype=float)
        if self.n_dof == 1:
            return np.full(s.shape, kappa[0])
        # the cell pair (joint j, joint j + 1) whose line gives kappa at s, ends extended
        t = s / self.h - 0.5  # joint coordinate: t = i at joint i
        j = np.clip(np.floor(t).astype(int), 0, self.n_dof - 2)
        w = t - j
        return (1.0 - w) * kappa[j] + w * kappa[j + 1]

    def curvature_bound(self) -> tuple[bool, float]:
        """(use the max, factor): max |kappa| <= factor x max |q_i| = 2 max |q_i| / h (the
        half cells at the ends extend the line through two joints)."""
        return True, 2.0 / self.h

    def curvature_extremes(self, q: np.ndarray) -> np.ndarray:
        """The joints and both ends: a piecewise linear profile peaks at one of them."""
        return np.concatenate([[0.0, self.length], (np.arange(self.n_dof) + 0.5) * self.h])

    def tangent_angle(self, q: np.ndarray, s) -> np.ndarray:
        """The angle to the root frame of the rigid segment at each arc length ``s`` (segment
        k spans (k - 1/2) h to (k + 1/2) h, the end ones half as long)."""
        k = np.clip(np.floor(np.asarray(s, dtype=float) / self.h + 0.5).astype(int), 0, self.n_dof)
        return self._angles(q)[k]

    def shape(self, q: np.ndarray, num: int = 64) -> np.ndarray:
        """The n + 2 joint/end points of the chain (root first); ``num`` is ignored."""
        phi = self._angles(q)
        pts = np.zeros((self.n_dof + 2, 2))
        pts[1:, 0] = np.cumsum(self.segments * np.cos(phi))
        pts[1:, 1] = np.cumsum(self.segments * np.sin(phi))
        return pts
