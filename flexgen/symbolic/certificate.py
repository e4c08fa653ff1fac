"""The local certificate of a Gauss kernel: its quadrature error bounded at each q.

A ``local`` kernel integrates with few Gauss nodes and certifies its error where it is used, at
the q it evaluates, instead of over a whole range of angles (the ``gauss`` family's bound, which
must cover the wiggliest profile of the range and so needs four times the nodes).

The bound. An integrand F analytic in the open Bernstein ellipse E_rho of [-1, 1] (foci +-1,
semi-axes summing to rho > 1) with |F| <= M there has Chebyshev coefficients |a_k| <= 2 M rho^-k
(Trefethen, Approximation Theory and Approximation Practice, Thm 8.1), so its best polynomial
approximation of degree m errs by at most 2 M rho^-m / (rho - 1). A G-node Gauss rule on [0, 1]
is exact to degree 2G - 1 and its positive weights sum to 1, as does the integral's length, so

    |int_0^1 f - sum_g w_g f(sigma_g)| <= 4 M rho^(1 - 2G) / (rho - 1).

The kernel's integrands are f = w(sigma) g(phi(sigma)) with w = 1 (pose), B_i (J) or B_i B_j (H)
and g = +-cos, +-sin. With sigma = (1 + t)/2 and the Chebyshev coefficients c_k of each
polynomial in t, on E_rho |T_k| <= (rho^k + rho^-k)/2 and |Im T_k| <= (rho^k - rho^-k)/2, and
|cos(x + iy)|, |sin(x + iy)| <= cosh(y), so

    M <= W(rho) cosh(sum_n |q_n| nu_n(rho)),
    W(rho) = max_w sum_k |c_k(w)| (rho^k + rho^-k)/2,  nu_n(rho) = sum_k |c_k(B_n)| (rho^k - rho^-k)/2.

For each rho of a fixed list and each of pose, J, H the error is within its tolerance where
sum_n nu_n(rho) |q_n| <= S(rho) = acosh((tol - rounding) / (4 W(rho) rho^(1 - 2G) / (rho - 1)));
a row (nu(rho), S(rho)) is kept when S > 0 (the smallest S of the three). ``in_range(q)`` of a
local kernel is 1 when one row holds: a few multiply-adds per row, no transcendental function.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import mpmath
import sympy as sp

from flexgen.codegen.spec import MAX_NODES
from flexgen.symbolic.basis import DIGITS, angle_basis, gauss_rounding, sigma

# the ellipse parameters tried, one in_range inequality each: a large rho suits small bends (the
# rho^(1 - 2G) factor), a small rho large ones (the cosh factor); the rows of a kernel are the
# ones with a positive limit (the shipped 9 to 13 nodes: rho from 3, 4 or 5 to 32)
RHOS = ("1.25", "1.5", "2", "2.5", "3", "4", "5", "6", "8", "10", "12", "16", "24", "32")
# the tolerances on J and H relative to the pose's (their integrands carry B_i, B_i B_j)
JACOBIAN_FACTOR = 10.0
HESSIAN_FACTOR = 100.0


def tolerances(tol: float) -> tuple[float, float, float]:
    """The certified bounds (pose, J, H) of a local kernel of pose tolerance ``tol`` (J and H
    as printed: 12 significant digits)."""
    return tol, float(f"{JACOBIAN_FACTOR * tol:.12g}"), float(f"{HESSIAN_FACTOR * tol:.12g}")


@dataclass(frozen=True)
class Row:
    """sum_n nu[n] |q_n| <= limit: the error bounds hold (the ellipse rho)."""

    rho: float
    nu: tuple[float, ...]
    limit: float


def _chebyshev(poly: sp.Poly) -> list[mpmath.mpf]:
    """Chebyshev coefficients (lowest first) of poly(sigma) as a polynomial in t, sigma = (1 + t)/2."""
    t = sp.Symbol("t")
    mono = sp.Poly(sp.expand(poly.as_expr().subs(sigma, (1 + t) / 2)), t).all_coeffs()[::-1]
    return _mono_to_cheb([mpmath.mpf(sp.Rational(c).p) / sp.Rational(c).q for c in mono])


def _mono_to_cheb(mono: list[mpmath.mpf]) -> list[mpmath.mpf]:
    """Monomial to Chebyshev coefficients: t^j = sum_k b_jk T_k by t T_k = (T_{k+1} + T_{k-1})/2."""
    out = [mpmath.mpf(0)] * len(mono)
    power = [mpmath.mpf(1)]  # t^0 in the Chebyshev basis
    for j, c in enumerate(mono):
        if j > 0:
            nxt = [mpmath.mpf(0)] * (len(power) + 1)
            for k, b in enumerate(power):
                if k == 0:
                    nxt[1] += b
                else:
                    nxt[k + 1] += b / 2
                    nxt[k - 1] += b / 2
            power = nxt
        for k, b in enumerate(power):
            out[k] += c * b
    return out


@cache
def _weights(modes: int) -> tuple[list[list[mpmath.mpf]], list[list[mpmath.mpf]]]:
    """The Chebyshev coefficients of B_n (J's weights) and of B_i B_j (H's)."""
    with mpmath.workdps(DIGITS):
        basis = [_chebyshev(angle_basis(n)) for n in range(modes)]
        products = [
            _chebyshev(angle_basis(i) * angle_basis(j))
            for i in range(modes)
            for j in range(i, modes)
        ]
        return basis, products


def _on_ellipse(coeffs: list[mpmath.mpf], rho: mpmath.mpf, sign: int) -> mpmath.mpf:
    """sum_k |c_k| (rho^k + sign rho^-k) / 2: a bound on |p| (sign +1) or |Im p| (-1) on E_rho."""
    return mpmath.fsum(abs(c) * (rho**k + sign * rho**-k) / 2 for k, c in enumerate(coeffs))


def certificate(modes: int, nodes: int, tol: float) -> tuple[Row, ...]:
    """The rows of the local certificate of a ``nodes``-point Gauss kernel of ``modes`` modes:
    pose error <= tol, J <= JACOBIAN_FACTOR tol, H <= HESSIAN_FACTOR tol (units of L) at every q
    one row holds for. Floats rounded to the safe side (nu up, limits down)."""
    rows = []
    with mpmath.workdps(DIGITS):
        rounding = gauss_rounding(modes, nodes)
        W1, terms = _ellipse_terms(modes)
        for rho, W, nu in terms:
            scale = 4 * rho ** (1 - 2 * nodes) / (rho - 1)
            limit = mpmath.inf
            for w, w1, bound in zip(W, W1, tolerances(tol)):
                # the rounding of the sum: |w| <= w1 on [0, 1], |cos|, |sin| <= 1
                room = (bound - rounding * w1) / (scale * w)
                limit = min(limit, mpmath.acosh(room) if room >= 1 else mpmath.mpf(-1))
            if limit > 0:
                rows.append(
                    Row(
                        float(rho),
                        tuple(float(v) * (1 + 1e-12) for v in nu),
                        float(limit) * (1 - 1e-12),
                    )
                )
    return tuple(rows)


@cache
def _ellipse_terms(modes: int) -> tuple:
    """(the bounds of the (pose, J, H) weights on [-1, 1], and per rho of RHOS: rho, W(rho) of
    (pose, J, H), nu(rho))."""
    out = []
    with mpmath.workdps(DIGITS):
        basis, products = _weights(modes)
        families = ([[mpmath.mpf(1)]], basis, products)
        W1 = tuple(_on_ellipse_max(fam) for fam in families)
        for text in RHOS:
            rho = mpmath.mpf(text)
            W = tuple(max(_on_ellipse(w, rho, 1) for w in fam) for fam in families)
            nu = tuple(_on_ellipse(b, rho, -1) for b in basis)
            out.append((rho, W, nu))
    return W1, tuple(out)


def _on_ellipse_max(weights: list[list[mpmath.mpf]]) -> mpmath.mpf:
    """max_w sum_k |c_k(w)|: a bound on |w| on [-1, 1] (rho = 1)."""
    return max(mpmath.fsum(abs(c) for c in w) for w in weights)


def certified(rows: tuple[Row, ...], q) -> bool:
    """Does one row hold at q (a sequence of floats)? The reference for the generated checks."""
    a = [abs(float(v)) for v in q]
    return any(sum(n * x for n, x in zip(row.nu, a)) <= row.limit for row in rows)


def nodes_for_arc(modes: int, bend: float, tol: float, max_nodes: int = MAX_NODES) -> int:
    """The fewest nodes whose certificate covers the constant-curvature arc of ``bend`` radians
    (q = (bend, 0, ..., 0))."""
    q = [bend] + [0.0] * (modes - 1)
    for G in range(1, max_nodes + 1):
        if certified(certificate(modes, G, tol), q):
            return G
    raise ValueError(f"--range: no local kernel of up to {max_nodes} nodes covers this bend")
