"""Equilibrium, stability and compliance of a scene under dead loads and tendons.

Total potential at load factor ``lam`` (every load and tendon tension scaled by ``lam``)::

    Pi(q) = U(q) - lam * sum_p F_p . pose_p(q) + lam * sum_t T_t l_t(q)      F_p = (fx, fy, moment)
    r(q)  = grad U - lam * sum_p J_p^T F_p + lam * sum_t T_t grad l_t        (residual = grad Pi)
    K(q)  = hess U - lam * sum_p H_p^T F_p + lam * sum_t T_t hess l_t        (stiffness = hess Pi)

A moment acts on the angle row of its point's pose (the body's angle), a force on the position rows.

Continuation. The solve starts from the unloaded state (q = 0 at lam = 0) and raises lam to 1 in
adaptive steps (tangent predictor dq/dlam = K^-1 Q_ext while K is positive definite, then Newton
with a backtracking line search on |r|; the step grows after quick convergence and halves after a
failure), so the answer is the branch a slowly applied load reaches.

Stability and bifurcations. After every step K is checked (Cholesky). When a step from a stable
state lands on an unstable one, the lost mode v (eigenvector of the smallest eigenvalue) tells the
two cases apart: at a bifurcation the load does no work along v (|v . Q| <= 1e-6 (|Q| + |K_geo|),
e.g. by symmetry); otherwise the step overshot a limit point onto the unstable branch and is
retried shorter. At a bifurcation the crossing is located by regula falsi (Illinois) on the smallest
eigenvalue, re-solving the equilibrium along the path at each trial load factor; the critical load
factor is recorded with a warning and the solve leaves the unstable branch: from the unstable state
it descends the potential (Newton with the eigenvalues of K replaced by their magnitudes, Armijo
line search on Pi, step expansion along negative curvature) starting at q +- eps v, and keeps the
stable side with the lower potential; when both sides have the same potential (a symmetric
pitchfork) it keeps the side that moves the output points to larger mean world y (then: larger mean
body angle, i.e. counter-clockwise). If the path ends (a limit point: Newton finds no equilibrium
near the path even at the smallest step) the same descent finds the stable equilibrium the
structure snaps to, with a warning and the load factor recorded. A step along the path may change
no coordinate by more than ``max_dq``; a larger change counts as a jump and the step is shortened.

Convergence. The residual is relative to the scale of the generalized forces in the problem:

    rel = |r|_inf / max(|grad U|_inf, lam * max_i S_i)
    S_i = sum_p (|f_p| |d r_p/d q_i| + |m_p| |d th_p/d q_i|) + sum_t T_t sum_k |d(r_k+1 - r_k)/d q_i|

evaluated at the current q: S_i is the largest generalized force the loads and tendons could exert
on coordinate q_i whatever their direction (so a load that happens to do no work on q, such as an
axial load on a straight flexure, still sets the scale). An equilibrium is accepted when
rel <= tol (default 1e-12). This is invariant under a change of units. The unloaded state (all
terms zero) counts as converged.

If no equilibrium is found (Newton fails even at the smallest step, too many continuation steps, a
model raising an error such as a kernel out of its range), ``solve`` returns a Result with
``converged=False`` and a ``reason``; it raises only for invalid input (unknown points, missing
models).
"""
from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np
import scipy.linalg

from .chain import Chain, ChainError
from .compiled import solver as compiled_solver
from .models.base import FlexureModel
from .result import UNSTABLE, Result, point_result
from .scene import Flexure, Scene

_EVAL_ERRORS = (ValueError, ArithmeticError, np.linalg.LinAlgError)
BACKENDS = ("python", "c")


@dataclass
class State:
    """Everything about one configuration ``q`` at load factor ``lam``."""

    q: np.ndarray
    lam: float
    Pi: float         # total potential
    U: float          # elastic energy
    r: np.ndarray     # residual (gradient of Pi)
    K: np.ndarray     # stiffness (Hessian of Pi)
    Q: np.ndarray     # external generalized force at lam = 1 (loads minus tendons)
    scale: float      # force scale of the relative residual
    kg: float = 0.0   # norm of the load (geometric) part of K
    parts: tuple | None = field(default=None, repr=False, compare=False)
    # the load-independent pieces (System.at_lambda re-scales them to another load factor)

    @functools.cached_property
    def rel(self) -> float:
        """Relative residual (computed once: a State is not modified after it is built)."""
        rn = float(np.max(np.abs(self.r))) if self.r.size else 0.0
        if rn == 0.0:
            return 0.0
        return rn / self.scale if self.scale > 0 else math.inf


