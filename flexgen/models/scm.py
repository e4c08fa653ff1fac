"""The smooth curvature model of one flexure, through the generated NumPy kernels.

q are the Legendre curvature coefficients (kappa L = sum q_n P_n(2s/L - 1)), dimensionless, so
q[0] is the tip angle. The kernels, tried in this order where a choice has them:

- the local Gauss kernel scm{N}_local{G}, wherever its error bound is certified at the q it
  evaluates (smooth bends up to about 270 degrees, tighter bounds, 0.5x to 0.2x the polynomial
  kernel's time): "auto" and "local";
- the closed-form polynomial kernel scm{N}, valid while |phi| <= its PHI_MAX along the flexure:
  "auto" and "poly" (and "local" without a local kernel in the kernel folder);
- the Gauss kernel scm{N}_gauss{G}, any angle, certified on its range: "auto", "local" and
  "gauss". Reaching it from one of the others is a switch: the core reports each flexure that
  switched, and the Result notes it.

With "poly" alone a pose past the range raises ValueError naming the flexure (``name``) and the
range, so the solver reports no equilibrium instead of a wrong one. ``cc`` is this model with one
mode.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
from numpy.polynomial import legendre

from flexgen import kernels
from flexgen.models.base import TipKinematics

KERNEL_CHOICES = ("auto", "poly", "gauss", "local")


def angle_basis(modes: int, sigma: np.ndarray) -> np.ndarray:
    """B[k, n] = int_0^sigma_k P_n(2t - 1) dt (numpy only: the runtime does not import SymPy)."""
    cols = []
    for n in range(modes):
        c = np.zeros(n + 1)
        c[n] = 1
        cols.append(legendre.legval(2 * sigma - 1, legendre.legint(c, lbnd=-1) / 2))
    return np.array(cols).T


@cache
def _angle_coefficients(modes: int) -> np.ndarray:
    """(modes + 1, modes) M: M @ q are the Legendre coefficients (in 2 sigma - 1) of
    phi(sigma) = int_0^sigma kappa L (``angle_basis``'s columns, as one series)."""
    out = np.zeros((modes + 1, modes))
    for n in range(modes):
        c = np.zeros(n + 1)
        c[n] = 1
        integral = legendre.legint(c, lbnd=-1) / 2
        out[: integral.size, n] = integral
    out.setflags(write=False)
    return out


@cache
def _grid_bases(modes: int, num: int) -> tuple[np.ndarray, np.ndarray]:
    """(num, modes) matrices K, A on sigma = linspace(0, 1, num): K @ q = kappa L (the
    Legendre values) and A @ q = phi (``angle_basis``) there."""
    sigma = np.linspace(0.0, 1.0, num)
    K = legendre.legvander(2.0 * sigma - 1.0, modes - 1)
    A = angle_basis(modes, sigma)
    K.setflags(write=False)
    A.setflags(write=False)
    return K, A


def _peak3(q1: float, q2: float) -> float | None:
    """Three modes: the x in [-1, 1] where kappa' = q1 + 3 q2 x vanishes (kappa L = q0 + q1 x +
    q2 (3 x^2 - 1) / 2), None where there is none; in plain floats (a study asks per case: the
    root finder's eigenvalue call would cost more than the solve). ``extremes_profile`` applies
    the same rule to many rows at once."""
    if q2 == 0.0:
        return None
    x = -q1 / (3.0 * q2)
    return x if -1.0 <= x <= 1.0 else None


class SCMModel:
    kind = "scm"
    CONSTANT_HESSIAN = True  # quadratic energy: energy_hessian does not depend on q

    def __init__(
        self,
        length: float,
        EI: float,
        modes: int = 3,
        kernel: str = "auto",
        name: str = "?",
    ):
        if kernel not in KERNEL_CHOICES:
            raise ValueError(f"kernel: must be one of {', '.join(KERNEL_CHOICES)}, got {kernel!r}")
        self.length, self.EI, self.n_dof, self.kernel = float(length), float(EI), modes, kernel
        # the kernels in the order the core tries them (fg_flexure.local, .poly, .gauss; the
        # module docstring); a name and a NumPy module each, None where the choice has none
        self.local_name = self.local = None
        if kernel in ("auto", "local"):
            try:
                self.local_name = kernels.gauss_kernel_name(modes, family="local")
                self.local = kernels.load_numpy(self.local_name)
            except kernels.KernelNotFound:
                pass  # the polynomial kernel in its place (slower, as accurate)
        self.poly_name = self.poly = None
        if kernel in ("auto", "poly") or (kernel == "local" and self.local is None):
            self.poly_name = kernels.kernel_name(modes)
            self.poly = kernels.load_numpy(self.poly_name)
        self.gauss_name = self.gauss = self.no_gauss = None
        if kernel != "poly":
            try:
                self.gauss_name = kernels.gauss_kernel_name(modes)
                self.gauss = kernels.load_numpy(self.gauss_name)
            except kernels.KernelNotFound as missing:
                if kernel == "gauss":
                    raise
                self.no_gauss = str(missing)  # "auto", "local": fine while the first is in range
        loaded = self.poly or self.local or self.gauss
        assert loaded is not None  # "gauss" (no other) raises above if its kernel is missing
        self.weights = loaded.ENERGY_WEIGHTS
        self.name = name

    # -- kernels -------------------------------------------------------------------------
    def first(self, q):
        """The first kernel (local, then polynomial) that evaluates q, or None: past both (or
        kernel "gauss")."""
        if self.local is not None and self.local.in_range(q):
            return self.local
        if self.poly is not None and self.poly.in_range(q):
            return self.poly
        return None

    def in_range(self, q) -> bool:
        """Is q within the set of the first kernels (local, polynomial), so that no switch to the
        Gauss kernel is needed (for "gauss": is its bound certified)?"""
        q = np.asarray(q, dtype=float)
        if self.local is not None or self.poly is not None:
            return self.first(q) is not None
        assert self.gauss is not None  # no other: kernel "gauss", whose kernel must exist
        return bool(self.gauss.in_range(q))

    def core_flexure(self, f) -> np.ndarray:
        """Describe this flexure to the solver core: its generated C kernels (compiled into
        flexgen._core) in the ``fg_flexure`` f; the diagonal of the energy Hessian."""
        from flexgen.core import kernel_functions, lib

        f.kind, f.length = lib.FG_MODEL_KERNEL, self.length
        if self.local is not None:
            f.local, f.local_in_range = kernel_functions(self.local_name)
        if self.poly is not None:
            f.poly, f.in_range = kernel_functions(self.poly_name)
        if self.gauss is not None:
            f.gauss, f.gauss_in_range = kernel_functions(self.gauss_name)
        return self.EI / self.length * np.asarray(self.weights, dtype=float)

    def first_range(self) -> str:
        """Where the first kernels (local, polynomial) hold, in words: the local kernel's
        certified set, the polynomial kernel's range, or both."""
        assert self.local is not None or self.poly is not None, "first_range: Gauss kernel only"
        words = []
        if self.local is not None:
            words.append(
                f"the set where the local kernel {self.local_name} certifies its error bound "
                f"(smooth bends up to about {math.degrees(self.local.PHI_MAX):g} deg)"
            )
        if self.poly is not None:
            words.append(
                f"the range of the polynomial kernel {self.poly_name} "
                f"(|phi| <= {math.degrees(self.poly.PHI_MAX):g} deg along the flexure)"
            )
        return " and ".join(words)

    def range_error(self) -> str:
        """Why this flexure cannot be evaluated past its first kernels' range."""
        assert self.local is not None or self.poly is not None, "range_error: Gauss kernel only"
        why = (
            f"and {self.no_gauss}"
            if self.no_gauss
            else "kernel 'poly' was asked for, 'auto' switches to the Gauss kernel"
        )
        return f"flexure {self.name!r}: bent past {self.first_range()}; {why}"

    def kernel_at(self, q):
        """The kernel that evaluates q, as the core picks it: the local kernel where it
        certifies q, the polynomial one within its range, else the Gauss kernel; ValueError
        (``range_error``) when there is none."""
        first = self.first(q)
        if first is not None:
            return first
        if self.gauss is None:
            raise ValueError(self.range_error())
        return self.gauss

    def switch_note(self, q=None) -> str | None:
        """The note for a solve in which this flexure left its first kernels' set (the core
        reports that it did); ``q`` is the equilibrium, if one was found."""
        if self.local is None and self.poly is None:
            return None
        if q is None:
            where = "during the solve"
        elif self.in_range(q):
            where = "during the solve (the equilibrium is back in range)"
        else:
            where = "at equilibrium"
        return (
            f"flexure {self.name!r}: bent past {self.first_range()} {where}; "
            f"switched to the Gauss kernel {self.gauss_name}"
        )

    def error_bound(self, q) -> float:
        """Kernel error bound on the tip position at q, in length units."""
        return float(self.kernel_at(np.asarray(q, dtype=float)).ERROR_BOUND) * self.length

    # -- the FlexureModel protocol ---------------------------------------------------------
    def tip(self, q) -> TipKinematics:
        q = np.asarray(q, dtype=float)
        pose, J, H = self.kernel_at(q).evaluate(q)
        pose[..., :2] *= self.length
        J[..., :2, :] *= self.length
        H[..., :2, :, :] *= self.length
        return TipKinematics(pose, J, H)

    def tip_poses(self, Q) -> np.ndarray:
        """(m, 3) tip poses of the rows of ``Q`` (m, modes), each by the kernel ``kernel_at``
        picks for it: one vectorised call per kernel (``Chain.frame_poses_batch``)."""
        Q = np.asarray(Q, dtype=float).reshape(-1, self.n_dof)
        out = np.empty((Q.shape[0], 3))
        left = np.ones(Q.shape[0], dtype=bool)
        for kernel in (self.local, self.poly, self.gauss):
            if kernel is None or not left.any():
                continue
            take = left if kernel is self.gauss else left & kernel.in_range(Q)
            if take.any():
                out[take] = kernel.evaluate(Q[take])[0]
                left &= ~take
        if left.any():
            raise ValueError(self.range_error())
        out[:, :2] *= self.length
        return out

    def energy(self, q) -> float:
        q = np.asarray(q, dtype=float)
        return 0.5 * self.EI / self.length * float(self.weights @ (q * q))

    def energy_gradient(self, q) -> np.ndarray:
        return self.EI / self.length * self.weights * np.asarray(q, dtype=float)

    def energy_hessian(self, q) -> np.ndarray:
        return np.diag(self.EI / self.length * self.weights)

    def curvature(self, q, s) -> np.ndarray:
        """kappa(s) = sum q_n P_n(2 s/L - 1) / L at the arc lengths ``s`` (1/length)."""
        sigma = np.asarray(s, dtype=float) / self.length
        return legendre.legval(2.0 * sigma - 1.0, np.asarray(q, dtype=float)) / self.length

    def curvature_bound(self) -> tuple[bool, float]:
        """(use the max, factor): max |kappa| <= factor x sum |q_n| (|P_n| <= 1 on the
        flexure), the validity screen's cheap strain check on every answer (validity.calm)."""
        return False, 1.0 / self.length

    def max_abs_curvature(self, q) -> float:
        """max |kappa| over the flexure (1/length), on the polynomial as ``curvature_extremes``
        finds it; for up to three modes in closed form with plain floats (a study asks for it
        once per case: the root finder's eigenvalue call would cost more than the solve)."""
        if len(q) > 3:
            return float(np.max(np.abs(self.curvature(q, self.curvature_extremes(q)))))
        q0, q1, q2 = (*(float(v) for v in q), 0.0, 0.0)[:3]
        # kappa L = q0 + q1 x + q2 (3 x^2 - 1) / 2 on x in [-1, 1]: the ends, and x* where
        # kappa' = q1 + 3 q2 x vanishes
        best = max(abs(q0 + q1 + q2), abs(q0 - q1 + q2))
        x = _peak3(q1, q2)
        if x is not None:
            best = max(best, abs(q0 + q1 * x + q2 * (1.5 * x * x - 0.5)))
        return best / self.length

    def curvature_extremes(self, q) -> np.ndarray:
        """The arc lengths where |kappa| may peak: both ends and the real roots of kappa' in
        the flexure (the maximum of |p| of a polynomial p on an interval is at an end or where
        p' = 0), so the largest curvature is found exactly, not to a grid's resolution."""
        q = np.asarray(q, dtype=float)
        ends = np.array([0.0, self.length])
        if q.size < 3:  # kappa' is a constant: |kappa| peaks at an end
            return ends
        if q.size == 3:  # kappa' = q1 + 3 q2 x: its root in closed form (no eigenvalue call)
            x = _peak3(float(q[1]), float(q[2]))
            return ends if x is None else np.append(ends, 0.5 * (x + 1.0) * self.length)
        roots = legendre.legroots(legendre.legder(q))
        real = roots[np.abs(roots.imag) <= 1e-12 * (1.0 + np.abs(roots.real))].real
        inside = real[(real >= -1.0) & (real <= 1.0)]
        return np.concatenate([ends, (inside + 1.0) * 0.5 * self.length])

    def grid_profile(self, q, num: int) -> tuple[np.ndarray, np.ndarray]:
        """(kappa, phi) on ``num`` arc lengths evenly from root to tip: ``curvature`` and
        ``tangent_angle`` there, by two cached matrices; ``q`` (..., modes) gives (..., num)
        (a study's stresses, many answers at once)."""
        K, A = _grid_bases(self.n_dof, num)
        q = np.asarray(q, dtype=float)
        return (q @ K.T) / self.length, q @ A.T

    def extremes_profile(self, Q) -> tuple[np.ndarray, np.ndarray]:
        """(kappa, phi) at the interior ``curvature_extremes`` of each row of ``Q`` (m, modes):
        (m, modes - 2) each, NaN where a row has fewer; the ends are not in it (the grid has
        them). Three modes in closed form for all rows at once, more per row."""
        Q = np.asarray(Q, dtype=float).reshape(-1, self.n_dof)
        m, k = Q.shape[0], max(self.n_dof - 2, 0)
        x = np.full((m, k), np.nan)
        if self.n_dof == 3:  # _peak3 on every row
            with np.errstate(divide="ignore", invalid="ignore"):
                r = -Q[:, 1] / (3.0 * Q[:, 2])
            x[:, 0] = np.where((r >= -1.0) & (r <= 1.0), r, np.nan)
        elif self.n_dof > 3:
            for i, q in enumerate(Q):
                inside = 2.0 * self.curvature_extremes(q)[2:] / self.length - 1.0
                x[i, : inside.size] = inside
        xs = np.nan_to_num(x)  # evaluated anywhere, NaN again below
        angle_series = Q @ _angle_coefficients(self.n_dof).T  # (m, modes + 1)
        kappa = legendre.legval(xs.T, Q.T, tensor=False).T / self.length
        phi = legendre.legval(xs.T, angle_series.T, tensor=False).T
        return np.where(np.isnan(x), np.nan, kappa), np.where(np.isnan(x), np.nan, phi)

    def tangent_angle(self, q, s) -> np.ndarray:
        """phi(s) = int_0^s kappa: the tangent's angle to the root frame at the arc lengths ``s``
        (flexgen.statics: the axial force along the flexure)."""
        sigma = np.clip(np.asarray(s, dtype=float) / self.length, 0.0, 1.0)
        series = _angle_coefficients(self.n_dof) @ np.asarray(q, dtype=float)
        return legendre.legval(2.0 * sigma - 1.0, series)

    def shape(self, q, num: int = 64) -> np.ndarray:
        """Centreline in the root frame: cumulative Gauss integration of cos/sin phi per panel."""
        q = np.asarray(q, dtype=float)
        edges = np.linspace(0.0, 1.0, num)
        x, w = legendre.leggauss(8)
        h = edges[1] - edges[0]
        sig = edges[:-1, None] + (x + 1)[None, :] * h / 2
        phi = angle_basis(self.n_dof, sig.ravel()) @ q
        phi = phi.reshape(sig.shape)
        dx = (np.cos(phi) @ w) * h / 2
        dy = (np.sin(phi) @ w) * h / 2
        pts = np.zeros((num, 2))
        pts[1:, 0], pts[1:, 1] = np.cumsum(dx), np.cumsum(dy)
        return pts * self.length
