"""Polynomial stand-ins for cos and sin on [-a, a], and certified bounds of their errors.

The polynomial kernel replaces cos and sin by their Chebyshev interpolants of degree D on the
angle range [-a, a] (D + 1 first-kind Chebyshev points). Their errors, and the errors of their
first and second derivatives, are bounded from the Chebyshev series

    cos(a t) = J0(a) + 2 sum_{m>=1} (-1)^m J_2m(a) T_2m(t),
    sin(a t) = 2 sum_{m>=0} (-1)^m J_2m+1(a) T_2m+1(t),

whose coefficients are Bessel values (evaluated in mpmath to 40 digits). Interpolation at D + 1
Chebyshev points aliases T_k (k > D) onto +-T_k' with k' <= D, so the error is
sum_{k>D} alpha_k (T_k - alias_k), and |T_k^(r)| <= T_k^(r)(1) = prod_{j<r} (k^2 - j^2)/(2j + 1).
The same series bounds the truncation error sum_{k>D} |alpha_k| T_k^(r)(1) used by the Gauss
kernels. Tails are summed until they fall below 1e-40.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import mpmath

DIGITS = 40
FUNCTIONS = ("cos", "sin")


def _chebyshev_coefficient(func: str, a: mpmath.mpf, k: int) -> mpmath.mpf:
    """alpha_k of func(a t) = sum alpha_k T_k(t) (alpha_0 without the usual 1/2)."""
    if (func == "cos") != (k % 2 == 0):
        return mpmath.mpf(0)
    sign = -1 if (k // 2) % 2 else 1
    scale = 1 if k == 0 else 2
    return sign * scale * mpmath.besselj(k, a)


def _derivative_at_one(k: int, r: int) -> mpmath.mpf:
    """max over [-1, 1] of |T_k^(r)|, attained at t = 1."""
    value = mpmath.mpf(1)
    for j in range(r):
        value *= mpmath.mpf(k * k - j * j) / (2 * j + 1)
    return max(value, mpmath.mpf(0))


def _alias(k: int, degree: int) -> int | None:
    """Index k' <= degree that T_k takes at the degree+1 Chebyshev points (None: T_k vanishes)."""
    n = degree + 1
    k %= 4 * n
    if k > 2 * n:
        k = 4 * n - k
    if k == n:
        return None
    return k if k < n else 2 * n - k


@cache
def error_bound(
    func: str, a: float, degree: int, derivative: int = 0, kind: str = "interpolation"
) -> float:
    """Certified sup over [-a, a] of |d^r/dphi^r (func - p)|, p the degree-D interpolant
    (kind="interpolation") or the truncated Chebyshev series (kind="truncation")."""
    with mpmath.workdps(DIGITS):
        a_mp = mpmath.mpf(a)
        total = mpmath.mpf(0)
        k = degree + 1
        while True:
            alpha = abs(_chebyshev_coefficient(func, a_mp, k))
            term = _derivative_at_one(k, derivative)
            if kind == "interpolation":
                alias = _alias(k, degree)
                if alias is not None:
                    term += _derivative_at_one(alias, derivative)
            total += alpha * term
            if k > degree + 8 and alpha * term < mpmath.mpf(10) ** -40 and k > 2 * a + 8:
                break
            k += 1
        return float(total / a_mp**derivative)


@dataclass(frozen=True)
class TrigInterpolant:
    """Monomial coefficients (40-digit mpf, lowest first) of the cos/sin interpolants on [-a, a]."""

    a: float
    degree: int
    cos: tuple[mpmath.mpf, ...]
    sin: tuple[mpmath.mpf, ...]

    def bound(self, derivative: int = 0) -> float:
        """Certified bound on |cos - C|, |sin - S| (or their r-th derivatives) over [-a, a]."""
        return max(error_bound(f, self.a, self.degree, derivative) for f in FUNCTIONS)


@cache
def chebyshev_interpolant(a: float, degree: int) -> TrigInterpolant:
    """Interpolate cos and sin at the degree+1 Chebyshev points of [-a, a]; exact parity."""
    with mpmath.workdps(DIGITS + 10):
        a_mp = mpmath.mpf(a)
        n = degree + 1
        ts = [mpmath.cos((2 * j + 1) * mpmath.pi / (2 * n)) for j in range(n)]
        coeffs = {}
        for name, f in (("cos", mpmath.cos), ("sin", mpmath.sin)):
            values = [f(a_mp * t) for t in ts]
            # Chebyshev coefficients by the discrete orthogonality of T_k at the nodes.
            cheb = [
                2 * mpmath.fsum(v * mpmath.chebyt(k, t) for v, t in zip(values, ts)) / n
                for k in range(n)
            ]
            cheb[0] /= 2
            # T_k(phi / a) to monomials in phi.
            mono = [mpmath.mpf(0)] * n
            for k, c in enumerate(cheb):
                if (name == "cos") != (k % 2 == 0):
                    continue  # parity: cos is even, sin is odd, exactly
                for j, t in enumerate(_chebyshev_t_monomials(k)):
                    mono[j] += c * t / a_mp**j
            coeffs[name] = tuple(mono)
        return TrigInterpolant(a=float(a), degree=degree, cos=coeffs["cos"], sin=coeffs["sin"])


@cache
def _chebyshev_t_monomials(k: int) -> tuple[int, ...]:
    """Integer monomial coefficients of T_k, lowest first."""
    prev: tuple[int, ...] = (1,)
    cur: tuple[int, ...] = (0, 1)
    if k == 0:
        return prev
    for _ in range(k - 1):
        nxt = [0] * (len(cur) + 1)
        for j, c in enumerate(cur):
            nxt[j + 1] += 2 * c
        for j, c in enumerate(prev):
            nxt[j] -= c
        prev, cur = cur, tuple(nxt)
    return cur


def degree_for_tolerance(a: float, tol: float, max_degree: int = 60) -> int:
    """Smallest degree whose certified cos/sin interpolation error on [-a, a] is <= tol."""
    for degree in range(1, max_degree + 1):
        if max(error_bound(f, a, degree) for f in FUNCTIONS) <= tol:
            return degree
    raise ValueError(f"tolerance {tol:g} needs a degree above {max_degree} on range {a:g} rad")