class System:
    """A Chain with the scene's loads and tendons: potential, residual and stiffness."""

    def __init__(self, chain: Chain, loads=None, tendons=None):
        self.chain = chain
        scene = chain.scene
        loads = scene.loads if loads is None else loads
        self.loads = [(ld.point, np.array([ld.force[0], ld.force[1], ld.moment], dtype=float))
                      for ld in loads]
        self.tendons = [(float(t.tension), tuple(t.route))
                        for t in (scene.tendons if tendons is None else tendons)]
        for ref, _ in self.loads:
            chain.resolve_point(ref)
        for _, route in self.tendons:
            for ref in route:
                chain.resolve_point(ref)

    def state(self, q, lam: float) -> State:
        ch = self.chain
        q = np.array(q, dtype=float)        # a private copy (State.q)
        n = ch.ndof
        U, gU, KU = ch.energy_terms(q)
        ch._light_frames(q)                 # the points' poses and Jacobians at q (ch._pj)
        W, QL = 0.0, np.zeros(n)
        coeffs = []             # Hessian row coefficients per point: -F for loads, T u for tendons
        reach = np.zeros(n)     # largest generalized force the loads could exert on each q_i
        for ref, F in self.loads:
            pose, J = ch._pj(ref)
            f0, f1, f2 = float(F[0]), float(F[1]), float(F[2])
            W += float(F @ pose)
            QL += F @ J
            coeffs.append((ref, (-f0, -f1, -f2)))
            h = math.hypot(f0, f1)
            if f2 == 0.0:           # the same sum: a zero term adds 0.0
                reach += h * np.sqrt(J[0] * J[0] + J[1] * J[1])
            elif h == 0.0:
                reach += abs(f2) * np.abs(J[2])
            else:
                reach += h * np.sqrt(J[0] * J[0] + J[1] * J[1]) + abs(f2) * np.abs(J[2])
        V, QT, GT = 0.0, np.zeros(n), np.zeros((n, n))
        for T, route in self.tendons:
            if T == 0.0:
                continue
            # length l = sum of segment lengths; grad l and the rank-one part of hess l here,
            # the points' Hessians through the contraction (chain.tendon_length's terms)
            pts = [ch._pj(ref) for ref in route]
            l, gl, hl = 0.0, np.zeros(n), np.zeros((n, n))
            for k in range(len(pts) - 1):
                (pa, Ja), (pb, Jb) = pts[k], pts[k + 1]
                dx = float(pb[0] - pa[0])
                dy = float(pb[1] - pa[1])
                rho = math.hypot(dx, dy)
                if rho == 0.0:
                    raise ChainError(f"tendon segment {route[k]!r} -> {route[k + 1]!r} has zero "
                                     f"length")
                ux, uy = dx / rho, dy / rho
                Jx = Jb[0] - Ja[0]
                Jy = Jb[1] - Ja[1]
                l += rho
                gl += ux * Jx + uy * Jy
                m = ux * Jy - uy * Jx
                hl += np.multiply.outer(m, m / rho)
                coeffs.append((route[k + 1], (T * ux, T * uy, 0.0)))
                coeffs.append((route[k], (-T * ux, -T * uy, 0.0)))
                reach += abs(T) * np.sqrt(Jx * Jx + Jy * Jy)
            V += T * l
            QT += T * gl
            GT += T * hl
        parts = (U, W, V, gU, KU, QL, QT, GT + ch.hessian_sum(q, coeffs),
                 float(np.max(np.abs(gU), initial=0.0)), float(np.max(reach, initial=0.0)),
                 ch.light_snapshot())
        return self._at(q, lam, parts)

    @staticmethod
    def _at(q, lam: float, parts) -> State:
        U, W, V, gU, KU, QL, QT, S, gmax, rmax, _ = parts
        r = gU - lam * QL + lam * QT
        G = lam * S
        K = KU + G
        K = 0.5 * (K + K.T)
        scale = max(gmax, abs(lam) * rmax)
        kg = float(np.linalg.norm(G))
        return State(q, float(lam), U - lam * W + lam * V, U, r, K, QL - QT, scale, kg, parts)

    def at_lambda(self, st: State, lam: float) -> State:
        """``state(st.q, lam)`` without evaluating the chain again: every term is linear in the
        load factor, so the same numbers (bit for bit) from ``st``'s load-independent parts."""
        if st.parts is None:
            return self.state(st.q, lam)
        return self._at(st.q, lam, st.parts)


