"""Pseudo-rigid-body 1R model (Howell) of a straight cantilever flexure.

The flexure of length L is replaced by a rigid segment of length (1 - gamma) L from the root, a pin,
and a rigid segment of length gamma L to the tip. A torsion spring of stiffness
K = gamma * K_theta * EI / L acts on the pin angle q[0]. The tip frame rotates with the second
segment, so the tip angle is q[0]. Howell's defaults gamma = 0.85, K_theta = 2.65 give a tip path
within about 0.5 % of the deflection up to about 64 degrees of tip rotation (for a tip moment the
angle/moment relation is then approximate to a few percent).
"""

from __future__ import annotations

import numpy as np

from .base import TipKinematics, core_tip


class PRBModel:
    kind = "prb"
    CONSTANT_HESSIAN = True  # quadratic energy: energy_hessian does not depend on q
    n_dof = 1

    def __init__(self, length: float, EI: float, gamma: float = 0.85, K_theta: float = 2.65):
        if length <= 0 or EI <= 0:
            raise ValueError(
                f"PRBModel needs length > 0 and EI > 0, got length={length!r}, EI={EI!r}"
            )
        if not 0.0 < gamma <= 1.0:
            raise ValueError(f"PRBModel needs 0 < gamma <= 1, got gamma={gamma!r}")
        self.length = float(length)
        self.EI = float(EI)
        self.gamma = float(gamma)
        self.K_theta = float(K_theta)
        self.stiffness = self.gamma * self.K_theta * self.EI / self.length

    def core_flexure(self, f) -> np.ndarray:
        """Describe this flexure to the solver core (``fg_flexure`` f, FG_MODEL_PRB); the
        diagonal of the energy Hessian."""
        from ..core import lib

        f.kind, f.length, f.gamma = lib.FG_MODEL_PRB, self.length, self.gamma
        return np.array([self.stiffness])

    def tip(self, q: np.ndarray) -> TipKinematics:
        """Tip pose, Jacobian and Hessian: the solver core's own evaluation of this model
        (``fg_flexure_tip``: the pseudo-rigid body with its derivatives is written once, in C;
        ``tip_poses`` repeats only its pose, batched, for the frame poses of stresses and
        drawings, tested against this)."""
        return core_tip(self, q)

    def tip_poses(self, Q) -> np.ndarray:
        """(m, 3) tip poses of the pin angles ``Q`` (m, 1), as ``tip`` (the core's) gives them."""
        q = np.asarray(Q, dtype=float).reshape(-1)
        arm = self.gamma * self.length
        return np.column_stack(
            [(1.0 - self.gamma) * self.length + arm * np.cos(q), arm * np.sin(q), q]
        )

    def energy(self, q: np.ndarray) -> float:
        q = np.asarray(q, dtype=float).reshape(1)
        return 0.5 * self.stiffness * float(q[0] ** 2)

    def energy_gradient(self, q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, dtype=float).reshape(1)
        return self.stiffness * q.copy()

    def energy_hessian(self, q: np.ndarray) -> np.ndarray:
        return np.array([[self.stiffness]])

    def curvature(self, q: np.ndarray, s) -> np.ndarray:
        """The pin's spring torque T = K q[0] is the bending moment the pseudo-rigid body
        carries; T/EI is the curvature it stands for. The model knows that moment at its pin
        only, so the profile is that constant along the whole flexure (a tip moment bends a
        real strip uniformly; under a tip force the root moment is larger, by about 1/gamma,
        which this model cannot see)."""
        q = np.asarray(q, dtype=float).reshape(1)
        kappa = self.stiffness * float(q[0]) / self.EI
        return np.full(np.shape(s), kappa)

    def curvature_bound(self) -> tuple[bool, float]:
        """(use the max, factor): |kappa| = K |q| / EI itself (the profile is constant)."""
        return False, self.stiffness / self.EI

    def curvature_extremes(self, q: np.ndarray) -> np.ndarray:
        """Where |kappa| peaks: anywhere (the profile is constant); the root."""
        return np.zeros(1)

    def tangent_angle(self, q: np.ndarray, s) -> np.ndarray:
        """The segments' angle to the root frame at the arc lengths ``s``: 0 on the first,
        rigid one, the pin angle q[0] beyond the pin at (1 - gamma) L."""
        q = np.asarray(q, dtype=float).reshape(1)
        s = np.asarray(s, dtype=float)
        return np.where(s <= (1.0 - self.gamma) * self.length, 0.0, float(q[0]))

    def shape(self, q: np.ndarray, num: int = 64) -> np.ndarray:
        """(num, 2) points along the two rigid segments (root, pin, tip), root first."""
        q = np.asarray(q, dtype=float).reshape(1)
        L, g = self.length, self.gamma
        s = np.linspace(0.0, L, num)
        s1 = (1.0 - g) * L
        out = np.zeros((num, 2))
        first = s <= s1
        out[first, 0] = s[first]
        d = s[~first] - s1
        out[~first, 0] = s1 + d * np.cos(q[0])
        out[~first, 1] = d * np.sin(q[0])
        return out
