"""The error estimate every chain-model answer carries: the model checked by a richer one.

``Estimator(solver)`` prepares, once per (scene, models), the *richer* model of every flexure and
its own prepared ``Solver``; ``Estimator.estimate(solver)`` solves the richer model warm-started
from the answer in ``solver.workspace`` (Newton at the full load from the answer's q mapped to
the richer coordinates; the core falls back to a full solve when that does not land on a stable
equilibrium close by) and measures, per output point p, the difference of the two answers:

    pose:        max(|r_p - r_p,rich| / L_p, |theta_p - theta_p,rich|)   (L_p: the summed length
                 of the flexures between the base and p, ``select.length_scales``)
    compliance:  ||C_p - C_p,rich||_2 / ||C_p,rich||_2                    (2x2, spectral norm)

The richer model (``richer``), per flexure:

    scm N (N <= 6)  -> scm N + 2, the same kernel choice; q padded with zeros. N is compared with
                       N + 2, not N + 1: Legendre truncation errors come in even/odd plateaus
                       (docs/selection.md). Spectral convergence makes N + 2 much more accurate,
                       so the difference is N's error (the margin ``SCM_FACTOR`` covers a
                       contraction of up to 1/3 per two modes: err(N) <= d / (1 - rho)).
    scm 7, 8        -> scm N - 2 (no richer kernel ships): the difference then measures the
                       error of N - 2, which bounds N's (more modes are never worse); the
                       estimate is conservative by about one convergence step (scm7 gets
                       scm5's estimate, scm8 scm6's).
    cc (scm 1), prb -> scm 3 (q: the tip angle; the rest zero). Both are far poorer than scm3
                       (margin ``COARSE_FACTOR``).
    fem n           -> fem 2n (the joint rotations are the curvature at the cell midpoints
                       times h: interpolated); fem converges as 1/n^2, so
                       err(n) = 4/3 |x_n - x_2n| (Richardson), times ``FEM_FACTOR``'s margin.

Every smooth curvature flexure also adds its kernel's certified bounds (the answer's and the
richer model's: ``ERROR_BOUND L_i / L_p`` on the positions beyond it, ``2 JACOBIAN_ERROR_BOUND``
on the compliance), a floor below which the comparison cannot see.

When the richer model finds no stable equilibrium (or an equilibrium with undefined
compliance), the estimate is inf and ``Estimate.warning`` says why. With several flexures the
largest margin of their pairs applies to the whole answer (the flexures of a chain interact).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import core
from .scene import Scene

# err(N) <= d + err(N + 2) <= d / (1 - rho) for a contraction rho per two modes: 1.5 covers
# rho <= 1/3 (measured: err(N) / d at most 1.12 on the suite of tests/test_estimate.py, at bends
# near 150 deg; typically 1.00)
SCM_FACTOR = 1.5
# Richardson for O(h^2): err(n) = 4/3 d, times 1.25 for n before the asymptotic range
# (measured: err(n) / d = 1.333 for fem16 and fem32, at most 1.36 for fem4)
FEM_FACTOR = 4.0 / 3.0 * 1.25
# cc and prb against scm3, whose own error is far below theirs: err = d (1 + err(scm3) / d);
# 1.25 leaves room for prb answers whose error is small (measured: at most 1.10)
COARSE_FACTOR = 1.25
MAX_SCM = 8  # the richest smooth curvature kernel shipped


@dataclass(frozen=True)
class Estimate:
    """Per output point (in ``Solver.outputs`` order) the pose and compliance estimates."""

    pose: list[float]
    compliance: list[float]
    warning: str | None = None

    @property
    def total(self) -> float:
        """The whole answer's estimate: the largest of every point's pose and compliance."""
        return max(max(self.pose, default=0.0), max(self.compliance, default=0.0))


def _path_owner(scene: Scene, body: str) -> str:
    """The body whose flexure path a point on ``body`` follows: the body itself (the base or a
    flexure), or the flexure a link is attached to."""
    if scene.body_kind(body) != "link":
        return body
    parent = scene.body_parent(body)
    assert parent is not None  # only the base has no parent
    return parent


def length_scales(scene: Scene, refs: Iterable[str]) -> dict[str, float]:
    """L_p for every point: the summed length of the flexures between the base and p (the
    longest flexure's length for a point on the base)."""
    longest = max(f.length for f in scene.flexures)
    out = {}
    for ref in refs:
        body, _ = scene.resolve_point(ref)
        path = scene.flexure_path(_path_owner(scene, body))
        out[ref] = sum(scene.flexure(n).length for n in path) or longest
    return out


def _scm_pad(n: int):
    def f(q: np.ndarray) -> np.ndarray:
        out = np.zeros(n)
        k = min(n, q.size)
        out[:k] = q[:k]
        return out

    return f


def _fem_refine(n: int, m: int):
    """fem n joint rotations -> fem m: q_i = h kappa(s_i) at the cell midpoints, interpolated."""
    s_n = (np.arange(n) + 0.5) / n
    s_m = (np.arange(m) + 0.5) / m

    def f(q: np.ndarray) -> np.ndarray:
        return np.interp(s_m, s_n, q * n) / m

    return f


def _tip_angle(n: int):
    def f(q: np.ndarray) -> np.ndarray:
        out = np.zeros(n)
        out[0] = float(q.sum()) if q.size else 0.0
        return out

    return f


def richer(model: Any) -> tuple[Any, Any, float, str]:
    """(richer model, map of q to its coordinates, factor, label) for one flexure model."""
    kind = getattr(model, "kind", None)
    if kind == "scm":
        from .models.scm import SCMModel

        n = int(model.n_dof)
        if n == 1:
            m = SCMModel(model.length, model.EI, 3, model.kernel, name=model.name)
            return m, _scm_pad(3), COARSE_FACTOR, "scm3"
        k = n + 2 if n + 2 <= MAX_SCM else n - 2
        m = SCMModel(model.length, model.EI, k, model.kernel, name=model.name)
        return m, _scm_pad(k), SCM_FACTOR, f"scm{k}"
    if kind == "prb":
        from .models.scm import SCMModel

        m = SCMModel(model.length, model.EI, 3, "auto")
        return m, _tip_angle(3), COARSE_FACTOR, "scm3"
    if kind == "fem":
        from .models.fem import FEMModel

        n = int(model.n_dof)
        fine = FEMModel(model.length, model.EI, 2 * n)
        return fine, _fem_refine(n, 2 * n), FEM_FACTOR, f"fem{2 * n}"
    raise ValueError(f"no richer model for {model!r}")


def _kernel_bounds(model: Any) -> tuple[float, float]:
    """(position bound / length, compliance bound) of a smooth curvature model's kernels (the
    larger of its polynomial and Gauss kernels: either may evaluate the answer)."""
    if getattr(model, "kind", None) != "scm":
        return 0.0, 0.0
    mods = [k for k in (model.poly, model.gauss) if k is not None]
    pos = max(float(k.ERROR_BOUND) for k in mods)
    jac = max(float(k.JACOBIAN_ERROR_BOUND) for k in mods)
    return pos, 2.0 * jac


class Estimator:
    """The richer model of a prepared ``Solver``'s scene and models, prepared once."""

    def __init__(self, solver: Any, solver_class: Any):
        scene = solver.scene
        self.scene = scene
        self.order = list(solver.problem.flexure_order)
        rich: dict[str, Any] = {}
        self.maps: dict[str, Any] = {}
        factors = []
        labels = {}
        for name, m in solver.models.items():
            r, f, fac, lab = richer(m)
            rich[name], self.maps[name], labels[name] = r, f, lab
            factors.append(fac)
        self.labels = labels
        # the poorest pair decides the margin (flexures of a chain interact)
        self.factor = max(factors, default=1.0)
        self.rich = solver_class(scene, rich, solver.settings)
        self.outputs = list(solver.problem.outputs)
        self.n = len(self.outputs)
        # the q map, linear in q: one matrix from the answer's packed q to the richer one's
        src = solver.problem.chain.slices
        dst = self.rich.problem.chain.slices
        T = np.zeros((self.rich.workspace.q0.size, solver.workspace.q.size))
        for name, f in self.maps.items():
            s, d = src[name], dst[name]
            k = s.stop - s.start
            T[d, s] = np.column_stack([f(np.eye(k)[j]) for j in range(k)])
        self.T = T
        refs = self.outputs
        scales = length_scales(scene, refs) if scene.flexures and refs else {}
        self.scales = [float(scales[r]) for r in refs]
        # kernel floors per point: positions add along the path, compliance takes the largest
        pos_floor = np.zeros(len(refs))
        comp_floor = 0.0
        for name, m in solver.models.items():
            a = _kernel_bounds(m)
            b = _kernel_bounds(rich[name])
            comp_floor = max(comp_floor, a[1] + b[1])
            L = scene.flexure(name).length
            for i, ref in enumerate(refs):
                body, _ = scene.resolve_point(ref)
                if body != "base" and name in scene.flexure_path(_path_owner(scene, body)):
                    pos_floor[i] += (a[0] + b[0]) * L / self.scales[i]
        self.pos_floor = pos_floor.tolist()
        self.comp_floor = comp_floor
        self.rich_label = ", ".join(sorted(set(labels.values())))

    def estimate(self, solver: Any) -> Estimate:
        """The estimate of the answer now in ``solver.workspace`` (a solved equilibrium).

        Written for speed (it runs after every flexgen.solve): the q map is one matrix product,
        the loads are copied in place, the core is called directly and the per-point
        differences are plain floats (2x2 spectral norms in closed form)."""
        ws = solver.workspace
        p = solver.problem
        rich = self.rich
        rp, rw = rich.problem, rich.workspace
        np.matmul(self.T, ws.q, out=rw.q0)
        rp.loads[...] = p.loads
        rp.tensions[...] = p.tensions
        rp.struct.q0 = rw.q0_ptr
        status = core.lib.fg_solve(rp.struct, rw.work_ptr, rw.iwork_ptr, rw.answer)
        n = self.n
        why = None
        if status != core.SOLVED:
            why = "found no equilibrium"
        elif not rw.answer.stable:
            why = "found no stable equilibrium"
        else:
            got, ref = ws.pose[:n].tolist(), rw.pose[:n].tolist()
            cg, cr = ws.compliance[:n].tolist(), rw.compliance[:n].tolist()
            s, two_pi = self.factor, 2 * math.pi
            pose_est, comp_est = [], []
            for i in range(n):
                (x, y, th), (xr, yr, thr) = got[i], ref[i]
                (a, b, _), (b2, c, _), _ = cg[i]
                (ar, br, _), (br2, cr_, _), _ = cr[i]
                dpos = math.hypot(x - xr, y - yr) / self.scales[i]
                dth = abs(math.remainder(th - thr, two_pi))
                nr = _sym_norm(ar, 0.5 * (br + br2), cr_)
                nd = _sym_norm(a - ar, 0.5 * (b + b2 - br - br2), c - cr_)
                rel = nd / nr if nr > 0 else nd
                if not (math.isfinite(dpos + dth) and math.isfinite(rel)):
                    why = "has an undefined pose or compliance"
                    break
                pose_est.append(s * max(dpos, dth) + self.pos_floor[i])
                comp_est.append(s * rel + self.comp_floor)
            else:
                return Estimate(pose_est, comp_est)
        return Estimate(
            [math.inf] * n,
            [math.inf] * n,
            f"error estimate: the richer model ({self.rich_label}) {why} near this answer, "
            f"so its error is unknown",
        )


def _sym_norm(a: float, b: float, c: float) -> float:
    """Spectral norm of the symmetric 2x2 [[a, b], [b, c]]: its largest |eigenvalue|."""
    return abs(0.5 * (a + c)) + math.hypot(0.5 * (a - c), b)


def estimator_of(solver: Any, solver_class: Any) -> Estimator:
    """The solver's Estimator, prepared on first use and kept on the solver; ``solver_class``
    prepares the richer model (``flexgen.solver.Solver``, passed in by it: this module does not
    import the solver; from outside, ``Solver.estimator()``)."""
    est = getattr(solver, "_estimator", None)
    if est is None:
        est = solver._estimator = Estimator(solver, solver_class)
    return est


def estimate_answer(solver: Any, status: int, solver_class: Any) -> Estimate:
    """The estimate of the answer a ``solver.run`` just left in its workspace (``status``: what
    ``run`` returned; ``solver_class``: see ``estimator_of``); no answer: an empty Estimate (its
    Result says inf)."""
    n = len(solver.problem.outputs)
    if status != core.SOLVED:
        return Estimate([], [])
    try:
        est = estimator_of(solver, solver_class)
    except ValueError as exc:  # a flexure model with no richer model (a user's own)
        return Estimate([math.inf] * n, [math.inf] * n, f"error estimate: unknown ({exc})")
    return est.estimate(solver)