def _cholesky_ok(K: np.ndarray) -> bool:
    if K.size == 0:
        return True
    try:
        np.linalg.cholesky(K)
        return True
    except np.linalg.LinAlgError:
        return False


def _min_eig(K: np.ndarray) -> tuple[float, np.ndarray]:
    w, V = np.linalg.eigh(K)
    return float(w[0]), V[:, 0]


class _Solver:
    def __init__(self, system: System, tol: float, max_iterations: int):
        self.sys = system
        self.tol = tol
        self.max_iterations = max_iterations
        self.iterations = 0
        self.last_error: str | None = None
        self.model_error: str | None = None   # the last exception a model or the chain raised

    def evaluate(self, q, lam) -> State | None:
        try:
            st = self.sys.state(q, lam)
        except _EVAL_ERRORS as exc:
            self.last_error = self.model_error = str(exc)
            return None
        if not (np.isfinite(st.Pi) and np.all(np.isfinite(st.r)) and np.all(np.isfinite(st.K))):
            self.last_error = "a model returned a non-finite value"
            return None
        return st

    def at_lambda(self, st: State, lam: float) -> State | None:
        """``evaluate(st.q, lam)``, from st's parts (no chain evaluation)."""
        try:
            new = self.sys.at_lambda(st, lam)
        except _EVAL_ERRORS as exc:
            self.last_error = self.model_error = str(exc)
            return None
        if not (np.isfinite(new.Pi) and np.all(np.isfinite(new.r)) and np.all(np.isfinite(new.K))):
            self.last_error = "a model returned a non-finite value"
            return None
        return new

    def newton(self, q0, lam, descent=False, max_iterations=None,
               start: State | None = None) -> State | None:
        """Newton from q0 at load factor lam (or from the already evaluated ``start``).
        ``descent`` makes every step a descent direction of Pi (eigenvalues of K replaced by their
        magnitudes) so it ends at a stable equilibrium."""
        max_it = self.max_iterations if max_iterations is None else max_iterations
        st = start if start is not None else self.evaluate(q0, lam)
        if st is None:
            return None
        history = []
        for k in range(max_it + 1):
            if st.rel <= self.tol:
                return st        # the caller checks stability
            if k == max_it:
                break
            history.append(st.rel)
            if not descent and k >= 8 and st.rel > 0.5 * history[k - 6]:
                self.last_error = (f"Newton stagnates at load factor {lam:.6g} "
                                   f"(relative residual {st.rel:.2e})")
                return None
            self.iterations += 1
            indefinite = False
            if descent:
                w, V = np.linalg.eigh(st.K)
                top = max(float(np.max(np.abs(w))), 1e-300)
                indefinite = bool(w[0] <= 1e-10 * top)
                wm = np.maximum(np.abs(w), 1e-10 * top)
                d = -(V @ ((V.T @ st.r) / wm))
            else:
                try:
                    d = -np.linalg.solve(st.K, st.r)
                except np.linalg.LinAlgError:
                    d = -np.linalg.lstsq(st.K, st.r, rcond=None)[0]
            new = self._line_search(st, d, descent, indefinite)
            if new is None:
                return None
            st = new
        self.last_error = f"Newton did not converge in {max_it} iterations (relative residual {st.rel:.2e})"
        return None

    def _line_search(self, st: State, d, descent: bool, indefinite: bool) -> State | None:
        rn = float(np.linalg.norm(st.r))
        slope = float(st.r @ d)
        alpha = 1.0
        best = None
        for _ in range(30):
            trial = self.evaluate(st.q + alpha * d, st.lam)
            if trial is not None:
                tn = float(np.linalg.norm(trial.r))
                if descent:
                    ok = trial.Pi <= st.Pi + 1e-4 * alpha * slope
                    roundoff = abs(trial.Pi - st.Pi) <= 1e-13 * (abs(st.Pi) + abs(st.U)) and tn < rn
                    if ok or roundoff:
                        best = trial
                        if ok and indefinite and alpha >= 1.0:
                            # negative curvature: expand while the potential keeps falling
                            a = alpha
                            for _ in range(40):
                                a *= 2.0
                                t2 = self.evaluate(st.q + a * d, st.lam)
                                if t2 is None or t2.Pi >= best.Pi:
                                    break
                                best = t2
                        return best
                elif tn <= (1.0 - 1e-4 * alpha) * rn:
                    return trial
            alpha *= 0.5
        self.last_error = (f"line search failed at load factor {st.lam:.6g} "
                           f"(relative residual {st.rel:.2e})")
        return None


