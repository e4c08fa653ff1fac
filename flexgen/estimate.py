"""The error estimate every chain-model answer carries: the model checked by a richer one.

``Estimator(solver)`` prepares, once per (scene, models), the *richer* model of every flexure
(its own core ``Problem`` and ``Workspace``, reading the answer's load and tension arrays) and
the linear map of the answer's q to the richer coordinates; ``Estimator.estimate(solver)`` makes
one core call, ``fg_estimate`` (chain_solver.h): plain Newton on the richer model from the
answer's mapped q until it is seen to converge (usually two evaluations: a second step at most
a tenth of the first), and, per output point p, the difference of the answer to the richer
equilibrium (its pose linearized along the last step, its compliance at the last state):

    pose:        max(|r_p - r_p,rich| / L_p, |theta_p - theta_p,rich|)   (L_p: the summed length
                 of the flexures between the base and p, ``select.length_scales``)
    compliance:  ||C_p - C_p,rich||_2 / ||C_p,rich||_2, spectral norm, the larger of the 2x2
                 position block's and the 3x3's (d(x, y, angle)/d(fx, fy, moment), its angle
                 row and column times L_p: every entry then in the position block's units)

Where the two models' load paths may part (the answer's path snapped through, or a point's pose
estimate is above ``PATH_CHECK``), the richer model is solved along its own load path instead,
and the answer warns where it may be on the wrong side of a snap-through
(``Estimator._branch_warning``).
Where Newton from the answer does not converge (a coarse answer far from the richer
equilibrium: cc and prb under large loads), or meets an indefinite stiffness or a state it
cannot evaluate, the richer model is solved instead (``fg_solve`` warm-started from the answer:
Newton, else its own load path) and the same differences are taken at its equilibrium. One
evaluation (the step from the answer alone, the compliance at the answer's mapped q) is not
enough: its compliance is off by the order of the difference itself, and on the honesty suite
(``python benchmarks/estimate.py --honesty --seeds 0,1,2,3,4``) it covered 93.2 % of the answers
with a worst true/estimate of 4.3, against 100 % and 0.88 with the converged state (0.81
since the compliance estimate also covers the 3x3 compliance).

The richer model (``richer``), per flexure:

    scm N (N <= 6)  -> scm N + 2; q padded with zeros. N is compared with
                       N + 2, not N + 1: Legendre truncation errors come in even/odd plateaus
                       (docs/selection.md). Spectral convergence makes N + 2 much more accurate,
                       so the difference is N's error (the margin ``SCM_FACTOR`` covers a
                       contraction of up to 1/3 per two modes: err(N) <= d / (1 - rho)).
    scm 7, 8        -> scm N - 2 (no richer kernel ships): the difference then measures the
                       error of N - 2, which bounds N's (more modes are never worse); the
                       estimate is conservative by about one convergence step (scm7 gets
                       scm5's estimate, scm8 scm6's; margin ``POORER_FACTOR``). Beside
                       flexures of other models, the two groups are checked apart and their
                       estimates added (``SplitEstimator``).
    cc (scm 1), prb -> scm 3 (q: the tip angle; the rest zero). Both are far poorer than scm3
                       (margin ``COARSE_FACTOR``).
    fem n (n > 4)   -> fem 2n (the joint rotations are the curvature at the cell midpoints
                       times h: interpolated); fem converges as 1/n^2, so
                       err(n) = 4/3 |x_n - x_2n| (Richardson), times ``FEM_FACTOR``'s margin.
                       In a scene that also has flexures of other models: scm 8, as below
                       (``mixes_fem``).
    fem n (n <= 4)  -> scm 8 (q: the Legendre polynomial through the joints' curvatures), margin
                       ``COARSE_FACTOR``: so few elements are not in Richardson's range, and
                       near a limit load fem n and fem 2n are both far from it
                       (``FEM_REFINED``).

The richer smooth curvature models evaluate with the local Gauss kernels (``scmN_localG``:
few nodes, the error certified at each q, 0.5x to 0.2x the polynomial kernel's time for 3 to 8
modes; where the certificate fails, the Gauss kernel certified on 180 degrees), whatever kernel
the answer's model uses. Every smooth curvature flexure also adds its kernel's certified bounds
(the answer's and the richer model's: ``ERROR_BOUND L_i / L_p`` on the positions beyond it,
``2 JACOBIAN_ERROR_BOUND`` on the compliance), a floor below which the comparison cannot see,
and every estimate the answer's rounding (``ROUNDING_POSE``, ``ROUNDING_COMPLIANCE``): no
answer is claimed exact.

Each flexure's curvature (so its strain and stress) is estimated from the same richer
equilibrium, which ``fg_estimate`` also returns (``Estimate.rich_q``): the answer's curvature
profile against the richer model's on the same arc lengths, relative to the larger peak,
times the same margin, and for a smooth curvature or fem flexure at least its miss at its ends,
where equilibrium fixes the curvature (``end_floor``) (``CurvatureEstimates.of``, asked when
``Result.flexures`` is built). It is usually far larger than the pose's: the modes approximate
the curvature, the pose is its integral.

When the richer model finds no stable equilibrium (or an equilibrium with undefined
compliance), the estimate is inf and ``Estimate.warning`` says why. With several flexures the
largest margin of their pairs applies to the whole answer (the flexures of a chain interact).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple, cast

import numpy as np
from numpy.polynomial import legendre

from . import core
from .scene import Scene

# err(N) <= d + err(N + 2) <= d / (1 - rho) for a contraction rho per two modes: 1.5 covers
# rho <= 1/3 (measured: err(N) / d at most 1.12 on the suite of tests/test_estimate.py, at bends
# near 150 deg; typically 1.00)
SCM_FACTOR = 1.5
# scm N against scm N - 2 (N = 7, 8: no richer kernel): d = err(N) - err(N - 2), so
# err(N) <= rho / (1 - rho) d where err(N) = rho err(N - 2) with one sign; 2 covers rho <= 2/3
# (review: scm7's root curvature 0.64 of scm5's, 1.02 times its estimate at 1.5)
POORER_FACTOR = 2.0
# Richardson for O(h^2): err(n) = 4/3 d, times 1.25 for n before the asymptotic range
# (measured: err(n) / d = 1.333 for fem16 and fem32, at most 1.36 for fem4)
FEM_FACTOR = 4.0 / 3.0 * 1.25
# cc and prb against scm3, whose own error is far below theirs: err = d (1 + err(scm3) / d);
# 1.25 leaves room for prb answers whose error is small (measured: at most 1.10)
COARSE_FACTOR = 1.25
MAX_SCM = 8  # the richest smooth curvature kernel shipped
# fg_estimate's Newton may move a coordinate this many max_dq from the answer mapped to the
# richer model before it gives up for a solve of the richer model: cc and prb answers under
# large loads lie 0.5 to 1 from scm3's equilibrium in its higher modes (a cold solve of scm3
# each time, 5 to 9 times the answer's own solve, with 1 max_dq); Newton from there lands on the
# equilibrium the solve finds (the honesty suite of tests/test_estimate.py holds it to that)
REACH = 2.0
# Newton from the answer finds the richer equilibrium nearest the answer, which is the one on the
# richer model's own load path only where the two paths cannot part. Where they can, the richer
# model is solved along its own load path (from the unloaded state) instead:
# - the answer's path snapped through a limit point: a model whose limit load is lower than the
#   richer model's lands on the far branch, where the richer model also has an equilibrium that
#   Newton finds (fem16 just past its own limit, 0.3 % below the elastica's, was off by 2 rad
#   with an estimate of 4e-3);
# - a pose estimate is above PATH_CHECK: an answer that far from the richer equilibrium
#   may be on another branch of it (cc near a snap-through: off by 0.85 to 2.1 of L, estimated at
#   0.019 to 0.21). Such answers are coarse anyway: the richer model's solve is their cost.
PATH_CHECK = 1e-2
# What no comparison of two double-precision answers resolves, added to every estimate (pose,
# compliance) so that none claims an exact answer: an unloaded branch's pose is exact in every
# model, and its estimate was 0 where the answer is off by rounding (measured up to 1.3e-15 of
# L_p, fem on random trees; tests/test_estimate.py); a compliance J K^-1 J^T rounds to about
# cond(K) eps, and cond(K) is at most 1.5e2 over the honesty suite's answers (seeds 0-2, every
# model), so 1e-12 leaves a wide margin
ROUNDING_POSE, ROUNDING_COMPLIANCE = 1e-14, 1e-12
# the curvature's (relative to the flexure's largest |kappa|): kappa is a sum over q solved to
# the solver's tol
ROUNDING_CURVATURE = 1e-12
# An element chain whose joint turns by more than this (rad) does not resolve the curvature:
# fem n and fem 2n are then both off by about as much (fem4 and fem8 each 9 % low on a flexure
# bent 170 deg, a root joint of fem4 turning 2.2 rad), so their difference says nothing, and the
# curvature (stress) estimate is unknown (inf). Below it the comparison held on the review's
# scan (worst true/estimate 1.28, fem16 with joints of 0.68 rad; fem8 at 1.1-1.4 rad: 0.41-0.89)
FEM_COARSE_TURN = 1.5
# fem with fewer elements than this is checked against scm FEM_COARSE_REFERENCE, not fem 2n.
# Near a snap-through (0.9 to 0.9995 of the elastica's limit load, the review's family of 35
# answers) fem2, fem3 and fem4 against fem 4, 6, 8 covered 7 to 31 % of the pose answers (worst
# true/estimate 10.4, 35, 64, the worst unwarned 10.4, fem2): near the limit load fem n and
# fem 2n are both far from it. Against scm8 all of them (worst 0.8), and the review's cantilever
# and chain families (35 and 60 answers) stayed covered, stress included (worst 0.8). Not a
# poorer scm: at large bends its curvature is as far off as fem4's (scm3 8 %, scm5 4.3 %, fem4
# 9.6 % on a cantilever bent 170 deg; scm8 0.36 %), so the stress estimates would not hold
FEM_REFINED = 5
FEM_COARSE_REFERENCE = 8


class Estimate(NamedTuple):
    """Per output point (in ``Solver.outputs`` order) the pose and compliance estimates, and
    ``total``, the whole answer's: the largest of them (``estimate_of`` fills it). A named
    tuple, immutable: made on every answer, it costs a third of a frozen dataclass."""

    pose: list[float]
    compliance: list[float]
    warning: str | None = None
    total: float = 0.0
    # the richer model's equilibrium (its packed coordinates), for the curvature's estimate
    # (CurvatureEstimates.of); None where there is none
    rich_q: list[float] | None = None


def estimate_of(pose: list[float], compliance: list[float], warning: str | None = None) -> Estimate:
    """The Estimate of these per-point estimates, its total computed."""
    if pose and compliance:  # on every answer: max without its (slow) default keyword
        total = max(max(pose), max(compliance))
    else:
        total = max(max(pose, default=0.0), max(compliance, default=0.0))
    return Estimate(pose, compliance, warning, total)


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


def _fem_to_scm(n: int, m: int):
    """fem n joint rotations -> scm m modes: the Legendre polynomial of degree n - 1 through the
    joints' curvatures (kappa L = n q_i at x_i = 2 (i + 1/2) / n - 1), zero beyond; for n > m
    the least-squares one of degree m - 1 (a start for Newton on scm m, not an answer)."""
    x = 2.0 * (np.arange(n) + 0.5) / n - 1.0
    k = min(n, m)

    def f(q: np.ndarray) -> np.ndarray:
        out = np.zeros(m)
        out[:k] = legendre.legfit(x, q * n, k - 1)
        return out

    return f


def _tip_angle(n: int):
    def f(q: np.ndarray) -> np.ndarray:
        out = np.zeros(n)
        out[0] = float(q.sum()) if q.size else 0.0
        return out

    return f


def refined_fem(model: Any) -> bool:
    """A fem model checked against fem 2n (Richardson) where its scene lets it be."""
    return getattr(model, "kind", None) == "fem" and int(model.n_dof) >= FEM_REFINED


def mixes_fem(models: Iterable[Any]) -> bool:
    """Whether refined fem flexures share the scene with flexures of another model. fem 2n's
    own error is a quarter of fem n's, the richer smooth curvature models' next to none of
    theirs: where a scene mixes the two, the answer's errors from its flexures may cancel at a
    point while fem 2n's error there does not, and the difference then understates the
    answer's error whatever the margin (review: fem8 with scm2 and cc, a pose 1.26 times its
    estimate, a scm6 flexure's stress 2.4 times). In such a scene every fem flexure is checked
    against scm FEM_COARSE_REFERENCE instead, so that every richer model is far richer than its
    flexure's: the difference is the answer's error, cancelled or not."""
    refined = [refined_fem(m) for m in models]
    return any(refined) and not all(refined)


def richer(model: Any, mixed: bool = False) -> tuple[Any, Any, float, str]:
    """(richer model, map of q to its coordinates, factor, label) for one flexure model;
    ``mixed``: its scene ``mixes_fem`` (a refined fem flexure is then checked against scm
    FEM_COARSE_REFERENCE)."""
    kind = getattr(model, "kind", None)
    if kind == "scm":
        from .models.scm import SCMModel

        n = int(model.n_dof)
        if n == 1:
            m = SCMModel(model.length, model.EI, 3, "local", name=model.name)
            return m, _scm_pad(3), COARSE_FACTOR, "scm3"
        if n + 2 <= MAX_SCM:
            m = SCMModel(model.length, model.EI, n + 2, "local", name=model.name)
            return m, _scm_pad(n + 2), SCM_FACTOR, f"scm{n + 2}"
        m = SCMModel(model.length, model.EI, n - 2, "local", name=model.name)
        return m, _scm_pad(n - 2), POORER_FACTOR, f"scm{n - 2}"
    if kind == "prb":
        from .models.scm import SCMModel

        m = SCMModel(model.length, model.EI, 3, "local")
        return m, _tip_angle(3), COARSE_FACTOR, "scm3"
    if kind == "fem":
        from .models.fem import FEMModel

        n = int(model.n_dof)
        if n < FEM_REFINED or mixed:
            from .models.scm import SCMModel

            k = FEM_COARSE_REFERENCE
            m = SCMModel(model.length, model.EI, k, "local")
            return m, _fem_to_scm(n, k), COARSE_FACTOR, f"scm{k}"
        fine = FEMModel(model.length, model.EI, 2 * n)
        return fine, _fem_refine(n, 2 * n), FEM_FACTOR, f"fem{2 * n}"
    raise ValueError(f"no richer model for {model!r}")


def _kernel_bounds(model: Any) -> tuple[float, float]:
    """(position bound / length, compliance bound) of a smooth curvature model's kernels (the
    largest of its local, polynomial and Gauss kernels: any may evaluate the answer)."""
    if getattr(model, "kind", None) != "scm":
        return 0.0, 0.0
    mods = [k for k in (model.local, model.poly, model.gauss) if k is not None]
    pos = max(float(k.ERROR_BOUND) for k in mods)
    jac = max(float(k.JACOBIAN_ERROR_BOUND) for k in mods)
    return pos, 2.0 * jac


def curvature_difference(s: np.ndarray, kappa: np.ndarray, other: Any, other_q: Any) -> float:
    """max |kappa - kappa_other| over the profile's arc lengths ``s`` (its grid and its model's
    ``curvature_extremes``: flexgen.stress), relative to the larger peak |kappa| of the two (0
    when both are 0): the relative difference of two models' curvature, so of their strains
    and stresses."""
    kappa_other = np.asarray(other.curvature(np.asarray(other_q, dtype=float), s), dtype=float)
    peak = max(float(np.max(np.abs(kappa))), float(np.max(np.abs(kappa_other))))
    d = float(np.max(np.abs(kappa - kappa_other)))
    return d / peak if peak > 0.0 else 0.0


class CurvatureEstimates(NamedTuple):
    """What the curvature (so stress) estimates of an answer read of its Estimator: the richer
    models and their coordinates, the margin, the fem element lengths; no workspace (a Result
    keeps this, not the Estimator and the two workspaces it holds: review)."""

    rich_models: dict[str, Any]
    rich_slices: dict[str, slice]
    factor: float
    fem_h: dict[str, float]
    # the flexures whose profile is held to the curvature equilibrium fixes at its ends
    # (end_floor): smooth curvature (scm, cc) and fem (its end values are extrapolated over half
    # a cell: review, fem5 at a 122 deg bend 1.58 times its estimate without it)
    end_checked: frozenset[str] = frozenset()

    def of(
        self,
        est: Estimate,
        stresses: dict[str, Any],
        ends: Mapping[str, tuple[float, float]] | None = None,
    ) -> dict[str, float]:
        """Per flexure of ``stresses`` (``flexgen.stress.FlexureStress``: the answer's curvature
        profile), the estimated error of that profile relative to its largest |kappa| (and so of
        its largest strain and stress, which are kappa times constants): factor x the relative
        difference to the richer model's profile at its equilibrium (``est.rich_q``) on the same
        arc lengths (``curvature_difference``), plus ``ROUNDING_CURVATURE``; inf where the
        richer model has no equilibrium, and for a fem chain whose joint turns by more than
        ``FEM_COARSE_TURN`` (too coarse to resolve the curvature). ``ends``: {flexure: kappa at
        its root and tip by equilibrium} (``statics.end_curvatures``): a smooth curvature or fem
        profile's estimate is at least its miss there (``end_floor``)."""
        out: dict[str, float] = {}
        for name, st in stresses.items():
            rich: Any = self.rich_models.get(name)
            if not hasattr(rich, "curvature"):
                continue
            if est.rich_q is None:
                out[name] = math.inf
                continue
            h = self.fem_h.get(name)
            if h is not None and float(np.max(np.abs(st.curvature))) * h > FEM_COARSE_TURN:
                out[name] = math.inf  # the chain does not resolve the curvature
                continue
            rq = est.rich_q[self.rich_slices[name]]
            d = self.factor * curvature_difference(st.s, st.curvature, rich, rq)
            if ends is not None and name in ends and name in self.end_checked:
                d = max(d, end_floor(st.curvature, ends[name]))
            out[name] = d + ROUNDING_CURVATURE
        return out


