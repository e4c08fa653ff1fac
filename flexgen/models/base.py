"""The protocol every flexure model follows, in physical units.

A flexure model maps its generalized coordinates q (length ``n_dof``) to the pose of the flexure's
tip frame in its root frame, with the Jacobian and Hessian of that pose, and gives its elastic
energy with gradient and Hessian. The chain solver needs nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


@dataclass(frozen=True)
class TipKinematics:
    pose: (
        np.ndarray
    )  # (3,)       x, y (length units), theta (rad) of the tip frame in the root frame
    J: np.ndarray  # (3, n)     d pose / d q
    H: np.ndarray  # (3, n, n)  d2 pose / dq dq


class FlexureModel(Protocol):
    kind: str  # "scm", "cc", "prb", "fem"
    label: str  # e.g. "scm3", "fem16", "prb"
    n_dof: int
    length: float
    EI: float

    def tip(self, q: np.ndarray) -> TipKinematics: ...
    def energy(self, q: np.ndarray) -> float: ...
    def energy_gradient(self, q: np.ndarray) -> np.ndarray: ...
    def energy_hessian(self, q: np.ndarray) -> np.ndarray: ...
    def shape(self, q: np.ndarray, num: int = 64) -> np.ndarray:
        """(num, 2) centreline points in the root frame, root first, for plots."""
        ...
