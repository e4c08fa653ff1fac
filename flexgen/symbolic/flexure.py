"""One flexure's tip pose, Jacobian and Hessian as SymPy expressions in q, with error bounds.

Both kernel families integrate over sigma with a Gauss-Legendre rule on the nodes sigma_g:

    x = sum_g w_g c(phi_g),  y = sum_g w_g s(phi_g),  theta = q_0,   phi_g = sum_n q_n B_n(sigma_g)

* poly:  c, s are the degree-D Chebyshev interpolants C, S of cos, sin on [-a, a]. C(phi(sigma))
  is a polynomial of degree D*N in sigma, and G = ceil((D*N + 1)/2) nodes integrate it exactly,
  so the sum IS the closed-form polynomial x(q) of the paper (an identity, not a quadrature
  approximation), in the cheapest evaluation structure we measured (docs/expression-growth.md):
  fully expanded, the 6-mode degree-12 pose alone has 18,564 monomials. J and H are the exact
  derivatives of that polynomial: dx/dq_i = sum_g w_g B_i(sigma_g) C'(phi_g), and so on.
* gauss: c, s are cos and sin themselves; G is chosen so that the certified quadrature error on
  the range is below the tolerance. Valid at any angle; certified only on the range.
* local: as gauss, with the few nodes that certify the constant-curvature arc of the range;
  the error is certified at each q instead (``in_range``, flexgen.symbolic.certificate).

Error bounds (units of L; theta is exact):
* poly: |x - x_true| <= sup|C - cos| (the interpolation bound of trig.py), J and H likewise with
  the derivative bounds times int|B_i| <= ||B_i||_2 and int|B_i B_j| <= ||B_i B_j||_2.
* gauss: the rule is exact for T(phi(sigma)) with T any polynomial of degree D' <= (2G-1-deg h)/N,
  h the basis weight (1, B_i or B_i B_j), so the error is at most
  (sum_g w_g |h(sigma_g)| + int |h|) * (Chebyshev truncation error of degree D' on [-a, a]);
  with one mode phi = q0 sigma sweeps only [0, q0], and half the range is enough.
Both add a rounding allowance for double evaluation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import mpmath
import sympy as sp

from flexgen.codegen.spec import MAX_DEGREE, MAX_NODES, KernelSpec, SpecError
from flexgen.symbolic import certificate, trig
from flexgen.symbolic.basis import (
    UNIT_ROUNDOFF,
    angle_basis,
    energy_weights,
    gauss_legendre,
    gauss_rounding,
    sigma,
)

RANGE_SAMPLES = 33  # sigma samples of the in_range check (h = 1/32)


def _l2_norm(poly: sp.Poly) -> float:
    """sqrt(int_0^1 p^2): an upper bound on int_0^1 |p| (Cauchy-Schwarz)."""
    return math.sqrt(float((poly * poly).integrate().eval(1)))


@dataclass(frozen=True)
class ErrorBounds:
    pose: float  # max error of x, y (units of L)
    jacobian: float  # max error of any entry of J (units of L)
    hessian: float  # max error of any entry of H (units of L)


class FlexureKernel:
    """The derived kernel of one KernelSpec: node data, trig polynomials, expressions, bounds."""

    def __init__(self, spec: KernelSpec):
        self.spec = spec
        self.modes = N = spec.modes
        self.a = spec.range_rad
        self.q = sp.symbols(f"q0:{N}", real=True)
        self.basis = [angle_basis(n) for n in range(N)]
        self.degree: int | None  # poly only: the interpolation degree
        self.trig: trig.TrigInterpolant | None  # poly only: the cos/sin interpolant
        if spec.family == "poly":
            if spec.degree is not None:
                self._use_degree(spec.degree)
            else:
                self._degree_for_tolerance(spec.tol)
        elif spec.family == "local":
            self.degree = None
            self.trig = None
            try:
                self.nodes = spec.nodes or certificate.nodes_for_arc(N, self.a, spec.tol)
            except ValueError:
                raise SpecError(
                    f"--tol {spec.tol:g}: no local kernel of up to {MAX_NODES} nodes certifies the arc of "
                    f"{spec.range_deg:g} degrees to it (double rounding allows about 1e-14)"
                ) from None
            if not self.local_rows:
                raise SpecError(
                    f"--nodes: {self.nodes} nodes certify no q to --tol {spec.tol:g} (in_range "
                    "would always be 0); without --nodes, the fewest that certify the arc of "
                    "--range"
                )
        else:
            self.degree = None
            self.trig = None
            self.nodes = spec.nodes or self._nodes_for_tolerance(spec.tol)
            if not math.isfinite(self._gauss_bounds(self.nodes).hessian):
                # the rule is exact for no polynomial of the Hessian's basis weights B_i B_j
                # (degree 2N): no bound (it was emitted as `inf`, which neither C nor Python reads)
                raise SpecError(
                    f"--nodes: {self.nodes} nodes certify no error bound for {N} modes (the "
                    f"Hessian's needs at least {N + 1})"
                )
        self.sigma, self.weights = gauss_legendre(self.nodes)
        self.node_basis = [[_poly_at(b, s) for b in self.basis] for s in self.sigma]

    def _use_degree(self, degree: int) -> None:
        """A poly kernel's interpolant of this degree, and the nodes that integrate it exactly."""
        self.degree = degree
        self.trig = trig.chebyshev_interpolant(self.a, degree)
        self.nodes = max(1, math.ceil((self._poly_degree * self.modes + 1) / 2))

    def _degree_for_tolerance(self, tol: float, max_degree: int = MAX_DEGREE) -> None:
        """The lowest degree whose pose bound, rounding included, is at most tol (from the
        lowest whose cos/sin error is); SpecError where rounding alone exceeds tol."""
        try:
            degree = trig.degree_for_tolerance(self.a, tol, max_degree)
        except ValueError:  # no interpolant of degree <= max_degree meets it
            degree = max_degree
        while True:
            self._use_degree(degree)
            pose, rounding = self._poly_pose_bound()
            if pose <= tol:
                return
            if rounding >= tol or degree >= max_degree:
                raise SpecError(
                    f"--tol {tol:g}: no polynomial kernel of degree up to {max_degree} certifies "
                    f"it on this range (double rounding allows about {rounding:.0e})"
                )
            degree += 1

    def _poly_pose_bound(self) -> tuple[float, float]:
        """A poly kernel's pose bound, and its rounding allowance (part of it)."""
        interp = self.interpolant
        rounding = (interp.degree + self.modes + self.nodes + 4) * UNIT_ROUNDOFF * math.cosh(self.a)
        return interp.bound(0) + rounding, rounding

    # -- names --------------------------------------------------------------------------
    @property
    def name(self) -> str:
        if self.spec.family == "poly":
            return f"scm{self.modes}"
        return f"scm{self.modes}_{self.spec.family}{self.nodes}"

    @property
    def energy_weights(self) -> list[sp.Rational]:
        return energy_weights(self.modes)

    @property
    def interpolant(self) -> trig.TrigInterpolant:
        """The cos/sin interpolant of a poly kernel; ValueError for a gauss kernel (it has none)."""
        if self.trig is None:
            raise ValueError(f"{self.name}: a gauss kernel has no trig interpolant")
        return self.trig

    @property
    def _poly_degree(self) -> int:
        """Highest degree actually present in C or S."""
        deg = 0
        interp = self.interpolant
        for coeffs in (interp.cos, interp.sin):
            for k, c in enumerate(coeffs):
                if c != 0:
                    deg = max(deg, k)
        return deg

    # -- the trig stand-ins and their derivatives as polynomials in one symbol -------------
    def trig_polynomials(self, phi: sp.Symbol) -> dict[str, sp.Expr]:
        """c, c', c'', s, s', s'' at phi: Horner forms (poly) or cos/sin (gauss, local)."""
        if self.spec.family != "poly":
            c, s = sp.cos(phi), sp.sin(phi)
            return {"c": c, "dc": -s, "ddc": -c, "s": s, "ds": c, "dds": -s}
        out = {}
        interp = self.interpolant
        for name, coeffs in (("c", interp.cos), ("s", interp.sin)):
            poly = [sp.Float(c, 40) for c in coeffs]
            d1 = [k * poly[k] for k in range(1, len(poly))]
            d2 = [k * d1[k] for k in range(1, len(d1))]
            out[name] = _parity_horner(poly, phi)
            out["d" + name] = _parity_horner(d1, phi)
            out["dd" + name] = _parity_horner(d2, phi)
        return out

    # -- expressions in q ----------------------------------------------------------------
    @cached_property
    def phi_nodes(self) -> list[sp.Expr]:
        """phi_g = sum_n B_n(sigma_g) q_n."""
        return [
            sp.Add(*[sp.Float(b, 40) * qn for b, qn in zip(row, self.q)]) for row in self.node_basis
        ]

    @cached_property
    def expressions(self) -> dict[str, list]:
        """pose[3], J[3][N], H[3][N][N] as SymPy expressions in q (H symmetric, shared objects)."""
        N, G = self.modes, self.nodes
        phi = sp.Symbol("phi")
        polys = self.trig_polynomials(phi)
        at = [{k: v.xreplace({phi: p}) for k, v in polys.items()} for p in self.phi_nodes]
        w, b = self.weights, self.node_basis
        with mpmath.workdps(40):

            def total(key, factor):
                return sp.Add(*[sp.Float(factor(g), 40) * at[g][key] for g in range(G)])

            pose = [total("c", lambda g: w[g]), total("s", lambda g: w[g]), self.q[0]]
            J = [
                [total("dc", lambda g, i=i: w[g] * b[g][i]) for i in range(N)],
                [total("ds", lambda g, i=i: w[g] * b[g][i]) for i in range(N)],
                [sp.Integer(1 if i == 0 else 0) for i in range(N)],
            ]
            H = [[[None] * N for _ in range(N)] for _ in range(3)]
            for i in range(N):
                for j in range(i, N):
                    hx = total("ddc", lambda g, i=i, j=j: w[g] * b[g][i] * b[g][j])
                    hy = total("dds", lambda g, i=i, j=j: w[g] * b[g][i] * b[g][j])
                    H[0][i][j] = H[0][j][i] = hx
                    H[1][i][j] = H[1][j][i] = hy
                    H[2][i][j] = H[2][j][i] = sp.Integer(0)
        return {"pose": pose, "J": J, "H": H}

    # -- error bounds --------------------------------------------------------------------
    @cached_property
    def bounds(self) -> ErrorBounds:
        N, a = self.modes, self.a
        B = self.basis
        if self.spec.family == "poly":
            interp = self.interpolant
            pose, rounding = self._poly_pose_bound()
            jac = interp.bound(1) * max(_l2_norm(B[i]) for i in range(N)) + rounding * max(1, a)
            hess = interp.bound(2) * max(
                _l2_norm(B[i] * B[j]) for i in range(N) for j in range(N)
            ) + rounding * max(1, a * a)
            return ErrorBounds(pose, jac, hess)
        if self.spec.family == "local":  # where in_range(q) certifies them
            return ErrorBounds(*certificate.tolerances(self.spec.tol))
        return self._gauss_bounds(self.nodes)

    @cached_property
    def local_rows(self) -> tuple[certificate.Row, ...]:
        """A local kernel's in_range rows (flexgen.symbolic.certificate)."""
        return certificate.certificate(self.modes, self.nodes, self.spec.tol)

    def _gauss_bounds(self, G: int) -> ErrorBounds:
        N, a = self.modes, self.a
        sig, w = gauss_legendre(G)
        B = self.basis
        rounding = gauss_rounding(N, G)

        def term(h: sp.Poly, h_degree: int) -> float:
            d = (2 * G - 1 - h_degree) // N
            if d < 0:
                return math.inf
            if N == 1:
                # phi = q0 sigma only sweeps [0, q0]: approximate on that half of the range,
                # cos/sin(a/2 + a/2 t), whose Chebyshev coefficients are bounded by 2|J_k(a/2)|
                eps = sum(trig.error_bound(f, a / 2, d, kind="truncation") for f in trig.FUNCTIONS)
            else:
                eps = max(trig.error_bound(f, a, d, kind="truncation") for f in trig.FUNCTIONS)
            rule = float(sum(wg * abs(_poly_at(h, sg)) for wg, sg in zip(w, sig)))
            return eps * (rule + _l2_norm(h))

        one = sp.Poly(1, sigma)
        pose = term(one, 0) + rounding
        jac = max(term(B[i], i + 1) for i in range(N)) + rounding
        hess = max(term(B[i] * B[j], i + j + 2) for i in range(N) for j in range(i, N)) + rounding
        return ErrorBounds(pose, jac, hess)

    def _nodes_for_tolerance(self, tol: float, max_nodes: int = MAX_NODES) -> int:
        for G in range(1, max_nodes + 1):
            if gauss_rounding(self.modes, G) >= tol:
                break  # the rounding allowance alone exceeds tol: more nodes cannot help
            bounds = self._gauss_bounds(G)
            # the Hessian's bound too must exist (a tiny range met tol with too few nodes for
            # the Hessian's basis, then refused for --nodes the user never gave: review)
            if bounds.pose <= tol and math.isfinite(bounds.hessian):
                return G
        raise SpecError(
            f"--tol {tol:g}: no Gauss rule of up to {max_nodes} nodes certifies it on this range "
            "(double rounding allows about 1e-14)"
        )

    # -- the in_range check --------------------------------------------------------------
    @cached_property
    def range_check(self) -> tuple[list[list[float]], list[float]]:
        """(S, m): |phi| <= a along the flexure if max_k |S q|_k + m . |q| <= a.

        S samples phi at sigma_k = k/32; m_n = h^2/8 * n(n+1) bounds the linear-interpolation
        error between samples, since |phi''| = |kappa'| <= sum_n n(n+1)|q_n|.
        """
        M = RANGE_SAMPLES
        h = 1.0 / (M - 1)
        S = [[float(_poly_at(b, mpmath.mpf(k) / (M - 1))) for b in self.basis] for k in range(M)]
        m = [h * h / 8 * n * (n + 1) for n in range(self.modes)]
        return S, m

    @cached_property
    def range_bound(self) -> list[float]:
        """b_n = max_k |S_kn| + m_n: |q| . b bounds the range check's max_k |S q|_k + m . |q|,
        so |q| . b <= a decides in N multiply-adds where q is clearly in range (both backends'
        in_range ask it first)."""
        S, m = self.range_check
        return [max(abs(row[n]) for row in S) + m[n] for n in range(self.modes)]


def _poly_at(poly: sp.Poly, s) -> mpmath.mpf:
    """Evaluate an exact rational polynomial at an mpf point, in mpmath."""
    with mpmath.workdps(50):
        s = mpmath.mpf(s)
        total = mpmath.mpf(0)
        for c in poly.all_coeffs():
            total = total * s + mpmath.mpf(sp.Rational(c).p) / sp.Rational(c).q
        return total


def _parity_horner(coeffs: list, x: sp.Symbol) -> sp.Expr:
    """Horner form of sum_k coeffs[k] x^k in x^2, keeping the exact parity (zeros dropped)."""
    nonzero = [k for k, c in enumerate(coeffs) if c != 0]
    if not nonzero:
        return sp.Integer(0)
    parity = nonzero[0] % 2
    x2 = x * x
    acc = sp.Integer(0)
    for k in range(max(nonzero) - ((max(nonzero) - parity) % 2), parity - 1, -2):
        acc = acc * x2 + coeffs[k] if acc != 0 else coeffs[k]
    return acc * x if parity else acc