def end_floor(kappa: np.ndarray, ends: tuple[float, float]) -> float:
    """The larger miss of a curvature profile ``kappa`` (root first, tip last) at its two ends
    against the curvature equilibrium puts there (M / EI: ``statics.end_curvatures``), relative
    to the largest |kappa| of the three: a lower bound on the profile's error. The smooth
    curvature modes do not meet the natural end condition exactly, and where a flexure's largest
    curvature sits at an end (a tip moment) the richer model's difference missed it (review:
    scm4 under a tip moment 1.26 times its estimate, scm5 1.30)."""
    peak = max(float(np.max(np.abs(kappa))), abs(ends[0]), abs(ends[1]))
    miss = max(abs(float(kappa[0]) - ends[0]), abs(float(kappa[-1]) - ends[1]))
    return miss / peak if peak > 0.0 else 0.0


class Estimator:
    """The richer model of a prepared ``Solver``'s scene and models, prepared once: its
    ``Problem`` (sharing the answer's load and tension arrays), a ``Workspace``, the q map and
    the per-point scales and floors, and the buffer ``fg_estimate`` writes into."""

    def __init__(self, solver: Any, only: frozenset[str] | None = None):
        """``only``: the flexures made richer (the rest keep their own model: the difference
        is then theirs alone; ``SplitEstimator``); None: every flexure."""
        from .models.registry import build_models
        from .problem import Problem, Workspace

        scene = solver.scene
        self.scene = scene
        self.order = list(solver.problem.flexure_order)
        rich: dict[str, Any] = {}
        self.maps: dict[str, Any] = {}
        factors = []
        labels = {}
        mixed = mixes_fem(solver.models.values())
        for name, m in solver.models.items():
            if only is not None and name not in only:
                rich[name], self.maps[name] = m, _scm_pad(int(m.n_dof))  # itself, q as it is
                continue
            r, f, fac, lab = richer(m, mixed)
            rich[name], self.maps[name], labels[name] = r, f, lab
            factors.append(fac)
        self.labels = labels
        self.rich_models = rich
        # each fem flexure's element length, where fem 2n checks it: its joint turns by about
        # |kappa| h (FEM_COARSE_TURN; scm FEM_COARSE_REFERENCE, which checks fewer elements,
        # resolves the curvature at any turn)
        self._fem_h = {
            name: float(m.length) / int(m.n_dof)
            for name, m in solver.models.items()
            if refined_fem(m) and not mixed and name in labels
        }
        # the poorest pair decides the margin (flexures of a chain interact)
        self.factor = max(factors, default=1.0)
        base = solver.problem
        self.problem = rp = Problem(scene, build_models(scene, rich), solver.settings)
        self.workspace = rw = Workspace(rp)
        # the loads and tensions are the answer's own arrays (Solver.run writes them in place):
        # nothing to copy per estimate
        rp.struct.load, rp.struct.tension = base.struct.load, base.struct.tension
        self._base = base  # what those pointers point into
        self.outputs = list(base.outputs)
        assert list(rp.outputs) == self.outputs  # the same scene: the same points, in order
        self.n = len(self.outputs)
        # the q map, linear in q: one matrix from the answer's packed q to the richer one's
        src = base.chain.slices
        dst = rp.chain.slices
        nb, nr = solver.workspace.q.size, rw.q.size
        T = np.zeros((nr, nb))
        for name, f in self.maps.items():
            s, d = src[name], dst[name]
            k = s.stop - s.start
            T[d, s] = np.column_stack([f(np.eye(k)[j]) for j in range(k)])
        self.T = np.ascontiguousarray(T)
        self._identity = np.eye(max(nr, 1))
        refs = self.outputs
        scales = length_scales(scene, refs) if scene.flexures and refs else {}
        self.scales = [float(scales[r]) for r in refs]
        self._scale = np.array(self.scales or [1.0])
        # the floors fg_estimate adds: each point's position floor (rounding, and the kernel
        # bounds, which add along the path), then the compliance floor (rounding and the
        # largest kernel bound)
        self._floors = floors = np.full(len(refs) + 1, ROUNDING_POSE)
        floors[-1] = ROUNDING_COMPLIANCE
        for name, m in solver.models.items():
            a = _kernel_bounds(m)
            b = _kernel_bounds(rich[name])
            floors[-1] = max(floors[-1], ROUNDING_COMPLIANCE + a[1] + b[1])
            L = scene.flexure(name).length
            for i, ref in enumerate(refs):
                body, _ = scene.resolve_point(ref)
                if body != "base" and name in scene.flexure_path(_path_owner(scene, body)):
                    floors[i] += (a[0] + b[0]) * L / self.scales[i]
        self.rich_label = ", ".join(sorted(set(labels.values())))
        # fg_estimate's output (2 per point, the total, the richer q) and every pointer it takes,
        # made once
        self.out = np.zeros(2 * self.n + 1 + nr)  # then the richer equilibrium's q
        self.rich_slices = dict(dst)
        double_ptr = core.double_ptr
        self._args = (
            rp.struct,
            double_ptr(self.T),
            nb,
            double_ptr(solver.workspace.q),
            double_ptr(solver.workspace.pose),
            double_ptr(solver.workspace.compliance),
            double_ptr(self._scale),
            double_ptr(self._floors),
            self.factor,
            REACH * solver.settings.max_dq,
            rw.work_ptr,
            rw.iwork_ptr,
            double_ptr(self.out),
        )
        end_checked = frozenset(  # (only the flexures made richer: SplitCurvatureEstimates)
            n
            for n, m in solver.models.items()
            if getattr(m, "kind", "") in ("scm", "fem") and n in labels
        )
        self.curvature = CurvatureEstimates(
            rich, self.rich_slices, self.factor, self._fem_h, end_checked
        )
        self._solved_args = (
            rp.struct,
            double_ptr(self._identity),
            nr,
            double_ptr(rw.q),
        ) + self._args[4:]
        self._ws = solver.workspace

    def estimate(self, solver: Any) -> Estimate:
        """The estimate of the answer now in ``solver.workspace`` (a solved equilibrium).

        Written for speed (it runs after every flexgen.solve): one core call (``fg_estimate``:
        the q map, Newton from the answer on the richer model, the per-point differences, the
        margin and floors on them and their largest) with arguments made once. When the
        richer model's equilibrium is not within Newton's reach of the answer
        (``FG_ESTIMATE_FAR``), the richer model is solved, warm-started from the answer, and
        the same differences taken at its equilibrium (so also when the step finds no stable
        state or cannot evaluate the richer model)."""
        if solver.workspace is not self._ws:  # the pointers name this solver's answer
            raise ValueError("Estimator.estimate: not the solver it was prepared for")
        status = _fg_estimate(*self._args)
        n = self.n
        warning = None
        if status == _ESTIMATED:
            d = self.out.tolist()  # per point (pose, compliance), the total, the richer q
            # the paths may part (PATH_CHECK): a snap-through on the answer's path, or a pose
            # estimate above PATH_CHECK (the compliance's does not count: a coarse model's
            # compliance may be far off on the right branch, cc's under an end moment)
            snap = _last_snap(solver.workspace) if solver.workspace.answer.ncritical else None
            if snap is not None or max(d[0 : 2 * n : 2], default=0.0) > PATH_CHECK:
                status = self._solve_richer(solver, cold=True)
                if status == _ESTIMATED:
                    d = self.out.tolist()
                    warning = self._branch_warning(snap, _last_snap(self.workspace))
        elif status != _UNDEFINED:
            # not within Newton's reach, or no stable state or no evaluation there: what the
            # richer model's own solve finds decides
            status = self._solve_richer(solver)
            d = self.out.tolist()
        if status == _ESTIMATED:  # the estimates (pose, compliance) per point, then the total
            # tuple.__new__ with every field given: 60 % of Estimate(...)'s cost
            return _new_tuple(
                Estimate, (d[0 : 2 * n : 2], d[1 : 2 * n : 2], warning, d[2 * n], d[2 * n + 1 :])
            )
        why = _WHY.get(status, "found no equilibrium")
        return estimate_of(
            [math.inf] * n,
            [math.inf] * n,
            f"error estimate: the richer model ({self.rich_label}) {why} near this answer, "
            f"so its error is unknown",
        )

    def _branch_warning(self, snap: float | None, rich_snap: float | None) -> str | None:
        """The warning when the richer model's load path snapped through (at load factor
        ``rich_snap``) and the answer's did not (``snap`` None: the two models disagree on
        whether the load is past a limit point), or did too but the applied load is within the
        estimated error of its limit load (factor x the two limit loads' difference): either
        way the structure itself may not snap through yet, and the estimate, taken on the far
        branch, would not see it. None when the richer model did not snap (its equilibrium, on
        the near branch, already makes the estimate large) or both are clearly past the limit."""
        if rich_snap is None:
            return None
        if snap is not None and snap + self.factor * abs(snap - rich_snap) < 1.0:
            return None
        mine = "no limit point" if snap is None else f"a limit point at load factor {snap:.6g}"
        return (
            f"near a snap-through: this model's load path passes {mine}, the richer model's "
            f"({self.rich_label}) one at {rich_snap:.6g}; the structure may not snap through "
            f"yet, and this answer may be on the wrong branch"
        )

    def _solve_richer(self, solver: Any, cold: bool = False) -> int:
        """The richer model solved (warm-started from the answer: Newton, else its own load
        path; ``cold``: along its own load path from the unloaded state), then ``fg_estimate``
        at its equilibrium (the identity map: the step is ~0)."""
        lib = core.lib
        rp, rw = self.problem, self.workspace
        if not cold:
            np.matmul(self.T, solver.workspace.q, out=rw.q0[: rw.q.size])
            rp.struct.q0 = rw.q0_ptr
        status = lib.fg_solve(rp.struct, rw.work_ptr, rw.iwork_ptr, rw.answer)
        rp.struct.q0 = core.ffi.NULL
        if status != core.SOLVED:
            return _NO_EQUILIBRIUM
        if not rw.answer.stable:
            return int(lib.FG_ESTIMATE_UNSTABLE)
        status = lib.fg_estimate(*self._solved_args)
        return _NO_EQUILIBRIUM if status == lib.FG_ESTIMATE_FAR else int(status)


