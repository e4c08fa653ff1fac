"""The protocol every flexure model follows, in physical units.

A flexure model maps its generalized coordinates q (length ``n_dof``) to the pose of the flexure's
tip frame in its root frame, with the Jacobian and Hessian of that pose, and gives its elastic
energy with gradient and Hessian. The chain solver needs nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np


@dataclass(frozen=True)
class TipKinematics:
    pose: (
        np.ndarray
    )  # (3,)       x, y (length units), theta (rad) of the tip frame in the root frame
    J: np.ndarray  # (3, n)     d pose / d q
    H: np.ndarray  # (3, n, n)  d2 pose / dq dq


class FlexureModel(Protocol):
    kind: str  # "scm" (cc is scm with one mode), "prb", "fem": a KINDS entry of registry.py
    n_dof: int
    length: float
    EI: float

    def tip(self, q: np.ndarray) -> TipKinematics: ...
    def energy(self, q: np.ndarray) -> float: ...
    def energy_gradient(self, q: np.ndarray) -> np.ndarray: ...
    def energy_hessian(self, q: np.ndarray) -> np.ndarray: ...
    def core_flexure(self, f: Any) -> np.ndarray:
        """Fill the solver core's ``fg_flexure`` f (kind, length, kernels...); return the
        diagonal of the energy Hessian (every chain model's energy is quadratic with a diagonal
        Hessian)."""
        ...

    def shape(self, q: np.ndarray, num: int = 64) -> np.ndarray:
        """(num, 2) centreline points in the root frame, root first, for plots (fem: its
        n + 2 joint and end points, ``num`` ignored)."""
        ...


def core_tip(model, q) -> TipKinematics:
    """The tip kinematics of a model the solver core evaluates by itself (the n-element chain,
    the pseudo-rigid body): ``fg_flexure_tip`` on the model's ``fg_flexure``, so the formula
    with its derivatives exists once, in C (their ``tip_poses``, the pose alone and batched, is
    tested against it). (Smooth curvature models evaluate their generated NumPy kernels.)"""
    from ..core import ffi, lib

    k = int(model.n_dof)
    q = np.ascontiguousarray(np.asarray(q, dtype=float).reshape(k))
    f = ffi.new("fg_flexure *")
    f.ndof = k
    model.core_flexure(f)
    pose, J, H = np.empty(3), np.empty((3, k)), np.empty((3, k, k))
    scratch = np.empty(4 * (k + 1))
    buffers = [ffi.from_buffer("double[]", a) for a in (q, pose, J, H, scratch)]
    if not lib.fg_flexure_tip(f, *buffers):
        raise ValueError(f"{model!r} cannot be evaluated at q = {q.tolist()}")
    return TipKinematics(pose=pose, J=J, H=H)
