"""Exact (elastica) reference solver for planar, inextensible Euler-Bernoulli flexures.

Everything here integrates the elastica ODE with ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-13)
and solves the boundary value problem by shooting with Newton's method and load continuation
from the unloaded state, so the result is the equilibrium that a slowly applied load reaches.
It is the reference the kernels are checked against: slow, but right to about 1e-9.

Nondimensional form used internally, per flexure of length L and bending stiffness EI:
sigma = s/L, (X, Y) = (x, y)/L, mu = m L/EI (internal bending moment), f = F L^2/EI:

    X' = cos(phi),  Y' = sin(phi),  phi' = mu,  mu' = fx sin(phi) - fy cos(phi)

where F = (Fx, Fy) is the (constant) force that the part of the mechanism beyond the section
exerts on it, in the world frame, and m(s) = M_tip + (r_tip - r(s)) x F.

Public API
----------
cantilever(EI, L, force=(Fx, Fy), moment=M, num=101) -> CantileverSolution
tip_compliance(EI, L, force, moment, solution=None) -> (3, 3) d(x, y, theta)/d(Fx, Fy, M)
euler_load(EI, L, k=1) -> (2k - 1)^2 pi^2 EI / (4 L^2)
post_buckled(EI, L, tip_angle) -> (P, x_tip, y_tip), closed form (elliptic integrals)
solve_exact(scene, num=65) -> SceneSolution
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk, ellipkm1

RTOL = 1e-13
ATOL = 1e-14
# the largest nondimensional unknown (F L^2/EI, M L/EI) the shooting integrates: the integration
# costs steps in proportion to the turns of the curve, so beyond it a solve could run for hours
MAX_LOAD = 1e3
# the warning of a solution whose load was not fully applied: it is the equilibrium at the last
# converged load factor (``load_factor``), which a Result does not report (exact_result.py)
PARTIAL_LOAD = "load not fully applied: result is at the last converged load factor"
# the residual the scene's shooting cannot resolve below, relative to its size (the load level):
# with rtol 1e-13 its floor was 1e-12 to 5e-12 of it on cantilevers at F L^2/EI = 70 to 200.
# Newton stops where its step is at rounding and the residual below this, which needs no
# smaller residual than the rounding gives (its step, 1e-16 there, says z is converged)
SHOOTING_NOISE = 1e-10
# the load level (F L^2/EI + M L/EI) up to which that holds: measured, transverse tip loads
# converge up to 200 and stall near 290 (0.72 of 400) where fem has a smooth path; past it a
# stall is not reported as a sure limit point
SHOOTING_RESOLVED = 200.0
# the relative error of an answer's compliance times its ``margin`` (``shooting_margin``): the
# shooting Jacobian's error (complex steps: the integration's rounding) and z's, amplified near a
# critical load by 1 / margin. Measured against the closed-form lateral compliance of a column
# under P below its Euler load (tests/test_exact_near_critical.py): error x margin 1.5e-14 to
# 1.7e-14 at P = 0.3 to 0.999999 P_cr for a lone column, 2.3e-14 for the same column in a tree
# (an unloaded second branch, the column's root turned by pi); imperfect columns (a lateral
# force of 1e-6 to 1e-3 of the axial one) moved by at most 6e-14 x margin when polished
# further. About 4x the worst, so that the stated error bounds hold with room
COMPLIANCE_NOISE = 1e-13
# the imaginary step of the complex-step derivatives (``_SceneProblem.jacobian_complex_step``):
# no difference is taken, so no cancellation; any step far below the unknowns' rounding will do
COMPLEX_STEP = 1e-30
# the polishing of the answer's z (``_polished``): at most this many Newton steps, each at most
# POLISH_REACH of z's size (a polishing step is at Newton's tolerance over the margin, far below)
POLISH_STEPS, POLISH_REACH = 3, 1e-6
# the most a load step may turn a flexure's tip (rad): more, and the step is retried shorter
# (the chain solvers' max_dq, the same purpose)
MAX_TURN_STEP = 0.5


# ----------------------------------------------------------------------------------------------
# closed forms
# ----------------------------------------------------------------------------------------------


def euler_load(EI: float, L: float, k: int = 1) -> float:
    """k-th critical axial load of a clamped-free column: (2k - 1)^2 pi^2 EI / (4 L^2)."""
    return (2 * k - 1) ** 2 * math.pi**2 * EI / (4.0 * L**2)


def post_buckled(EI: float, L: float, tip_angle: float):
    """First-mode post-buckled cantilever under an axial dead end load (closed form).

    Returns (P, x_tip, y_tip) for tip angle a in (0, pi): with k = sin(a/2),
    sqrt(P/EI) L = K(k), x_tip = 2 E(k)/sqrt(P/EI) - L, y_tip = 2 k/sqrt(P/EI).
    """
    k = math.sin(0.5 * tip_angle)
    m = k * k
    K = float(ellipk(m))
    lam = K / L
    return EI * lam**2, 2.0 * float(ellipe(m)) / lam - L, 2.0 * k / lam


def _buckled_root_moment_nd(P_nd: float) -> float:
    """Nondimensional root moment of the first-mode post-buckled branch for P L^2/EI = P_nd
    (> pi^2/4), bending towards +y: mu0 = 2 k sqrt(P_nd) with K(k) = sqrt(P_nd)."""
    target = math.sqrt(P_nd)

    # solve K(m) = target in p = 1 - m, on a log scale (p -> 0 for large loads)
    def g(t: float) -> float:
        return float(ellipkm1(math.exp(t))) - target

    t = brentq(g, -700.0, 0.0, xtol=1e-15, rtol=1e-15)
    m = 1.0 - math.exp(t)
    return 2.0 * math.sqrt(m) * target


# ----------------------------------------------------------------------------------------------
# one cantilever
# ----------------------------------------------------------------------------------------------


def _rhs_sens(fx: float, fy: float, nsens: int):
    """RHS of the nondimensional elastica with sensitivities w.r.t. (mu0, fx, fy)[:nsens]."""

    def rhs(t, y):
        c, s = math.cos(y[2]), math.sin(y[2])
        out = np.empty_like(y)
        out[0] = c
        out[1] = s
        out[2] = y[3]
        out[3] = fx * s - fy * c
        p = fx * c + fy * s
        for k in range(nsens):
            b = 4 + 4 * k
            dphi = y[b + 2]
            out[b] = -s * dphi
            out[b + 1] = c * dphi
            out[b + 2] = y[b + 3]
            out[b + 3] = p * dphi + (s if k == 1 else (-c if k == 2 else 0.0))
        return out

    return rhs


def _shoot(mu0: float, fx: float, fy: float, nsens: int = 1, dense: bool = False):
    y0 = np.zeros(4 + 4 * nsens)
    y0[3] = mu0
    y0[4 + 3] = 1.0  # d mu(0) / d mu0
    sol = solve_ivp(
        _rhs_sens(fx, fy, nsens),
        (0.0, 1.0),
        y0,
        method="DOP853",
        rtol=RTOL,
        atol=ATOL,
        dense_output=dense,
    )
    if not sol.success:
        raise RuntimeError(f"elastica integration failed: {sol.message}")
    return sol


def _stability(sol) -> tuple[bool, float]:
    """Jacobi test of the second variation for a clamped-free elastica with dead tip load.

    With u the Jacobi field (u(0) = 0, u'(0) = 1, i.e. d phi / d mu0), the equilibrium is stable
    iff u > 0 on (0, 1] (no conjugate point) and u'(1) = d mu(1)/d mu0 > 0 (the shooting
    derivative). Returns (stable, u'(1)).
    """
    u = sol.y[6, 1:]
    du1 = float(sol.y[7, -1])
    return bool(np.all(u > 0.0) and du1 > 0.0), du1


def _newton_mu0(
    mu0: float, fx: float, fy: float, mM: float, tol: float = 1e-13, max_iter: int = 30
):
    """Newton on the root moment; returns (mu0, sol, iterations) or raises RuntimeError."""
    for it in range(1, max_iter + 1):
        sol = _shoot(mu0, fx, fy)
        R = sol.y[3, -1] - mM
        dR = sol.y[7, -1]
        if dR == 0.0:
            raise RuntimeError("singular shooting derivative")
        step = -R / dR
        # keep a Newton step from jumping across the branch
        lim = 0.5 + abs(mu0)
        if abs(step) > lim:
            step = math.copysign(lim, step)
        mu0 += step
        # R's rounding is relative to the loads (the scene solver's residual_scale)
        if abs(step) < tol * (1.0 + abs(mu0)) and abs(R) < 1e3 * tol * (
            1.0 + abs(fx) + abs(fy) + abs(mM)
        ):
            return mu0, _shoot(mu0, fx, fy), it
    raise RuntimeError("Newton on the root moment did not converge")


@dataclass
class CantileverSolution:
    pose: np.ndarray  # (3,) tip x, y, theta
    shape: np.ndarray  # (num, 2) centreline, root first
    s: np.ndarray  # (num,) arc length of the shape points
    phi: np.ndarray  # (num,) tangent angle
    moment: np.ndarray  # (num,) internal bending moment EI phi'
    root_moment: float  # EI phi'(0)
    force: np.ndarray  # (2,) applied tip force
    tip_moment: float
    stable: bool  # Jacobi test of the second variation
    converged: bool
    iterations: int  # Newton iterations over the whole continuation
    branch: str  # "primary" or "post-buckled"
    critical_load_factor: float | None = None  # load factor where the path lost stability
    critical_load: float | None = None  # |force| at that factor (axial: Euler load)
    warnings: list = field(default_factory=list)


def _is_symmetric_axial(fx: float, fy: float, mM: float) -> bool:
    return fx < 0.0 and fy == 0.0 and mM == 0.0


def _continue(fx: float, fy: float, mM: float, max_step: float = 0.25):
    """Load continuation lam: 0 -> 1 for the nondimensional cantilever.

    Returns dict(mu0, iterations, branch, lam_c, warnings)."""
    lam, mu0 = 0.0, 0.0
    hist = [(0.0, 0.0)]
    dlam = min(0.1, max_step)
    iters = 0
    branch = "primary"
    lam_c = None
    warnings = []
    stable_prev = True
    symmetric = _is_symmetric_axial(fx, fy, mM)
    while lam < 1.0:
        lam_new = min(1.0, lam + dlam)
        if branch.startswith("post-buckled"):
            # the first-mode post-buckled branch is known in closed form: use it as predictor
            guess = _buckled_root_moment_nd(-fx * lam_new)
        elif len(hist) >= 2:
            (l0, m0), (l1, m1) = hist[-2], hist[-1]
            guess = m1 + (m1 - m0) * (lam_new - l1) / (l1 - l0)
        else:
            guess = mu0
        try:
            mu_new, sol, it = _newton_mu0(guess, lam_new * fx, lam_new * fy, lam_new * mM)
            iters += it
            # step control: the corrector must stay close to the predictor (no branch jumping)
            ok = abs(mu_new - guess) < 0.1 * (1.0 + abs(mu_new))
        except RuntimeError:
            ok = False
        if ok:
            stable, _ = _stability(sol)
            if (
                stable_prev
                and not stable
                and not (symmetric and abs(mu_new) < 1e-9)
                and dlam > 1e-6
            ):
                ok = False  # confirm a loss of stability with small steps (no jump)
        if not ok:
            dlam *= 0.5
            if dlam < 1e-9:
                warnings.append(
                    f"continuation stalled at load factor {lam:.9g} "
                    "(limit point: the load would snap through)"
                )
                if lam_c is None:
                    lam_c = lam
                break
            continue
        if stable_prev and not stable:
            # locate the loss of stability on the path between lam and lam_new
            def indicator(l):
                # called at once by brentq below: the loop variables are the current ones
                m_, s_, _ = _newton_mu0(
                    mu0 + (mu_new - mu0) * (l - lam) / (lam_new - lam),  # noqa: B023
                    l * fx,
                    l * fy,
                    l * mM,
                )
                return s_.y[7, -1]

            try:
                lam_c = brentq(indicator, lam, lam_new, xtol=1e-15, rtol=1e-15)
            except (ValueError, RuntimeError):
                lam_c = lam_new
            if symmetric and abs(mu_new) < 1e-9:
                # straight column past the Euler load: switch to the stable buckled branch (+y)
                branch = "post-buckled"
                lam = lam_c
                mu0 = 0.0
                hist = []
                continue
            warnings.append(f"equilibrium path lost stability at load factor {lam_c:.9g}")
        stable_prev = stable
        lam, mu0 = lam_new, mu_new
        hist.append((lam, mu0))
        dlam = min(max_step, dlam * (1.5 if it <= 4 else 1.0))
    return dict(mu0=mu0, iterations=iters, branch=branch, lam_c=lam_c, warnings=warnings, lam=lam)


def cantilever(
    EI: float,
    L: float,
    force=(0.0, 0.0),
    moment: float = 0.0,
    num: int = 101,
    max_step: float = 0.25,
) -> CantileverSolution:
    """Exact equilibrium of a cantilever clamped at the origin along +x under a dead tip load.

    force = (Fx, Fy) and moment M act at the tip and keep their world direction. The load is
    applied by continuation from the unloaded state (adaptive load steps, secant predictor,
    Newton on the root moment with the variational equations), so the result is the branch a
    slowly applied load reaches. A purely compressive axial load past the first Euler load makes
    the straight column unstable: the bifurcation is located (``critical_load_factor``,
    ``critical_load`` = pi^2 EI/(4 L^2)) and the stable post-buckled branch that bends towards +y
    is followed. ``stable`` is the Jacobi (conjugate point) test of the second variation.
    """
    EI, L = float(EI), float(L)
    fx, fy = float(force[0]) * L**2 / EI, float(force[1]) * L**2 / EI
    mM = float(moment) * L / EI
    res = _continue(fx, fy, mM, max_step=max_step)
    warnings = list(res["warnings"])
    converged = res["lam"] >= 1.0
    sol = _shoot(res["mu0"], res["lam"] * fx, res["lam"] * fy, dense=True)
    stable, _ = _stability(sol)
    sig = np.linspace(0.0, 1.0, num)
    Y = sol.sol(sig)
    Y[:, 0] = sol.y[:, 0]
    Y[:, -1] = sol.y[:, -1]
    lam_c = res["lam_c"]
    crit = None if lam_c is None else lam_c * math.hypot(force[0], force[1])
    if not converged:
        warnings.append(PARTIAL_LOAD)
    branch = "post-buckled" if res["branch"].startswith("post") else "primary"
    return CantileverSolution(
        pose=np.array([L * sol.y[0, -1], L * sol.y[1, -1], sol.y[2, -1]]),
        shape=L * Y[0:2].T.copy(),
        s=L * sig,
        phi=Y[2].copy(),
        moment=EI / L * Y[3],
        root_moment=EI / L * res["mu0"],
        force=np.array(force, dtype=float),
        tip_moment=float(moment),
        stable=stable,
        converged=converged,
        iterations=res["iterations"],
        branch=branch,
        critical_load_factor=lam_c,
        critical_load=crit,
        warnings=warnings,
    )


def tip_compliance(
    EI: float,
    L: float,
    force=(0.0, 0.0),
    moment: float = 0.0,
    solution: CantileverSolution | None = None,
) -> np.ndarray:
    """3x3 compliance d(x, y, theta)_tip / d(Fx, Fy, M) at the loaded equilibrium.

    Exact (variational equations, no finite differences): with R = mu(1) - M = 0,
    d mu0 = -(dR/dF dF - dM) / (dR/d mu0), and the tip sensitivities follow by the chain rule.
    The equilibrium is found with ``cantilever`` unless ``solution`` is given.
    """
    EI, L = float(EI), float(L)
    if solution is None:
        solution = cantilever(EI, L, force, moment, num=3)
    fx, fy = force[0] * L**2 / EI, force[1] * L**2 / EI
    mu0 = solution.root_moment * L / EI
    sol = _shoot(mu0, fx, fy, nsens=3)
    y = sol.y[:, -1]
    T = [y[4 + 4 * k : 4 + 4 * k + 3] for k in range(3)]  # d(X, Y, phi)(1) / d(mu0, fx, fy)
    dR = [y[4 + 4 * k + 3] for k in range(3)]  # d mu(1) / d(mu0, fx, fy)
    C = np.empty((3, 3))
    C[:, 0] = T[1] - T[0] * dR[1] / dR[0]
    C[:, 1] = T[2] - T[0] * dR[2] / dR[0]
    C[:, 2] = T[0] / dR[0]
    scale = np.array([[L**3, L**3, L**2], [L**3, L**3, L**2], [L**2, L**2, L]]) / EI
    return C * scale


# ----------------------------------------------------------------------------------------------
# whole scenes
# ----------------------------------------------------------------------------------------------


def _compose(A, B):
    """Frames (..., 3): A then B (B expressed in A)."""
    c, s = np.cos(A[..., 2]), np.sin(A[..., 2])
    return np.stack(
        [
            A[..., 0] + c * B[..., 0] - s * B[..., 1],
            A[..., 1] + s * B[..., 0] + c * B[..., 1],
            A[..., 2] + B[..., 2],
        ],
        axis=-1,
    )


@dataclass
class SceneSolution:
    converged: bool
    stable: bool
    iterations: int
    poses: dict  # point name -> (3,) world x, y, body angle   (output points)
    compliance: dict  # point name -> (2, 2) d position / d force at that point
    shapes: dict  # flexure name -> (num, 2) world centreline, root first
    tip_frames: dict  # flexure name -> (3,) world tip frame
    root_loads: dict  # flexure name -> (Fx, Fy, M0): force through it, root moment
    load_factor: float  # 1.0 when the whole load was applied
    critical_load_factor: float | None = None
    warnings: list = field(default_factory=list)
    # how far the answer is from a critical load: the smallest |eigenvalue| of J0^-1 J (J the
    # shooting Jacobian at the answer, J0 unloaded): 1 unloaded, about 0.8 (1 - P/P_cr) on a
    # column below its Euler load, 0 at a critical load (``shooting_margin``)
    margin: float = 1.0
    # facts about the answer that do not make it wrong (the Result's notes)
    notes: list = field(default_factory=list)


class ElasticaProfile:
    """The curvature along one flexure of an exact answer, from its own elastica: the ODE
    above integrated from the flexure's root with its solved unknowns, so the curvature is
    the state mu / L itself (no model in between). ``q`` is the flexure's root loads
    ``[Fx, Fy, M0]`` (``SceneSolution.root_loads``, the Result's ``q``); ``root_angle`` the
    world angle of its root frame (the ODE's phi is a world angle)."""

    def __init__(self, length: float, EI: float, root_angle: float):
        self.length, self.EI, self.root_angle = float(length), float(EI), float(root_angle)

    def _states(self, q, sigma: np.ndarray) -> np.ndarray:
        """(phi, mu) at the nondimensional arc lengths ``sigma`` (sorted, in [0, 1])."""
        L, EI = self.length, self.EI
        fx, fy = float(q[0]) * L**2 / EI, float(q[1]) * L**2 / EI

        def rhs(t, y):
            return [y[1], fx * math.sin(y[0]) - fy * math.cos(y[0])]

        y0 = [self.root_angle, float(q[2]) * L / EI]
        sol = solve_ivp(rhs, (0.0, 1.0), y0, method="DOP853", rtol=RTOL, atol=ATOL, t_eval=sigma)
        if not sol.success:
            raise RuntimeError(f"elastica integration failed: {sol.message}")
        return sol.y

    def curvature(self, q, s) -> np.ndarray:
        """kappa(s) = mu(s/L) / L, 1/length, at the arc lengths ``s``."""
        s = np.asarray(s, dtype=float)
        order = np.argsort(s)
        kappa = np.empty_like(s)
        kappa[order] = self._states(q, np.clip(s[order] / self.length, 0.0, 1.0))[1]
        return kappa / self.length

    def tangent_angle(self, q, s) -> np.ndarray:
        """phi(s) - the root angle: the tangent's angle to the root frame at arc lengths ``s``."""
        s = np.asarray(s, dtype=float)
        order = np.argsort(s)
        phi = np.empty_like(s)
        phi[order] = self._states(q, np.clip(s[order] / self.length, 0.0, 1.0))[0]
        return phi - self.root_angle

    def curvature_extremes(self, q, num: int = 257) -> np.ndarray:
        """Both ends and where mu' = fx sin(phi) - fy cos(phi) changes sign between samples of
        a fine grid (located by linear interpolation): the peaks of |kappa| inside."""
        L, EI = self.length, self.EI
        sigma = np.linspace(0.0, 1.0, num)
        phi = self._states(q, sigma)[0]
        fx, fy = float(q[0]) * L**2 / EI, float(q[1]) * L**2 / EI
        d = fx * np.sin(phi) - fy * np.cos(phi)
        k = np.flatnonzero(d[:-1] * d[1:] < 0.0)
        roots = sigma[k] + (sigma[k + 1] - sigma[k]) * d[k] / (d[k] - d[k + 1])
        return np.concatenate([[0.0, L], roots * L])


def _integrate(rhs, y0: np.ndarray, dense: bool):
    """solve_ivp of the elastica from y0 over sigma in [0, 1] (DOP853, RTOL, ATOL). A complex
    y0 (a complex step, ``_SceneProblem.jacobian_complex_step``) is integrated as the real
    system of its real part and its imaginary part over COMPLEX_STEP (the forward
    sensitivities, their derivative the imaginary part of rhs over the step): the step-size
    control then holds the sensitivities to RTOL too. Integrated as complex numbers it read
    only the real part, 1e-30 beside it, and took the steps of the unloaded column's trivial
    path for its oscillating sensitivities (compliance 7.5e-9 / margin off). ``_joined`` makes
    the solution complex again."""
    if y0.dtype.kind != "c":
        return solve_ivp(
            rhs, (0.0, 1.0), y0, method="DOP853", rtol=RTOL, atol=ATOL, dense_output=dense
        )
    n = y0.size

    def rhs_split(t, w):
        f = rhs(t, w[:n] + 1j * COMPLEX_STEP * w[n:])
        return np.concatenate([f.real, f.imag / COMPLEX_STEP])

    w0 = np.concatenate([y0.real, y0.imag / COMPLEX_STEP])
    return solve_ivp(
        rhs_split, (0.0, 1.0), w0, method="DOP853", rtol=RTOL, atol=ATOL, dense_output=dense
    )


def _joined(w: np.ndarray, n: int) -> np.ndarray:
    """A state of ``_integrate``'s solution as the elastica's (complex where it was split)."""
    return w if w.size == n else w[:n] + 1j * COMPLEX_STEP * w[n:]


class _SceneProblem:
    """Shooting formulation of a scene: unknowns per flexure (fx, fy, mu0), nondimensional."""

    def __init__(self, scene):
        self.scene = scene
        self.flex = {f.name: f for f in scene.flexures}
        self.links = {l.name: l for l in scene.links}
        for l in scene.links:
            if l.parent not in self.flex:
                raise ValueError(f"link {l.name!r}: parent {l.parent!r} is not a flexure")
        # topological order of the flexures (parents first), without recursion
        order = []
        seen = set()
        for f in scene.flexures:
            trail = []
            name = f.name
            while name != "base" and name not in seen:
                if name in trail:
                    raise ValueError(f"flexure {name!r}: parent chain is a cycle")
                trail.append(name)
                name = self.owner(self.flex[name].parent)
            for n in reversed(trail):
                seen.add(n)
                order.append(n)
        self.order = order
        self.index = {n: i for i, n in enumerate(order)}
        self.n = len(order)
        self.L = np.array([self.flex[n].length for n in order])
        self.EI = np.array([self.flex[n].EI for n in order])
        # the residuals' size (nondimensional forces and moments: up to the load level), which
        # the shooting's rounding (its integration's rtol) is relative to: Newton's tolerances
        # are times this (absolute ones stalled a cantilever at F L^2/EI = 61 to 1000 on a
        # residual floor of 1e-12 to 1e-9, reported as a limit point; found by review)
        self.residual_scale = 1.0 + max(scene.load_levels().values(), default=0.0)
        # chain[o] = set of flexures whose subtree contains body owner o
        self.chain = {"base": ()}
        for n in order:
            own = self.owner(self.flex[n].parent)
            self.chain[n] = (n,) + self.chain[own]
        # loads and tendons
        self.point_names = []
        self.loads = []
        for ld in scene.loads:
            self.loads.append((self._pid(ld.point), np.array(ld.force, float), float(ld.moment)))
        self.tendons = []
        for td in scene.tendons:
            if len(td.route) < 2:
                raise ValueError("tendon route needs at least two points")
            self.tendons.append((float(td.tension), [self._pid(p) for p in td.route]))
        # the chain models' points: [output], else the loaded points, else the free tips
        outs = list(scene.output_points())
        self.outputs = outs
        self.out_ids = [self._pid(p) for p in outs]
        self.P_owner = [self.resolve(p)[0] for p in self.point_names]
        self.P_local = np.array([self.resolve(p)[1] for p in self.point_names]).reshape(-1, 2)
        # member[i, p] = point p lies in the subtree beyond flexure i
        self.member = np.zeros((self.n, len(self.point_names)))
        for p, o in enumerate(self.P_owner):
            for f in self.chain[o]:
                self.member[self.index[f], p] = 1.0
        self.extra = np.zeros((len(self.point_names), 2))  # extra dead force per point

    def owner(self, body: str) -> str:
        if body == "base":
            return "base"
        if body in self.flex:
            return body
        if body in self.links:
            return self.links[body].parent
        raise ValueError(f"unknown body {body!r}")

    def resolve(self, ref: str):
        if "." not in ref:
            raise ValueError(f"point {ref!r}: expected '<body>.<point>'")
        body, pt = ref.rsplit(".", 1)
        if body == "base":
            if pt not in self.scene.base_points:
                raise ValueError(f"point {ref!r}: no such base point")
            return "base", tuple(map(float, self.scene.base_points[pt]))
        if body in self.flex and pt == "tip":
            return body, (0.0, 0.0)
        if body in self.links:
            pts = self.links[body].points
            if pt not in pts:
                raise ValueError(f"point {ref!r}: no such point on link {body!r}")
            return self.links[body].parent, tuple(map(float, pts[pt]))
        raise ValueError(f"point {ref!r}: unknown body or point")

    def _pid(self, ref: str) -> int:
        if ref not in self.point_names:
            self.resolve(ref)
            self.point_names.append(ref)
        return self.point_names.index(ref)

    # -- evaluation -------------------------------------------------------------------------
    def evaluate(self, Z, lam, shapes_num: int = 0):
        """Z: (K, 3n) unknowns. Returns residual (K, 3n), point world xy (K, P, 2),
        tip frames (K, n, 3) and (for row 0) shapes if shapes_num."""
        Z = np.atleast_2d(Z)
        if not np.max(np.abs(Z)) <= MAX_LOAD:  # also NaN: the continuation takes a smaller step
            raise RuntimeError(f"nondimensional load beyond {MAX_LOAD:g} (or not finite)")
        K = Z.shape[0]
        n = self.n
        dtype = Z.dtype  # complex in jacobian_complex_step: every operation below is analytic
        tips = np.zeros((K, n, 3), dtype)
        mu_tip = np.zeros((K, n), dtype)
        shapes = {}
        frames = {"base": np.zeros((K, 3), dtype)}
        for i, name in enumerate(self.order):
            fl = self.flex[name]
            root = _compose(frames[self.owner(fl.parent)], np.asarray(fl.at, float)[None, :])
            fx, fy, mu0 = Z[:, 3 * i], Z[:, 3 * i + 1], Z[:, 3 * i + 2]

            def rhs(t, y, fx=fx, fy=fy):
                y = y.reshape(4, K)
                c, s = np.cos(y[2]), np.sin(y[2])
                return np.concatenate([c, s, y[3], fx * s - fy * c])

            y0 = np.concatenate([np.zeros(K, dtype), np.zeros(K, dtype), root[:, 2], mu0])
            sol = _integrate(rhs, y0, bool(shapes_num))
            if not sol.success:
                raise RuntimeError(f"elastica integration failed on {name!r}: {sol.message}")
            yend = _joined(sol.y[:, -1], y0.size).reshape(4, K)
            Li = self.L[i]
            tips[:, i, 0] = root[:, 0] + Li * yend[0]
            tips[:, i, 1] = root[:, 1] + Li * yend[1]
            tips[:, i, 2] = yend[2]
            mu_tip[:, i] = yend[3]
            frames[name] = tips[:, i]
            if shapes_num:
                sig = np.linspace(0.0, 1.0, shapes_num)
                Yd = sol.sol(sig).reshape(4, K, shapes_num)[:, 0]
                Yd[:, 0] = y0.reshape(4, K)[:, 0]
                Yd[:, -1] = yend[:, 0]
                shapes[name] = np.stack([root[0, 0] + Li * Yd[0], root[0, 1] + Li * Yd[1]], axis=1)
        # points
        P = len(self.point_names)
        fr = np.stack([frames[o] for o in self.P_owner], axis=1) if P else np.zeros((K, 0, 3))
        c, s = np.cos(fr[..., 2]), np.sin(fr[..., 2])
        lx, ly = self.P_local[:, 0], self.P_local[:, 1]
        pts = np.stack([fr[..., 0] + c * lx - s * ly, fr[..., 1] + s * lx + c * ly], axis=-1)
        # forces (K, P, 2) and moments (K, P) at points
        F = np.zeros((K, P, 2), dtype)
        Mp = np.zeros((K, P), dtype)
        for pid, f, m in self.loads:
            F[:, pid] += lam * f
            Mp[:, pid] += lam * m
        F += self.extra[None]
        for T, ids in self.tendons:
            for a, b in zip(ids[:-1], ids[1:]):
                d = pts[:, b] - pts[:, a]
                if dtype.kind == "c":  # |d| continued analytically (norm takes moduli)
                    nrm = np.sqrt(d[..., 0:1] ** 2 + d[..., 1:2] ** 2)
                else:
                    nrm = np.linalg.norm(d, axis=-1, keepdims=True)
                u = d / np.where(nrm.real > 0.0, nrm, 1.0)
                F[:, a] += lam * T * u
                F[:, b] -= lam * T * u
        # required force through each flexure and moment at its tip
        N = np.einsum("ip,kpc->kic", self.member, F)  # (K, n, 2)
        arm = pts[:, None, :, :] - tips[:, :, None, :2]  # (K, n, P, 2)
        cross = arm[..., 0] * F[:, None, :, 1] - arm[..., 1] * F[:, None, :, 0]
        Mreq = np.einsum("ip,kip->ki", self.member, cross + Mp[:, None, :])
        R = np.empty((K, 3 * n), dtype)
        R[:, 0::3] = Z[:, 0::3] - N[..., 0] * self.L**2 / self.EI
        R[:, 1::3] = Z[:, 1::3] - N[..., 1] * self.L**2 / self.EI
        R[:, 2::3] = mu_tip - Mreq * self.L / self.EI
        return R, pts, tips, shapes, frames

    def output_rise(self, dpts):
        """d(mean world y of the output points)/dz, from ``jacobian``'s d(point xy)/dz."""
        idx = self.out_ids or list(range(dpts.shape[1]))
        return dpts[:, idx, 1].mean(axis=1)

    def jacobian(self, z, lam, h=1e-6):
        m = z.size
        Z = np.repeat(z[None, :], 1 + 2 * m, axis=0)
        for j in range(m):
            Z[1 + 2 * j, j] += h
            Z[2 + 2 * j, j] -= h
        R, pts, tips, _, frames = self.evaluate(Z, lam)
        J = (R[1::2] - R[2::2]).T / (2 * h)  # (m, m)
        dpts = (pts[1::2] - pts[2::2]) / (2 * h)  # (m, P, 2)
        return R[0], J, dpts, pts[0], tips[0]

    def jacobian_complex_step(self, z, lam):
        """``jacobian``'s tuple with J and the points' Jacobian by complex steps: each unknown
        moved by i h, the derivative the imaginary part over h, with no difference taken (no
        cancellation: h as small as wanted). The elastica is integrated with its forward
        sensitivities under the step control (``_integrate``), so this is the derivative of the
        shooting map to the integration's rtol (review: central differences left compliances
        3e-8 to 5e-8 off unflagged)."""
        m, h = z.size, COMPLEX_STEP
        Z = np.repeat(np.asarray(z, complex)[None, :], 1 + m, axis=0)
        for j in range(m):
            Z[1 + j, j] += 1j * h
        R, pts, tips, _, _ = self.evaluate(Z, lam)
        J = R[1:].imag.T / h
        dpts = pts[1:].imag / h
        return R[0].real, J, dpts, pts[0].real, tips[0].real

    def newton(self, z, lam, tol=1e-12, max_iter=25):
        """Newton on the shooting residual at load factor lam from z: converged when its step is
        below 1e-12 (relative) and the residual below tol, or below the rounding the shooting
        leaves in it (SHOOTING_NOISE x residual_scale), whichever is larger."""
        it = 0
        scale = self.residual_scale
        noise = SHOOTING_NOISE * scale
        for it in range(1, max_iter + 1):
            R, J, _, _, _ = self.jacobian(z, lam)
            try:
                dz = np.linalg.solve(J, -R)
            except np.linalg.LinAlgError:
                raise RuntimeError("singular shooting Jacobian") from None
            r0 = np.max(np.abs(R))
            t = 1.0
            while True:
                Rn = self.evaluate(z + t * dz, lam)[0][0]
                if np.max(np.abs(Rn)) < max(r0, noise):
                    break
                t *= 0.5
                if t < 0.06:  # no descent: let the continuation take a smaller load step
                    raise RuntimeError("shooting Newton: no descent")
            z = z + t * dz
            if np.max(np.abs(t * dz)) < 1e-12 * (1 + np.max(np.abs(z))) and np.max(
                np.abs(Rn)
            ) < max(tol * scale, noise):
                return z, it
            if np.max(np.abs(Rn)) < 1e-14 * scale:
                return z, it
        raise RuntimeError("shooting Newton did not converge")


def _load_derivative(prob, z, lam, R):
    """dR/dlam at (z, lam) (R: the residual there), exact since R is linear in lam:
    R(z, lam + 1) - R(z, lam); None where the shooting refuses."""
    try:
        return prob.evaluate(z, lam + 1.0)[0][0] - R
    except RuntimeError:
        return None


def _along_tangent(J, dR, dz) -> bool:
    """Whether a step dz from a stable state (shooting Jacobian J, dR/dlam there) goes along the
    equilibrium path, not against its tangent dz/dlam = -J^-1 dR/dlam: near the critical load of
    an imperfect structure the tangent points along the branch the imperfection chose, and a
    load step can land Newton on the mirror branch; a step against the tangent is such a jump,
    retried shorter (as the chain solver does: docs/solver-core.md, load continuation). True
    where the tangent is undefined."""
    if dR is None:
        return True
    try:
        tangent = np.linalg.solve(J, -dR)
    except np.linalg.LinAlgError:
        return True
    return bool(np.dot(dz, tangent) >= 0.0)


# the next accepted steps on which a branch switch that failed at a crossing is tried again
LOST_RETRIES = 4


def _switch_branch(prob, z_new, lam_new, J, dpts, side, ref_sign):
    """The stable branch near the state z_new at lam_new, whose shooting Jacobian J is of the
    wrong sign (past a bifurcation): Newton from pushes of growing size along J's null vector
    (oriented by the chain models' side rules: the side whose output points lie higher, else
    counter-clockwise; ``side``, an imperfect structure's, first), the first converged state
    that is stable and on that side: (z, R, J, tips, Newton iterations) or None."""
    _, _, Vt = np.linalg.svd(J)
    v = Vt[-1]
    mus = v[2::3]
    k = np.flatnonzero(np.abs(mus) > 1e-3 * np.max(np.abs(v)))
    if k.size and mus[k[0]] < 0:
        v = -v
    # a symmetric structure: the chain models' convention (docs/solver-core.md, the side
    # rules): the side whose output points lie higher, where the two differ in it (to first
    # order along v); else counter-clockwise, as above (found by review: a column along -x
    # bent to -y here and to +y in every chain model, off by 2.8 rad against estimates of 3e-4)
    rise = prob.output_rise(dpts)
    if abs(float(np.dot(rise, v))) > 1e-6 * float(np.linalg.norm(rise)) + 1e-12:
        v = v if float(np.dot(rise, v)) > 0.0 else -v
    # an imperfect structure: the side its imperfection chose
    if side is not None and float(np.dot(v, side)) < 0.0:
        v = -v
    iters = 0
    for eps in (0.05, 0.2, 0.5, 1.0, 2.0):
        try:
            zb, itb = prob.newton(z_new + eps * v, lam_new)
        except RuntimeError:
            continue
        iters += itb
        Rb, Jb, _, _, tips_b = prob.jacobian(zb, lam_new)
        # stable, and on v's side: past the critical load of an imperfect structure z_new may
        # lie between the two stable branches, and a short push along v can still fall back to
        # the far one
        if (
            np.sign(np.linalg.det(Jb)) == ref_sign
            and np.max(np.abs(zb - z_new)) > 1e-6
            and float(np.dot(zb - z_new, v)) > 0.0
        ):
            return zb, Rb, Jb, tips_b, iters
    return None


def _imperfection_side(J, dR):
    """The soft mode's part of the path's tangent at a stable state (shooting Jacobian J,
    dR/dlam there), as a vector: the side the load pushes the structure to as it nears a
    critical load. The tangent is -J^-1 dR/dlam; along J's softest singular pair (u, s, v) its
    part is -(u . dR/dlam) / s v. None when the load does no work along the soft mode
    (u . dR/dlam within 1e-9 of |dR/dlam|: a symmetric structure, or an imperfection too small
    to choose a side)."""
    if dR is None:
        return None
    try:
        U, S, Vt = np.linalg.svd(J)
    except np.linalg.LinAlgError:
        return None
    work = float(np.dot(U[:, -1], dR))
    if not abs(work) > 1e-9 * float(np.linalg.norm(dR)) or not S[-1] > 0.0:
        return None
    return -work / S[-1] * Vt[-1]


# a tendon segment shorter than this fraction of the longest flexure has (nearly) zero length:
# its direction, the force's, is undefined there and the continuation cannot pass it (the chain
# solvers' core: FG_SHORT_TENDON, chain_solver.c; a test holds the two equal)
SHORT_TENDON = 1e-3


def _short_tendon(prob, z, lam) -> tuple[str, str] | None:
    """The first tendon segment (its two points' names) pulled to nearly zero length at
    (z, lam): under tension, between two bodies, shorter than SHORT_TENDON of the longest
    flexure there and not in the unloaded state (review: a segment short from the start, which
    the load did not pull shut, was blamed for a limit point)."""
    if not prob.tendons:
        return None
    _, pts, *_ = prob.evaluate(z[None, :], lam)
    _, rest, *_ = prob.evaluate(np.zeros((1, z.size)), 0.0)
    short = SHORT_TENDON * float(np.max(prob.L))
    for tension, ids in prob.tendons:
        for a, b in zip(ids[:-1], ids[1:]):
            if tension == 0.0 or prob.P_owner[a] == prob.P_owner[b]:
                continue
            if (
                float(np.linalg.norm(pts[0, b] - pts[0, a])) < short
                and float(np.linalg.norm(rest[0, b] - rest[0, a])) >= short
            ):
                return prob.point_names[a], prob.point_names[b]
    return None


# a tendon segment this short (of the longest flexure) in the unloaded state is of zero length
# (the shooting puts a straight flexure's tip off by a few 1e-16 of its length)
ZERO_SEGMENT = 1e-12


def _zero_segment(prob) -> tuple[str, str] | None:
    """The first tendon segment (its two points' names) under tension, between two bodies,
    of zero length in the unloaded state: it has no direction, so the chain models refuse the
    scene (the core's fail_route, "no equilibrium of the unloaded scene"), and so does this
    solver (review: it pulled along the rounding of the tip's position, exit 0). Zero up to
    the shooting's rounding of the straight flexures (ZERO_SEGMENT of the longest; the chain
    models' unloaded poses are exact)."""
    if not prob.tendons:
        return None
    _, rest, *_ = prob.evaluate(np.zeros((1, 3 * prob.n)), 0.0)
    zero = ZERO_SEGMENT * float(np.max(prob.L))
    for tension, ids in prob.tendons:
        for a, b in zip(ids[:-1], ids[1:]):
            if tension == 0.0 or prob.P_owner[a] == prob.P_owner[b]:
                continue
            if float(np.hypot(*(rest[0, b] - rest[0, a]))) <= zero:
                return prob.point_names[a], prob.point_names[b]
    return None


def solve_exact(scene, num: int = 65, max_step: float = 0.25) -> SceneSolution:
    """See ``_solve_exact``. Floating-point overflow on the way (a hostile scene's huge or tiny
    numbers) is expected and shows in the answer (not converged, or non-finite compliance, which
    the JSON writes as null), so NumPy does not warn about it."""
    with np.errstate(all="ignore"):
        return _solve_exact(scene, num, max_step)


# The final shooting Jacobian, whose compliances the answer reports: by complex steps
# (``_SceneProblem.jacobian_complex_step``), the derivative of the integrated shooting map with
# no difference taken. Central differences at 1e-6 left compliances 3e-8 to 5e-8 off with no
# note (review: two roll-ups under a tip moment, a tip force of 100 EI/L^2; their 2x2 block
# asymmetric by 1.6e-7), and 12 % off on a three-flexure chain under large loads, where the
# shooting map bends sharply (step truncation); the complex step has no step error.
# the relative compliance error an exact answer may carry unflagged: beyond it, as near a
# critical load (exact_result.near_critical), a warning. The exact solver is the reference the
# chain models' estimates are measured against, so it is held to far below their errors
COMPLIANCE_RESOLVED = 1e-6


def _compliances(prob, J, dpts, pts, tips) -> dict:
    """{output point: (2, 2) d(position)/d(force at it)} by the implicit function theorem on
    the converged shooting system: dz = -J^-1 dR/dF, dR/dF analytic (force rows -L^2/EI,
    moment rows -(L/EI) (r_p - r_tip) x e), then the points' Jacobian dpts (J and dpts from
    ``jacobian_complex_step``)."""
    m = J.shape[0]
    compl = {}
    for name, pid in zip(prob.outputs, prob.out_ids):
        if prob.P_owner[pid] == "base":
            compl[name] = np.zeros((2, 2))
            continue
        B = np.zeros((m, 2))
        for i in range(prob.n):
            if prob.member[i, pid]:
                a = pts[pid] - tips[i, :2]
                B[3 * i, 0] = -(prob.L[i] ** 2) / prob.EI[i]
                B[3 * i + 1, 1] = -(prob.L[i] ** 2) / prob.EI[i]
                B[3 * i + 2, 0] = -prob.L[i] / prob.EI[i] * (-a[1])
                B[3 * i + 2, 1] = -prob.L[i] / prob.EI[i] * a[0]
        try:
            dz = -np.linalg.solve(J, B)  # (m, 2)
        except np.linalg.LinAlgError:
            dz = np.full((m, 2), np.nan)
        compl[name] = dpts[:, pid, :].T @ dz  # (2, 2)
    return compl


def _polished(prob, z, lam):
    """(z, ``jacobian_complex_step`` at z): Newton steps with the complex-step Jacobian from the
    converged z while each lowers the residual (at most POLISH_STEPS, each within POLISH_REACH).
    Newton's stop (its residual below SHOOTING_NOISE times the load level) leaves z off by that
    over the margin, and under large loads the compliance moves with z: 1.3e-6 at a tip force
    of 200 EI/L^2; the accurate Jacobian takes z to the integration's rounding in a step or
    two."""
    state = prob.jacobian_complex_step(z, lam)
    for _ in range(POLISH_STEPS):
        R0, J = state[0], state[1]
        try:
            dz = np.linalg.solve(J, R0)
        except np.linalg.LinAlgError:
            break
        if not np.max(np.abs(dz), initial=0.0) <= POLISH_REACH * (1.0 + np.max(np.abs(z))):
            break
        trial = prob.jacobian_complex_step(z - dz, lam)
        if not np.max(np.abs(trial[0]), initial=0.0) < np.max(np.abs(R0), initial=0.0):
            break
        z, state = z - dz, trial
    return z, state


def shooting_margin(J0: np.ndarray, J: np.ndarray) -> float:
    """How far a state is from a critical load: the smallest |eigenvalue| of J0^-1 J (the
    shooting Jacobian there against the unloaded one). The shooting Jacobian is singular exactly
    where the second variation is, and its compliance solve divides by this: near 0 the
    compliance amplifies the shooting Jacobian's error (``COMPLIANCE_NOISE``)."""
    try:
        ev = np.linalg.eigvals(np.linalg.solve(J0, J))
    except np.linalg.LinAlgError:
        return 0.0
    value = float(np.min(np.abs(ev)))
    return value if math.isfinite(value) else 0.0


def _solve_exact(scene, num: int = 65, max_step: float = 0.25) -> SceneSolution:
    """Exact elastica equilibrium of a whole scene (tree of flexures and links).

    Unknowns: for every flexure, the force transmitted through it (world frame) and its root
    moment; residuals: that force and the tip moment must equal the resultant of everything
    beyond the flexure's tip (dead loads, tendon forces at the current geometry). Newton with a
    central-difference Jacobian of the batched shooting map, load continuation lam: 0 -> 1 on all
    loads and tendon tensions.

    ``stable``: the sign of det(shooting Jacobian) is the one it has in the unloaded, stable
    state. The shooting Jacobian is singular exactly where the second variation is, so an odd
    number of eigenvalue crossings along the path is detected; an even number is not. If the sign
    flips (a bifurcation, e.g. a straight column past its Euler load) the solver tries to switch
    to the branch along the null vector, oriented to the side the load pushed the last stable
    state along its softest mode (an imperfect structure: the side its imperfection chose;
    ``_imperfection_side``), else (a symmetric structure) by the chain models' side rules: the
    side whose output points lie higher (to first order along the null vector), else the one
    where the first flexure bends counter-clockwise at its root (+y for a flexure along +x); it
    keeps the branch if it is stable and on that side. A step from a stable state against the path's tangent is a jump to the mirror
    branch and is retried shorter.

    ``compliance``: d(position of p)/d(force at p), by the implicit function theorem on the
    converged shooting system (exact dR/dF, the complex-step shooting Jacobian and d(pos)/dz),
    all other loads held.
    """
    prob = _SceneProblem(scene)
    m = 3 * prob.n
    warnings = []
    z = np.zeros(m)
    R, J0, _, _, tips_cur = prob.jacobian(z, 0.0)
    ref_sign = np.sign(np.linalg.det(J0))
    # at the last accepted state (z, lam): the shooting Jacobian and, while it is stable,
    # dR/dlam (the path's tangent is -J^-1 dR/dlam), found once per state for every step tried
    J_cur, dR_cur = J0, _load_derivative(prob, z, 0.0, R)
    lam, dlam = 0.0, min(0.1, max_step)
    hist = [(0.0, z.copy())]
    iters = 0
    lam_c = None
    sign = ref_sign
    lost = None  # a crossing whose branch switch failed: (its load factor, side, warning, tries)
    # the scene's own loads past the cap (docs/scene.md, "Limits"): refused before any step
    level = max(scene.load_levels().values(), default=0.0)
    if not level <= MAX_LOAD:
        warnings.append(
            f"nondimensional load {level:.3g} (force x L^2/EI + moment x L/EI) is beyond the "
            f"exact solver's cap of {MAX_LOAD:g}, where the elastica winds too often to follow"
        )
        lam = -1.0  # no step is taken; reported as load factor 0 below
    zero = _zero_segment(prob)
    if zero is not None:
        warnings.append(
            f"tendon segment {zero[0]!r} -> {zero[1]!r} has zero length in the unloaded scene"
        )
        lam = -1.0
    while 0.0 <= lam < 1.0:
        lam_new = min(1.0, lam + dlam)
        if len(hist) >= 2:
            (l0, z0), (l1, z1) = hist[-2], hist[-1]
            guess = z1 + (z1 - z0) * (lam_new - l1) / (l1 - l0)
        else:
            guess = z.copy()
        why = None  # what stopped this step, when the shooting itself refused
        try:
            z_new, it = prob.newton(guess, lam_new, max_iter=10)
            iters += it
            # step control: the corrector must stay close to the predictor (no branch jumping)
            ok = np.max(np.abs(z_new - guess)) < 0.1 * (1.0 + np.max(np.abs(z_new)))
            if ok and sign == ref_sign:
                ok = _along_tangent(J_cur, dR_cur, z_new - z)
        except RuntimeError as exc:
            ok, why = False, str(exc)
        if ok:
            R_new, J, dpts, _, tips_new = prob.jacobian(z_new, lam_new)
            s_new = np.sign(np.linalg.det(J))
            if s_new != sign and dlam > 1e-3:
                ok = False  # confirm a sign change of det J with small steps (no jump)
            # a step that turns a flexure's tip by more than MAX_TURN_STEP may have jumped to
            # another branch (found by review: under tension and a moment the default step
            # landed on a branch wound once more, tip angle 7.89 rad against 1.65)
            elif np.max(np.abs(tips_new[:, 2] - tips_cur[:, 2])) > MAX_TURN_STEP:
                ok = False
        if not ok:
            dlam *= 0.5
            if dlam < 1e-6:
                short = _short_tendon(prob, z, lam)
                capped = why is not None and why.startswith("nondimensional load beyond")
                limit = short is None and not capped and lam * level <= SHOOTING_RESOLVED
                warnings.append(
                    f"continuation stalled at load factor {lam:.6g} "
                    + (
                        f"(the root loads would pass the solver's cap: {why})"
                        if capped
                        # review: a tendon pulled to zero length read as a snap-through
                        else f"(tendon segment {short[0]!r} -> {short[1]!r} has nearly zero "
                        "length: its point has reached the other)"
                        if short is not None
                        else "(limit point: the load would snap through)"
                        if limit
                        else "(a limit point, or past what the shooting resolves: a load level of "
                        f"{lam * level:.3g}, above {SHOOTING_RESOLVED:g}; check with fem)"
                    )
                )
                if lam_c is None and limit:  # only a limit point is a critical load
                    lam_c = lam
                break
            continue
        if s_new != sign:
            # locate this crossing (every one: review, a second bifurcation's note gave the
            # first one's load factor); the first is the answer's critical load factor
            lam_x = lam_new
            try:

                def dets(l):
                    zz = z + (z_new - z) * (l - lam) / (lam_new - lam)  # noqa: B023
                    zz, _ = prob.newton(zz, l)
                    return np.linalg.det(prob.jacobian(zz, l)[1])

                lam_x = brentq(dets, lam, lam_new, xtol=1e-12)
            except (ValueError, RuntimeError):
                pass
            if lam_c is None:
                lam_c = lam_x
            if s_new != ref_sign:
                side = _imperfection_side(J_cur, dR_cur)  # from the last state before it
                found = _switch_branch(prob, z_new, lam_new, J, dpts, side, ref_sign)
                if found is not None:
                    z_new, R_new, J, tips_new, itb = found
                    iters += itb
                    s_new = ref_sign
                    # secant from the last point before the bifurcation: predicts on the
                    # chosen side of the pitchfork (no jump to the mirror branch)
                    hist = [(lam, z.copy())]
                    warnings.append(
                        f"bifurcation at load factor {lam_x:.9g}: followed the stable branch"
                    )
                else:
                    warnings.append(f"equilibrium path lost stability at load factor {lam_x:.9g}")
                    # just past a bifurcation the stable branch lies within the shooting's
                    # reach of the unstable one: pushes along the null vector fall back to it
                    # (review: a column under a tendon anchored at its root stayed straight,
                    # unstable, at 1.1 x its critical tension): tried again on the next steps
                    lost = (lam_x, side, len(warnings) - 1, LOST_RETRIES)
            else:
                lost = None  # stable again on its own
        elif lost is not None and sign != ref_sign and lost[3] > 0:
            lam_l, side, at, left = lost
            lost = (lam_l, side, at, left - 1)
            found = _switch_branch(prob, z_new, lam_new, J, dpts, side, ref_sign)
            if found is not None:
                z_new, R_new, J, tips_new, itb = found
                iters += itb
                s_new = ref_sign
                hist = []  # the states before are on the unstable branch: no secant from them
                warnings[at] = (
                    f"bifurcation at load factor {lam_l:.9g}: followed the stable branch "
                    f"(reached from the unstable one at load factor {lam_new:.6g})"
                )
                lost = None
        sign = s_new
        hist.append((lam_new, z_new.copy()))
        lam, z, tips_cur = lam_new, z_new, tips_new
        J_cur = J
        dR_cur = _load_derivative(prob, z, lam, R_new) if sign == ref_sign and lam < 1.0 else None
        dlam = min(max_step, dlam * (1.5 if it <= 4 else 1.0))
    converged = lam >= 1.0
    lam = max(lam, 0.0)
    if not converged:
        warnings.append(PARTIAL_LOAD)
    # final quantities: z polished with the complex-step shooting Jacobian, then the
    # compliances at it by the implicit function theorem
    z, (R0, J, dpts, pts, tips) = _polished(prob, z, lam)
    compl = _compliances(prob, J, dpts, pts, tips)
    notes: list[str] = []
    stable = bool(np.sign(np.linalg.det(J)) == ref_sign)
    margin = shooting_margin(J0, J)
    _, _, _, shapes, frames = prob.evaluate(z, lam, shapes_num=num)
    poses = {}
    for name, pid in zip(prob.outputs, prob.out_ids):
        th = frames[prob.P_owner[pid]][0, 2]
        poses[name] = np.array([pts[pid, 0], pts[pid, 1], th])
    root_loads = {}
    for i, name in enumerate(prob.order):
        sc = prob.EI[i] / prob.L[i] ** 2
        root_loads[name] = np.array(
            [z[3 * i] * sc, z[3 * i + 1] * sc, z[3 * i + 2] * prob.EI[i] / prob.L[i]]
        )
    return SceneSolution(
        converged=converged,
        stable=stable,
        iterations=iters,
        poses=poses,
        compliance=compl,
        shapes=shapes,
        tip_frames={n: tips[i] for i, n in enumerate(prob.order)},
        root_loads=root_loads,
        load_factor=lam,
        critical_load_factor=lam_c,
        warnings=warnings,
        margin=margin,
        notes=notes,
    )