def _last_snap(ws: Any) -> float | None:
    """The load factor of the last snap-through (a limit point) on the load path of the answer
    in the workspace ``ws``; 1.0 when more critical events happened than were stored (one of
    them may be a snap-through); None when the path passed no limit point."""
    a = ws.answer
    if not a.ncritical:
        return None
    stored = min(a.ncritical, a.max_critical)
    if a.ncritical > stored:
        return 1.0
    snaps = ws.critical[:stored][ws.critical_kind[:stored] == _SNAP_THROUGH]
    return float(snaps.max()) if snaps.size else None


_fg_estimate = core.lib.fg_estimate
_SNAP_THROUGH: int = core.SNAP_THROUGH
_new_tuple = tuple.__new__
_SOLVED: int = core.SOLVED
_ESTIMATED: int = core.lib.FG_ESTIMATED
_UNDEFINED: int = core.lib.FG_ESTIMATE_UNDEFINED
_NO_EQUILIBRIUM = -1  # the richer solve found none
_WHY = {
    _NO_EQUILIBRIUM: "found no equilibrium",
    core.lib.FG_ESTIMATE_NO_EVALUATION: "cannot be evaluated",
    core.lib.FG_ESTIMATE_UNSTABLE: "found no stable equilibrium",
    core.lib.FG_ESTIMATE_UNDEFINED: "has an undefined pose or compliance",
}