def _output_points(scene: Scene, chain: Chain) -> list[str]:
    if scene.outputs:
        return list(scene.outputs)
    refs = list(dict.fromkeys(ld.point for ld in scene.loads))
    if refs:
        return refs
    # no loads: the tips of the flexures that carry no other flexure
    parents = {chain.body_parent(f.name) for f in scene.flexures}
    link_parent = {l.name: l.parent for l in scene.links}
    leaf = []
    for f in scene.flexures:
        carries = any(p == f.name or link_parent.get(p) == f.name for p in parents)
        if not carries:
            leaf.append(f"{f.name}.tip")
    return leaf


def _model_info(model: FlexureModel) -> dict:
    kind = getattr(model, "kind", "?")
    info = {"kind": kind}
    if kind in ("scm", "cc"):
        info["modes"] = int(getattr(model, "modes", model.n_dof))
    elif kind == "fem":
        info["elements"] = int(getattr(model, "elements", model.n_dof))
    return info


def prepare_system(scene: Scene, models: Mapping[str, FlexureModel]):
    """(chain, system, output points, model info) of a scene with these models."""
    chain = Chain(scene, models)
    system = System(chain)
    outputs = _output_points(scene, chain)
    for ref in outputs:
        chain.resolve_point(ref)
    return chain, system, outputs, {name: _model_info(m) for name, m in models.items()}


def _load_scene(scene) -> Scene:
    if isinstance(scene, Scene):
        return scene
    from . import scene as scene_mod
    if isinstance(scene, (str, os.PathLike)) and hasattr(scene_mod, "load_scene"):
        return scene_mod.load_scene(scene)
    if isinstance(scene, Mapping) and hasattr(scene_mod, "scene_from_dict"):
        return scene_mod.scene_from_dict(scene)
    raise TypeError(f"solve() needs a Scene, not {type(scene).__name__}")


