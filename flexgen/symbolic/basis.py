"""The shifted Legendre curvature basis of one flexure, and Gauss-Legendre rules on [0, 1].

kappa(sigma) L = sum_n q_n P_n(2 sigma - 1);  phi(sigma) = sum_n q_n B_n(sigma),
B_n(sigma) = int_0^sigma P_n(2t - 1) dt;  U = EI/(2L) sum_n q_n^2 / (2n + 1).
Exact arithmetic (SymPy rationals) for the basis; mpmath at 40 digits for the quadrature rules,
so that generated constants do not depend on the machine's libm.
"""

from __future__ import annotations

from functools import cache

import mpmath
import sympy as sp

sigma = sp.Symbol("sigma", real=True)
DIGITS = 40
UNIT_ROUNDOFF = 2.0**-53


def gauss_rounding(modes: int, nodes: int) -> float:
    """The rounding allowance of a Gauss kernel's sums in double (N-term node angles, G-term
    sums of terms of magnitude at most 1), units of L; the error bounds of the gauss and local
    kernels add it."""
    return (modes + nodes + 4) * 2 * UNIT_ROUNDOFF


def shifted_legendre(n: int) -> sp.Poly:
    """P_n(2 sigma - 1) as an exact polynomial in sigma."""
    return sp.Poly(sp.legendre(n, 2 * sigma - 1), sigma)


@cache
def angle_basis(n: int) -> sp.Poly:
    """B_n(sigma) = int_0^sigma P_n(2t - 1) dt; B_n(1) = 1 if n == 0 else 0."""
    return shifted_legendre(n).integrate()


def energy_weights(modes: int) -> list[sp.Rational]:
    """w_n = 1/(2n+1): U = EI/(2L) sum w_n q_n^2."""
    return [sp.Rational(1, 2 * n + 1) for n in range(modes)]


@cache
def gauss_legendre(nodes: int) -> tuple[tuple[mpmath.mpf, ...], tuple[mpmath.mpf, ...]]:
    """Gauss-Legendre nodes and weights on [0, 1] (weights sum to 1), to DIGITS digits."""
    with mpmath.workdps(DIGITS + 10):
        xs, ws = [], []
        for k in range(1, nodes + 1):
            x = mpmath.cos(mpmath.pi * (k - mpmath.mpf(1) / 4) / (nodes + mpmath.mpf(1) / 2))
            for _ in range(100):
                p0, p1 = mpmath.mpf(1), x
                for j in range(2, nodes + 1):
                    p0, p1 = p1, ((2 * j - 1) * x * p1 - (j - 1) * p0) / j
                dp = nodes * (x * p1 - p0) / (x * x - 1) if nodes > 1 else mpmath.mpf(1)
                if nodes == 1:
                    p1 = x
                step = p1 / dp
                x -= step
                if abs(step) < mpmath.mpf(10) ** (-(DIGITS + 5)):
                    break
            p0, p1 = mpmath.mpf(1), x
            for j in range(2, nodes + 1):
                p0, p1 = p1, ((2 * j - 1) * x * p1 - (j - 1) * p0) / j
            dp = nodes * (x * p1 - p0) / (x * x - 1) if nodes > 1 else mpmath.mpf(1)
            xs.append((1 - x) / 2)  # ascending sigma in [0, 1]
            ws.append(1 / ((1 - x * x) * dp * dp))  # 2/((1-x^2)P'^2), halved for [0, 1]
        return tuple(xs), tuple(ws)