class SplitEstimator:
    """The estimate of a scene whose flexures are not all checked against a richer model: scm7
    and scm8 against scm N - 2 (no richer kernel ships), which is poorer, beside flexures
    checked against far richer ones. One Estimator per group (``estimate_groups``), each making
    only its flexures richer; the estimates add per point. A difference over the whole scene
    at once could not be trusted: the answer's errors from its flexures may cancel at a point
    while scm N - 2's own error, far larger than scm N's, does not (review: scm7 with fem16, a
    pose 4.9 times its estimate; scm8 with scm4, a compliance 3.5 times; scm5 with scm7, whose
    richer models were the same scene with its flexures swapped). By groups, each difference is
    that group's error alone (or, for scm N, scm N - 2's, which bounds it), and their sum
    bounds the answer's: one more core call than the Estimator's."""

    def __init__(self, solver: Any, groups: list[frozenset[str]]):
        self.parts = [Estimator(solver, only=g) for g in groups]
        spans, offset = [], 0  # each part's richer coordinates, one after the other in rich_q
        for part in self.parts:
            spans.append((offset, offset + part.workspace.q.size))
            offset += part.workspace.q.size
        self.curvature = SplitCurvatureEstimates(
            tuple(part.curvature for part in self.parts), tuple(spans)
        )

    def estimate(self, solver: Any) -> Estimate:
        """The parts' estimates added per point (inf where one is: its warning says why)."""
        parts = [part.estimate(solver) for part in self.parts]
        failed = next((e for e in parts if e.rich_q is None), None)
        if failed is not None:
            return failed
        pose = [sum(v) for v in zip(*(e.pose for e in parts))]
        compliance = [sum(v) for v in zip(*(e.compliance for e in parts))]
        warning = next((e.warning for e in parts if e.warning), None)
        rich_q = [x for e in parts for x in cast(list, e.rich_q)]
        return estimate_of(pose, compliance, warning)._replace(rich_q=rich_q)