def solve(scene: Scene, models: Mapping[str, FlexureModel] | None = None, *,
          model_factory: Callable[[Flexure], FlexureModel] | None = None,
          tol: float = 1e-12, max_iterations: int = 50, max_steps: int = 500,
          initial_step: float = 0.1, max_step: float = 0.25, min_step: float = 1e-5,
          max_dq: float = 0.5, tolerance: float | None = None,
          q0: Mapping[str, "np.ndarray | list[float]"] | None = None,
          backend: str = "python") -> Result:
    """Solve ``scene`` under its loads and tendons by load continuation from the unloaded state.

    ``models`` gives the FlexureModel of some or all flexures; the others are built by
    ``model_factory`` (default ``flexgen.models.registry.build_model``, from each flexure's
    ModelSpec). ``tol`` is the relative residual (see the module docstring); ``max_iterations``
    bounds the Newton iterations of one continuation step; ``max_steps`` the continuation steps;
    ``initial_step``, ``max_step``, ``min_step`` the load-factor steps; ``max_dq`` the largest
    change of any generalized coordinate in one step along the path (larger changes count as a
    jump to another branch and make the step shorter).

    ``tolerance`` (or ``[model] tolerance`` in the scene, when no ``models``/``model_factory`` are
    given) chooses the fewest modes per flexure that meet it: see ``flexgen.select``.
    ``q0`` ({flexure: coordinates}, e.g. the ``q`` of a richer solve; Legendre coefficients are
    padded with zeros or truncated to each model's size) is a warm start: Newton at the full load
    from q0 first; if that converges to a stable equilibrium within ``max_dq`` of q0 it is the
    answer, otherwise the solve falls back to the continuation from the unloaded state.

    ``backend`` = "c" solves with the compiled chain solver (``flexgen.compiled``) where it can:
    the same direct attempt, warm start and load continuation as here, bifurcations,
    snap-throughs and kernel switches included; every case it hands back (a failed warm start, a
    solve that fails, a model without a C counterpart) runs the Python solver below, so the
    answer is the same.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend: must be one of {', '.join(BACKENDS)}, got {backend!r}")
    scene = _load_scene(scene)
    if tolerance is None and models is None and model_factory is None:
        from .select import scene_tolerance
        tolerance = scene_tolerance(scene)
    if tolerance is not None:
        if models is not None or model_factory is not None:
            raise ValueError("solve: tolerance chooses the models; do not also pass models")
        from .select import solve_to_tolerance
        return solve_to_tolerance(scene, tolerance, tol=tol, max_iterations=max_iterations,
                                  max_steps=max_steps, initial_step=initial_step,
                                  max_step=max_step, min_step=min_step, max_dq=max_dq,
                                  backend=backend)
    from .models.registry import build_models
    models = build_models(scene, models, model_factory)
    for m in models.values():          # a model reused from an earlier solve: its switch is not ours
        if getattr(m, "switched", False):
            m.switched = False

    prepare = functools.partial(prepare_system, scene, models)
    unavailable = None          # why the compiled solver could not run, if it was asked for
    if backend == "c":
        settings = dict(tol=tol, max_iterations=max_iterations, max_steps=max_steps,
                        initial_step=initial_step, max_step=max_step, min_step=min_step,
                        max_dq=max_dq)
        compiled, unavailable = compiled_solver.solve_compiled(scene, models, settings, prepare,
                                                                q0)
        if compiled is not None:
            return compiled
    chain, system, outputs, info = prepare()
    sol = _Solver(system, tol, max_iterations)
    warnings: list[str] = []
    if unavailable:
        warnings.append(unavailable)
    critical: list[float] = []

    def fail(reason: str, lam: float) -> Result:
        if sol.model_error and sol.model_error not in reason:
            reason = f"{reason} (last model error: {sol.model_error})"
        warnings.extend(_kernel_warnings(models, chain, None))
        return Result(scene=scene.name, converged=False, stable=False, iterations=sol.iterations,
                      model=info, q={}, points={}, warnings=warnings, reason=reason,
                      critical_load_factors=critical, load_factor=lam)

    if q0 is not None:
        warm = _warm_start(sol, chain, q0, max_dq)
        if warm is not None:
            warm = _polish(sol, warm)
            warnings.extend(_kernel_warnings(models, chain, warm.q))
            return _result(scene, chain, system, warm, outputs, info, sol.iterations, warnings,
                           critical)
        sol.model_error = None
    st = sol.newton(chain.zeros(), 0.0)
    if st is None:
        return fail(f"no equilibrium of the unloaded scene: {sol.last_error}", 0.0)
    direct = _direct_solve(sol, st, models, max_dq) if max_steps >= 1 else None
    if direct is not None:
        direct = _polish(sol, direct)
        warnings.extend(_kernel_warnings(models, chain, direct.q))
        return _result(scene, chain, system, direct, outputs, info, sol.iterations, warnings,
                       critical)
    lam, dlam, steps = 0.0, float(initial_step), 0
    while lam < 1.0:
        steps += 1
        if steps > max_steps:
            return fail(f"load continuation needed more than {max_steps} steps "
                        f"(reached load factor {lam:.6g})", lam)
        lam_n = min(1.0, lam + dlam)
        it0 = sol.iterations
        new = _path_step(sol, st, lam_n, max_dq)
        used = sol.iterations - it0
        if new is not None and not _cholesky_ok(new.K) and _cholesky_ok(st.K):
            if _is_bifurcation(new):
                new = _cross_bifurcation(sol, st, new, outputs, chain, warnings, critical)
                if new is None:
                    return fail(f"no stable equilibrium found past the bifurcation near load "
                                f"factor {lam:.6g}: {sol.last_error}", lam)
                st, lam, dlam = new, lam_n, float(initial_step)
                continue
            new = None        # landed on the unstable side of a limit point: a shorter step
        if new is None:
            if dlam > min_step:
                dlam = max(0.5 * dlam, min_step)
                continue
            # the path ends here (limit point): descend to the equilibrium it snaps to
            new = sol.newton(st.q, lam_n, descent=True, max_iterations=20 * max_iterations)
            if new is None or not _cholesky_ok(new.K):
                return fail(f"no equilibrium found beyond load factor {lam:.6g}: {sol.last_error}", lam)
            critical.append(float(lam))
            warnings.append(snap_warning(lam))
            st, lam, dlam = new, lam_n, float(initial_step)
            continue
        if used <= 3:
            dlam = min(2.0 * dlam, max_step)
        elif used <= 6:
            dlam = min(1.2 * dlam, max_step)
        st, lam = new, lam_n
        sol.model_error = None

    st = _polish(sol, st)
    warnings.extend(_kernel_warnings(models, chain, st.q))
    return _result(scene, chain, system, st, outputs, info, sol.iterations, warnings, critical)


def _direct_solve(sol: _Solver, st0: State, models, max_dq: float,
                  samples=(0.25, 0.5, 0.75), max_iterations: int = 12) -> State | None:
    """The full load in one step, when that provably-enough lands where the continuation would.

    Newton at load factor 1 straight from the unloaded equilibrium ``st0``; the answer is accepted
    only if every check below passes, else None (the caller runs the continuation; the model
    state is restored as if this had not been tried):

    * K(q0, 1) is positive definite. K(q0, lam) is linear in lam, so it is then positive definite
      for every lam in [0, 1]: the unloaded configuration is stable under every fraction of the
      load, so no bifurcation from it (e.g. Euler buckling under an axial load, where Newton would
      stay on the straight, unstable branch) is possible.
    * Newton converges (relative residual <= tol) within ``max_iterations`` (and the solve's
      own limit); the end state and the
      sampled path states below are within every switching model's polynomial range (trial
      steps of the line search that went past it do not count and leave no warning).
    * The end state is stable (K positive definite).
    * The path in between is checked at ``samples`` load factors t: on the cubic Hermite curve
      through (0, q0) and (1, q1) with the path tangents dq/dlam = K^-1 Q at both ends, K(q(t), t)
      must be positive definite and the Newton correction |K^-1 r|_inf at q(t) at most
      0.2 max_dq (a continuation step may move q by up to max_dq; its predictors miss by about
      this much): an equilibrium path stable at both ends, close to a smooth curve and stable
      where sampled. A limit point (snap-through) or a jump to another branch between the ends
      makes the Hermite curve miss the equilibria (large correction) or pass through unstable
      states, and then the continuation (which locates and reports these) runs instead.

    A rejected attempt leaves no trace in the result (its Newton iterations are not counted).
    """
    if not _cholesky_ok(st0.K):
        return None
    flags = {name: getattr(m, "switched", None) for name, m in models.items()}
    it0, err0, merr0 = sol.iterations, sol.last_error, sol.model_error

    def reject():
        for name, m in models.items():
            if flags[name] is not None:
                m.switched = flags[name]
        sol.iterations, sol.last_error, sol.model_error = it0, err0, merr0
        return None

    s1 = sol.at_lambda(st0, 1.0)
    if s1 is None or not _cholesky_ok(s1.K):
        return reject()
    end = sol.newton(None, 1.0, max_iterations=min(max_iterations, sol.max_iterations), start=s1)
    if end is None:
        return reject()
    try:
        np.linalg.cholesky(end.K)                    # positive definite (else reject)
        t1 = np.linalg.solve(end.K, end.Q)
        t0 = np.linalg.solve(st0.K, st0.Q)
    except (np.linalg.LinAlgError, ValueError):
        return reject()
    q0, q1 = st0.q, end.q
    visited = [q1]
    for t in samples:
        h00, h10 = 2 * t ** 3 - 3 * t ** 2 + 1, t ** 3 - 2 * t ** 2 + t
        h01, h11 = -2 * t ** 3 + 3 * t ** 2, t ** 3 - t ** 2
        qt = h00 * q0 + h10 * t0 + h01 * q1 + h11 * t1
        s = sol.evaluate(qt, t)
        if s is None:
            return reject()
        try:
            np.linalg.cholesky(s.K)
            corr = np.linalg.solve(s.K, s.r)
        except np.linalg.LinAlgError:
            return reject()
        if not float(np.max(np.abs(corr), initial=0.0)) <= 0.2 * max_dq:
            return reject()
        visited.append(qt)
    # Newton's trial steps may have gone past a kernel's range (an error, or a kernel switch,
    # that the line search stepped back from): that is no part of the path. The path itself must
    # stay in range (else the continuation reports the switch as it always did).
    for name, m in models.items():
        if flags[name] is None:
            continue
        m.switched = flags[name]
        sl = sol.sys.chain.slices[name]
        if not all(m.in_range(q[sl]) for q in visited):
            return reject()
    sol.last_error, sol.model_error = err0, merr0
    return end


def _polish(sol: _Solver, st: State, target: float = 1e-14, steps: int = 3) -> State:
    """Plain Newton steps on an accepted equilibrium while they lower the relative residual
    below ``target``: an answer accepted at rel <= tol (1e-12) can still carry an error of
    ~1e-11 in q (K's conditioning), which depends on the path Newton came by; polished, the
    reported equilibrium is the same to rounding whichever way the solve reached it."""
    for _ in range(steps):
        if st.rel <= target:
            break
        try:
            d = np.linalg.solve(st.K, st.r)
        except np.linalg.LinAlgError:
            break
        trial = sol.evaluate(st.q - d, st.lam)
        if trial is None or not trial.rel < st.rel:
            break
        sol.iterations += 1
        st = trial
    return st


def _warm_start(sol: _Solver, chain: Chain, q0, max_dq: float) -> State | None:
    """Newton at the full load from q0 (per flexure, padded with zeros or truncated); the state
    if it converges to a stable equilibrium within max_dq of q0, else None."""
    start = chain.zeros()
    for name, sl in chain.slices.items():
        v = np.asarray(q0.get(name, ()), dtype=float).ravel()[: sl.stop - sl.start]
        start[sl.start:sl.start + v.size] = v
    st = sol.newton(start, 1.0)
    if st is None or not _cholesky_ok(st.K):
        return None
    if float(np.max(np.abs(st.q - start), initial=0.0)) > max_dq:
        return None
    return st


def _kernel_warnings(models, chain: Chain, q) -> list[str]:
    """One warning per flexure whose model switched kernels during the solve (scm "auto": past
    the polynomial kernel's range to the Gauss kernel); q is the equilibrium (None: none found)."""
    return kernel_warnings(models, chain.split(q) if q is not None else {})


def kernel_warnings(models, parts: Mapping[str, np.ndarray]) -> list[str]:
    """``_kernel_warnings`` with the equilibrium given per flexure (both solvers use it)."""
    out = []
    for name, m in models.items():
        warn = getattr(m, "switch_warning", None)
        msg = warn(parts.get(name)) if warn is not None else None
        if msg:
            out.append(msg)
    return out


def _path_step(sol: _Solver, st: State, lam_n: float, max_dq: float) -> State | None:
    """Newton at lam_n from the tangent predictor (or from st.q); None if it fails or jumps."""
    starts = []
    if _cholesky_ok(st.K):
        try:
            starts.append(st.q + (lam_n - st.lam) * np.linalg.solve(st.K, st.Q))
        except np.linalg.LinAlgError:
            pass
    starts.append(st.q)
    for q0 in starts:
        new = sol.newton(q0, lam_n)
        if new is not None:
            if float(np.max(np.abs(new.q - st.q), initial=0.0)) <= max_dq:
                return new
            sol.last_error = f"the path jumped by more than {max_dq} in q at load factor {lam_n:.6g}"
    return None


def _is_bifurcation(b: State, threshold: float = 1e-6) -> bool:
    """At a bifurcation the external load does no work along the lost mode v (v . Q = 0, e.g. by
    symmetry); at a limit point it does. Measured against |Q| + |geometric stiffness|."""
    _, v = _min_eig(b.K)
    scale = float(np.linalg.norm(b.Q)) + b.kg
    return abs(float(v @ b.Q)) <= threshold * scale if scale > 0 else True


def _cross_bifurcation(sol: _Solver, a: State, b: State, outputs, chain: Chain,
                       warnings: list[str], critical: list[float]) -> State | None:
    """The path went from stable ``a`` through a bifurcation to unstable ``b``: locate the critical
    load factor, then leave the unstable branch at ``b``'s load factor for a stable one."""
    lo, hi = a, b
    mu_lo, _ = _min_eig(lo.K)
    mu_hi, _ = _min_eig(hi.K)
    side = 0          # Illinois bookkeeping
    for _ in range(100):
        if hi.lam - lo.lam <= 1e-13 * max(1.0, hi.lam):
            break
        t = mu_lo / (mu_lo - mu_hi) if mu_lo != mu_hi else 0.5
        t = min(max(t, 0.01), 0.99)
        lam_m = lo.lam + t * (hi.lam - lo.lam)
        m = sol.newton(lo.q + t * (hi.q - lo.q), lam_m)
        if m is None:
            break
        mu_m, _ = _min_eig(m.K)
        if mu_m == 0.0:
            lo = hi = m
            break
        if mu_m > 0:
            lo, mu_lo = m, mu_m
            if side == -1:
                mu_hi *= 0.5
            side = -1
        else:
            hi, mu_hi = m, mu_m
            if side == 1:
                mu_lo *= 0.5
            side = 1
        if abs(mu_m) <= 1e-13 * max(1.0, float(np.max(np.abs(m.K)))):
            break
    m_lo, _ = _min_eig(lo.K)
    m_hi, _ = _min_eig(hi.K)
    lam_c = lo.lam if m_lo == m_hi else lo.lam + m_lo / (m_lo - m_hi) * (hi.lam - lo.lam)

    # leave the unstable branch at b's load factor: descend from b +- eps v
    _, v = _min_eig(b.K)
    eps = 1e-3 * max(1.0, float(np.linalg.norm(b.q)))
    candidates = []
    for sign in (1.0, -1.0):
        s = sol.newton(b.q + sign * eps * v, b.lam, descent=True,
                       max_iterations=20 * sol.max_iterations)
        if s is not None and _cholesky_ok(s.K):
            candidates.append(s)
    if not candidates:
        return None
    if len(candidates) == 1:
        choice, why = candidates[0], BUCKLING_SIDES[0]
    else:
        s1, s2 = candidates
        Pscale = max(abs(s1.Pi), abs(s2.Pi), abs(s1.U), abs(s2.U), 1e-300)
        if abs(s1.Pi - s2.Pi) > 1e-9 * Pscale:
            choice = s1 if s1.Pi < s2.Pi else s2
            why = BUCKLING_SIDES[1]
        else:
            def mean_row(s, row):
                if not outputs:
                    return 0.0
                return float(np.mean([chain.point_j(ref, s.q)[0][row] for ref in outputs]))
            y1, y2 = mean_row(s1, 1), mean_row(s2, 1)
            if abs(y1 - y2) > 1e-9 * max(abs(y1), abs(y2), 1e-300):
                choice = s1 if y1 > y2 else s2
                why = BUCKLING_SIDES[2]
            else:
                choice = s1 if mean_row(s1, 2) >= mean_row(s2, 2) else s2
                why = BUCKLING_SIDES[3]
    critical.append(float(lam_c))
    warnings.append(buckling_warning(lam_c, why))
    return choice


# Why the solve took the side it did past a bifurcation (the compiled solver reports the index
# plus one: chain_solver.h's FG_BUCKLING_*).
BUCKLING_SIDES = ("the only stable side found",
                  "the side of lower potential energy",
                  "symmetric: the side of larger world y, by convention",
                  "symmetric: the counter-clockwise side, by convention")


def buckling_warning(lam_c: float, why: str) -> str:
    """The warning of a bifurcation crossed at critical load factor ``lam_c`` (both solvers')."""
    return (f"buckling: bifurcation at critical load factor {lam_c:.10g} (the stiffness "
            f"matrix lost positive definiteness); continued on the stable post-buckled "
            f"branch ({why})")


def snap_warning(lam: float) -> str:
    """The warning of a path that ends at a limit point near load factor ``lam`` (both solvers')."""
    return (f"snap-through: the equilibrium path ends at a limit point near load factor "
            f"{lam:.6g}; the solve continued from the stable equilibrium it jumps to")


def compliance(system: System, st: State, ref: str) -> np.ndarray:
    """3x3 compliance d(x, y, angle)/d(fx, fy, moment) of point ``ref`` at state ``st``:
    J K^-1 J^T with the full stiffness (geometric stiffness of every load included)."""
    _restore_kinematics(system.chain, st)
    J = system.chain.point_j(ref, st.q)[1]
    try:
        X = scipy.linalg.solve(st.K, J.T, assume_a="sym")
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgError):
        return np.full((3, 3), np.nan)
    C = J @ X
    return 0.5 * (C + C.T)


def _restore_kinematics(chain: Chain, st: State) -> None:
    """Make the chain's cached poses and Jacobians those of ``st`` (saved when it was
    evaluated; the same numbers as evaluating st.q again), if they are not current."""
    if st.parts is not None and chain._light_key != st.parts[-1][0]:
        snap = st.parts[-1]
        if snap[0] == st.q.tobytes():
            chain.light_restore(snap)


def _result(scene, chain, system, st: State, outputs, info, iterations, warnings, critical) -> Result:
    _restore_kinematics(chain, st)
    stable = _cholesky_ok(st.K)
    if not stable:
        warnings.append(UNSTABLE)
    points = {ref: point_result(ref, chain.point_j(ref, st.q)[0], compliance(system, st, ref),
                                warnings) for ref in outputs}
    q = {name: [float(x) for x in v] for name, v in chain.split(st.q).items()}
    res = Result(scene=scene.name, converged=True, stable=stable, iterations=iterations,
                 model=info, q=q, points=points, warnings=warnings, reason=None,
                 critical_load_factors=critical, load_factor=1.0, energy=st.U, residual=st.rel)
    # the chain and final state, for the validity check to reuse (not a Result field)
    res._final = (chain, system, st)
    return res


__all__ = ["solve", "System", "State", "compliance"]