class SplitCurvatureEstimates(NamedTuple):
    """The curvature (stress) estimates of a SplitEstimator's answer: per flexure, the sum of
    its estimates from every part. In the part that makes it richer, its own model's error; in
    the others, where it keeps its model, how the other group's error moves its profile
    (review: counting only its own part, a scm7 flexure beside a cc one was 2360 times its
    estimate)."""

    parts: tuple[CurvatureEstimates, ...]
    spans: tuple[tuple[int, int], ...]  # each part's slice of the Estimate's rich_q

    def of(
        self,
        est: Estimate,
        stresses: dict[str, Any],
        ends: Mapping[str, tuple[float, float]] | None = None,
    ) -> dict[str, float]:
        out: dict[str, float] = {}
        for part, (a, b) in zip(self.parts, self.spans):
            sub = est._replace(rich_q=None if est.rich_q is None else est.rich_q[a:b])
            for name, d in part.of(sub, stresses, ends).items():
                out[name] = out.get(name, 0.0) + d
        return out


def poorer_reference(model: Any) -> bool:
    """A smooth curvature model with no richer kernel shipped (``richer``: scm N - 2)."""
    return getattr(model, "kind", None) == "scm" and int(model.n_dof) + 2 > MAX_SCM


def estimate_groups(models: Mapping[str, Any]) -> list[frozenset[str]] | None:
    """The flexures checked against poorer models (scm7, scm8) and the others, where a scene
    has both (``SplitEstimator``); None where one difference over the scene holds."""
    poorer = frozenset(n for n, m in models.items() if poorer_reference(m))
    rest = frozenset(models) - poorer
    return [rest, poorer] if poorer and rest else None


def estimator_of(solver: Any) -> Estimator | SplitEstimator:
    """The solver's Estimator (a SplitEstimator where ``estimate_groups`` splits its scene),
    prepared on first use and kept on the solver (from outside, ``Solver.estimator()``)."""
    est = solver._estimator
    if est is None:
        groups = estimate_groups(solver.models)
        est = solver._estimator = (
            Estimator(solver) if groups is None else SplitEstimator(solver, groups)
        )
    return est


def estimate_answer(solver: Any, status: int) -> Estimate:
    """The estimate of the answer a ``solver.run`` just left in its workspace (``status``: what
    ``run`` returned); no answer: an empty Estimate (its Result says inf)."""
    if status != _SOLVED:
        return estimate_of([], [])
    est = solver._estimator
    if est is None:
        try:
            est = estimator_of(solver)
        except ValueError as exc:  # a flexure model with no richer model (a user's own)
            n = len(solver.problem.outputs)
            return estimate_of([math.inf] * n, [math.inf] * n, f"error estimate: unknown ({exc})")
    return est.estimate(solver)
