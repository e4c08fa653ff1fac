"""The fewest modes: choose, per flexure, the smooth curvature model that meets a tolerance.

``solve_to_tolerance(scene, T) -> Result`` (what ``flexgen solve --tol T``, ``[model] tolerance``
and ``flexgen select`` use) picks, for every flexure, the fewest Legendre modes N (1..8) and the
kernel (the scene's choice: for "auto" the local kernel where it certifies q, the polynomial
kernel within its range, the Gauss kernel past both) whose a-posteriori error estimate on the
reported output points is <= T,
and reports the estimate. ``select_models`` returns the whole ``Selection`` (choices, estimates,
solves used); ``estimate_table`` + ``choose`` split the work so a sweep over several T solves once.

Error measure (``error_components``), per output point p, against a reference answer:

    pose:        |r_p - r_p,ref| / L_p   and   |theta_p - theta_p,ref|       (L_p: the summed
                 length of the flexures between the base and p, the scene's length scale there)
    compliance:  ||C_p - C_p,ref||_2 / ||C_p,ref||_2   (spectral norm; the larger of the 2x2
                 position block's and the 3x3's, d(x, y, angle)/d(fx, fy, moment) with its angle
                 row and column times L_p, as flexgen.estimate measures it)

the error of an answer is the largest of these over all output points.

Estimator (see docs/selection.md). Let R be the *rich* model: every flexure at M modes (8, with the
polynomial kernel when the flexure stays within its range, else with the Gauss kernel). For a
flexure i and N < M, solve with N modes on i and every other flexure rich (warm-started from R's
equilibrium), and let d_i(N) = |answer(N) - answer(N + 2)| componentwise (comparing N with N + 2
skips the even/odd plateaus of the Legendre series). The truncation error of N is estimated by the
telescoping tail

    e_i(N) = d_i(N) + e_i(N + 2),     e_i(M) = d_i(M - 2),
    e_i(M - 1) = |answer(M - 1) - answer(M)| + e_i(M)

(each difference times the margin SAFETY): the rich model's error is stated as M - 2's, as every
answer's estimate of scm8 is (flexgen.estimate), not extrapolated. Each flexure also carries its kernel's certified bounds (pose: ERROR_BOUND L_i /
L_p; compliance: 2 JACOBIAN_ERROR_BOUND). The estimate of a choice (N_1, ...) is the componentwise
sum over flexures, and after solving the chosen models it is raised, if needed, to
|answer(chosen) - answer(R)| + the rich model's own estimate (this catches interaction between
flexures). The choice minimises the total number of modes subject to estimate <= T.
"""

from __future__ import annotations

import itertools
import math
import numbers
import re
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from . import kernels
from .codegen.spec import MAX_MODES  # the polynomial kernels shipped: scm1 .. scm8
from .estimate import _path_owner, length_scales  # noqa: F401  (select.length_scales)
from .result import Result
from .scene import Scene, SceneError, _fmt, check_limits

SAFETY = 1.05  # margin on every measured difference (see docs/selection.md)


class SelectionError(SceneError):
    """Bad input to the selection (a tolerance not in (0, 1), a flexure that is not "scm"): one
    line."""


def max_gauss_modes() -> int:
    """The most modes a shipped Gauss kernel has (8 in the checked-in set: every mode count)."""
    parts = [kernels.name_parts(n) for n in kernels.available()]
    return max((p[0] for p in parts if p is not None and p[1] == "gauss"), default=0)


def check_choosable(scene: Scene) -> None:
    """SelectionError unless a tolerance can choose every flexure's modes (every flexure
    ``scm``; an exact scene too: ``flexgen.solve`` checks before it takes the exact solver)."""
    for i, f in enumerate(scene.flexures):
        if f.model.kind != "scm":
            raise SelectionError(
                f"flexure[{i}].kind: a tolerance chooses smooth curvature modes, so every "
                f"flexure must be kind 'scm', got {f.model.kind!r} for {f.name!r}"
            )


def scene_tolerance(scene: Scene) -> float | None:
    """The tolerance a scene asks for (``[model] tolerance`` or a flexure's), None if none; with
    several, the smallest."""
    tols = [f.model.tolerance for f in scene.flexures if f.model.tolerance is not None]
    if scene.model.tolerance is not None:
        tols.append(scene.model.tolerance)
    return min(tols) if tols else None


def check_tolerance(tol: Any) -> float:
    """A relative tolerance: a number in (0, 1) (as ``flexgen solve --tol`` and a scene's
    ``tolerance``); 1 or more would accept any answer."""
    real = isinstance(tol, numbers.Real) and not isinstance(tol, bool)
    if not (real and 0 < tol < 1):  # (a NumPy float32 is a real number too: review)
        raise SelectionError(f"tolerance: must be a number in (0, 1), got {_fmt(tol)}")
    return float(tol)


# -- the error measure -------------------------------------------------------------------------

Outputs = dict  # ref -> (pose (3,), compliance (3, 3), or (2, 2) where only that is known)


def outputs_of(result: Result) -> Outputs | None:
    """The output points of a converged Result as {ref: (pose, compliance)}: the 3x3
    compliance, or the 2x2 where the 3x3 is not all known (the exact solver's: NaN beyond it)."""
    if not result.converged:
        return None

    def compliance(p: Any) -> np.ndarray:
        c3 = np.asarray(p.compliance3, float)
        return c3 if np.all(np.isfinite(c3)) else np.asarray(p.compliance, float)

    return {ref: (np.asarray(p.pose, float), compliance(p)) for ref, p in result.points.items()}


def outputs_of_exact(sol) -> Outputs | None:
    """The output points of a ``models.exact.SceneSolution``."""
    if not sol.converged:
        return None
    return {
        ref: (np.asarray(sol.poses[ref], float), np.asarray(sol.compliance[ref], float))
        for ref in sol.poses
    }


def pose_parts(pose: Any, pose_ref: Any, scale: float) -> tuple[float, float]:
    """(position error / scale, angle error in rad, wrapped to [0, pi]) of one pose (x, y,
    angle) against a reference: the pose part of the error measure, L_p its scale."""
    dx, dy = float(pose[0]) - float(pose_ref[0]), float(pose[1]) - float(pose_ref[1])
    return math.hypot(dx, dy) / scale, abs(
        math.remainder(float(pose[2]) - float(pose_ref[2]), 2 * math.pi)
    )


def _relative(C: np.ndarray, C_ref: np.ndarray) -> float:
    nr = float(np.linalg.norm(C_ref, 2))
    dC = float(np.linalg.norm(C - C_ref, 2))
    return dC / nr if nr > 0 else dC


def compliance_error(C: Any, C_ref: Any, scale: float | None = None) -> float:
    """||C - C_ref||_2 / ||C_ref||_2 (absolute where C_ref is 0) of the 2x2 position blocks: the
    compliance part of the error measure; where both are 3x3 and ``scale`` (L_p) is given, the
    larger of that and the same of D C D, D = diag(1, 1, L_p) (the angle row and column in the
    position block's units, as flexgen.estimate weighs them: review, a tolerance answer's
    rotational compliance was 38 times its stated estimate); inf where C is not finite."""
    C, C_ref = np.asarray(C, dtype=float), np.asarray(C_ref, dtype=float)
    if not np.all(np.isfinite(C)):
        return math.inf
    out = _relative(C[:2, :2], C_ref[:2, :2])
    if scale is not None and C.shape == C_ref.shape == (3, 3):
        d = np.array([1.0, 1.0, scale])
        out = max(out, _relative(C * np.outer(d, d), C_ref * np.outer(d, d)))
    return out


def error_components(got: Outputs, ref: Outputs, scales: Mapping[str, float]) -> np.ndarray:
    """[position/L_p, angle, compliance] error of every output point (in ``ref``'s order)."""
    out = []
    for name, (pose_r, C_r) in ref.items():
        pose, C = got[name]
        out.extend(
            [*pose_parts(pose, pose_r, scales[name]), compliance_error(C, C_r, scales[name])]
        )
    return np.array(out)


def error(got: Outputs | None, ref: Outputs, scales: Mapping[str, float]) -> float:
    """The error of an answer against a reference (inf if there is no answer)."""
    if got is None:
        return math.inf
    comps = error_components(got, ref, scales)
    return float(np.max(comps)) if comps.size else 0.0


# -- solving one choice of modes ---------------------------------------------------------------


@dataclass
class Solved:
    """One choice of modes, solved: what the selection compares (its outputs, kernels and q),
    not its Result, which holds the answer's arrays (the stiffness: (8 x flexures)^2 numbers)
    and is made again only for the answer returned (``_Problem.result``): a 100-flexure
    selection kept 3.8 GB of Results it never read."""

    modes: tuple[int, ...]
    q0: Mapping[str, Any] | None  # the warm start it was solved from
    q: dict[str, list[float]]  # its equilibrium (the warm start of the next solves)
    reason: str | None  # why it has no equilibrium (None: converged)
    outputs: Outputs | None  # None: no stable equilibrium
    kernels: tuple[str, ...]  # kernel used at equilibrium per flexure ("local"/"poly"/"gauss")
    seconds: float
    made: Result | None = None  # the Result, once _Problem.result made it


class _Problem:
    """A scene, its flexures' allowed modes, and a cache of solved mode choices."""

    def __init__(self, scene: Scene, solve_kwargs: Mapping[str, Any]):
        check_choosable(scene)
        # a tolerance may choose up to MAX_MODES modes per flexure: the limit on coordinates
        # counts them so (docs/scene.md, Limits), whoever gave it (review: flexgen select and
        # solve --tol skipped the check a [model] tolerance meets, and ran out of memory)
        check_limits(scene, choosing_modes=True)
        self.scene = scene
        self.names = tuple(f.name for f in scene.flexures)
        self.flex = scene.flexures
        self.gauss_max = max_gauss_modes()
        # the caller's settings as given (time_per_solve: the solve a user then runs)
        self.kw = {k: v for k, v in solve_kwargs.items() if k not in ("tolerance", "q0")}
        # the settings of the selection's solves: the caller's, with every Newton step evaluated
        # (linearized_step 0). A linearized last step leaves the compliance off by about the last
        # residual over the margin to a critical load, alike in every model compared, so the
        # comparison cannot see it (review: a column at 0.9999 of its Euler load claimed 1.07e-7
        # where its compliance was 7.6e-7 off)
        from .solver import make_settings

        given = {k: v for k, v in self.kw.items() if k != "settings"}
        self.settings = replace(make_settings(self.kw.get("settings"), **given), linearized_step=0)
        self.cache: dict[tuple[int, ...], Solved] = {}
        self.solves = 0

    def kernel_choice(self, i: int, N: int) -> str | None:
        """The SCMModel kernel argument for flexure i at N modes (None: no such kernel)."""
        want = self.flex[i].model.kernel
        if want == "gauss":
            return "gauss" if N <= self.gauss_max else None
        if want == "poly" or N > self.gauss_max:
            return "poly" if N <= MAX_MODES else None
        return want  # "auto" or "local"

    def models(self, modes: Sequence[int]):
        from .models.scm import SCMModel

        out = {}
        for i, (f, N) in enumerate(zip(self.flex, modes)):
            kernel = self.kernel_choice(i, N)
            if kernel is None:  # callers check kernel_choice before they solve
                raise ValueError(f"flexure {f.name!r}: no kernel for {N} modes")
            out[f.name] = SCMModel(f.length, f.EI, N, kernel, name=f.name)
        return out

    def solve(self, modes: Sequence[int], q0=None) -> Solved:
        from .solver import solve_models

        modes = tuple(int(n) for n in modes)
        if modes in self.cache:
            return self.cache[modes]
        models = self.models(modes)
        t0 = time.perf_counter()
        res = solve_models(self.scene, models, q0=q0, settings=self.settings)
        dt = time.perf_counter() - t0
        self.solves += 1
        outs = outputs_of(res) if res.stable else None
        if outs is not None and not all(
            np.all(np.isfinite(C)) and np.all(np.isfinite(p)) for p, C in outs.values()
        ):
            outs = None
        used = []
        for name in self.names:
            m = models[name]
            q = np.asarray(res.q.get(name, np.zeros(m.n_dof)), float)
            first = m.first(q)  # the local or polynomial kernel, as the core picks them
            used.append(getattr(first, "FAMILY", "poly") if first is not None else "gauss")
        solved = Solved(modes, q0, res.q, res.reason, outs, tuple(used), dt)
        self.cache[modes] = solved
        return solved

    def result(self, solved: Solved) -> Result:
        """The Result of a solved choice: solved again as it was (the same models, settings and
        warm start: the same answer), once."""
        from .solver import solve_models

        if solved.made is None:
            # not counted in solves: the same solve again, for its Result (its time counts)
            solved.made = solve_models(
                self.scene, self.models(solved.modes), q0=solved.q0, settings=self.settings
            )
        return solved.made


def _kernel_module(N: int, kernel: str):
    return kernels.load_numpy(kernels.kernel_name(N, kernel))


def kernel_term(
    scene: Scene, i: int, N: int, kernel: str, refs: Sequence[str], scales: Mapping[str, float]
) -> np.ndarray:
    """Flexure i's certified kernel bounds as error components: position ERROR_BOUND L_i / L_p
    at the points beyond it, compliance 2 JACOBIAN_ERROR_BOUND (J and J^T in C = J K^-1 J^T)."""
    mod = _kernel_module(N, kernel)
    f = scene.flexures[i]
    out = []
    for ref in refs:
        body, _ = scene.resolve_point(ref)
        beyond = body != "base" and f.name in scene.flexure_path(_path_owner(scene, body))
        out.extend(
            [
                float(mod.ERROR_BOUND) * f.length / scales[ref] if beyond else 0.0,
                0.0,
                2.0 * float(mod.JACOBIAN_ERROR_BOUND),
            ]
        )
    return np.array(out)


# -- the estimate table ------------------------------------------------------------------------


@dataclass
class FlexureTable:
    name: str
    rich: int  # M: modes of the rich model
    est: dict[int, np.ndarray] = field(default_factory=dict)  # N -> truncation estimate
    kernel: dict[int, str] = field(default_factory=dict)  # N -> kernel at equilibrium
    kern: dict[int, np.ndarray] = field(default_factory=dict)  # N -> kernel bounds
    total: dict[int, np.ndarray] = field(default_factory=dict)  # N -> est + kernel bounds


@dataclass
class Table:
    problem: _Problem
    rich: Solved | None  # None only when reason says no kernel was available
    refs: tuple[str, ...]
    scales: dict[str, float]
    flexures: list[FlexureTable]
    reason: str | None = None  # set when no rich answer could be found


def _rich_modes(pb: _Problem) -> tuple[tuple[int, ...], Solved | None, str | None]:
    """M per flexure (8 where the polynomial kernel stays in range, else the Gauss maximum) and
    the rich answer."""
    from .models.scm import SCMModel

    base = tuple(
        min(pb.gauss_max, MAX_MODES) if pb.kernel_choice(i, pb.gauss_max) else MAX_MODES
        for i in range(len(pb.names))
    )
    if any(pb.kernel_choice(i, n) is None for i, n in enumerate(base)):
        return base, None, "no kernel available"
    pre = pb.solve(base)
    if pre.outputs is None:
        return base, pre, pre.reason or "no stable equilibrium"
    rich = list(base)
    for i, f in enumerate(pb.flex):
        if pb.kernel_choice(i, MAX_MODES) == "poly" and MAX_MODES > base[i]:
            q = np.zeros(MAX_MODES)
            qi = pre.q[f.name]
            q[: len(qi)] = qi
            if SCMModel(f.length, f.EI, MAX_MODES, "poly").in_range(q):
                rich[i] = MAX_MODES
    for _ in range(len(rich) + 1):
        if tuple(rich) == base:
            return base, pre, None
        sol = pb.solve(rich, q0=pre.q)
        bad = [i for i, n in enumerate(rich) if n != base[i] and sol.kernels[i] == "gauss"]
        if sol.outputs is not None and not bad:
            return tuple(rich), sol, None
        for i in bad or [i for i, n in enumerate(rich) if n != base[i]]:
            rich[i] = base[i]
    return base, pre, None


def estimate_table(scene: Scene, stop_at: float | None = None, **solve_kwargs) -> Table:
    """The estimates e_i(N) of every flexure (see the module docstring). With ``stop_at`` = T a
    flexure's sweep stops once two consecutive N have estimates > T (lower N only grow)."""
    pb = _Problem(scene, solve_kwargs)
    M, rich, reason = _rich_modes(pb)
    refs = tuple(rich.outputs) if rich is not None and rich.outputs else ()
    scales = length_scales(scene, refs)
    table = Table(pb, rich, refs, scales, [], reason)
    if reason is not None:
        return table
    assert rich is not None  # _rich_modes gives an answer whenever it gives no reason
    ncomp = 3 * len(refs)
    inf = np.full(ncomp, math.inf)
    for i, name in enumerate(pb.names):
        Mi = M[i]
        ft = FlexureTable(name, Mi)
        sols: dict[int, Outputs | None] = {Mi: rich.outputs}
        ft.kernel[Mi] = rich.kernels[i]
        d: dict[int, np.ndarray] = {}
        tail = False  # the tail from M down is set (once d(M - 2) .. d(M - 5) are measured)
        stopped = False

        def diff(N):  # called within this iteration only: sols is the current flexure's
            a, b = sols.get(N), sols.get(N + 2)  # noqa: B023
            return inf if a is None or b is None else error_components(a, b, scales)

        for N in range(Mi - 1, 0, -1):
            if stopped:
                sols[N] = None
                continue
            modes = list(M)
            modes[i] = N
            s = pb.solve(modes, q0=rich.q)
            sols[N] = s.outputs
            ft.kernel[N] = s.kernels[i]
            if N + 2 <= Mi:
                d[N] = diff(N)
            if not tail and (N == max(Mi - 5, 1) or s.outputs is None):
                tail = True
                # the rich model: its difference to M - 2, as every answer's estimate of M
                # takes it (flexgen.estimate: scm8 against scm6), not the observed contraction
                # applied once more, which stated 5e-6 for a true 3.5e-4 where the modes had
                # not converged by 8 (found by review: `--tol` claimed T, off by up to 97x)
                base = d.get(Mi - 2)
                ft.est[Mi] = SAFETY * base if base is not None else inf.copy()
                if Mi - 1 >= 1:  # M - 1 against M, plus M's own error
                    a, b = sols.get(Mi - 1), sols.get(Mi)
                    step = inf if a is None or b is None else error_components(a, b, scales)
                    ft.est[Mi - 1] = SAFETY * step + ft.est[Mi]
                for K in range(Mi - 2, N - 1, -1):
                    ft.est[K] = SAFETY * d.get(K, inf) + ft.est.get(K + 2, inf)
            elif tail:
                ft.est[N] = SAFETY * d.get(N, inf) + ft.est.get(N + 2, inf)
            if s.outputs is None:
                stopped = True
            elif (
                stop_at is not None
                and tail
                and N + 1 < Mi
                and np.max(ft.est.get(N, inf)) > stop_at
                and np.max(ft.est.get(N + 1, inf)) > stop_at
            ):
                stopped = True
        if not tail:  # a flexure with M = 1 (cannot happen with the shipped kernels)
            ft.est[Mi] = np.zeros(ncomp)
        for N in range(1, Mi + 1):
            e = ft.est.get(N)
            if e is None or sols.get(N) is None or not np.all(np.isfinite(e)):
                ft.est[N] = inf.copy()
                continue
            ft.kern[N] = kernel_term(scene, i, N, ft.kernel[N], refs, scales)
            ft.total[N] = e + ft.kern[N]
        for N in range(1, Mi + 1):
            ft.total.setdefault(N, inf.copy())
        table.flexures.append(ft)
    return table


# -- choosing ----------------------------------------------------------------------------------


@dataclass
class FlexureChoice:
    name: str
    modes: int
    kernel: str  # "local", "poly" or "gauss": the kernel used at the equilibrium
    error_estimate: float  # this flexure's share: truncation estimate + kernel bound
    rich: int  # modes of the rich model the estimate was measured against


@dataclass
class Selection:
    tolerance: float
    choices: dict[str, FlexureChoice]
    error_estimate: float
    reached: bool
    result: Result
    solves: int  # chain solves the selection used
    seconds: float  # wall time of the selection
    message: str | None = None  # why T is out of reach / no answer

    @property
    def modes(self) -> dict[str, int]:
        return {n: c.modes for n, c in self.choices.items()}


def choose(table: Table, tol: float) -> tuple[tuple[int, ...], np.ndarray, bool]:
    """The mode choice with the fewest total modes whose summed estimate is <= tol (ties: the
    smaller estimate); if none, the one with the smallest estimate. -> (modes, estimate, met)."""
    fts = table.flexures
    opts = [
        [N for N in sorted(ft.total) if np.all(np.isfinite(ft.total[N]))] or [ft.rich] for ft in fts
    ]
    best_ok, best_any = None, None
    count = math.prod(len(o) for o in opts)
    if count <= 50000:
        combos: Iterable = itertools.product(*opts)
    else:  # many flexures: each flexure alone, then combined
        combos = [tuple(_greedy(ft, o, tol / len(fts)) for ft, o in zip(fts, opts))]
        combos += [tuple(o[-1] for o in opts)]
    for combo in combos:
        tot = combine(
            [ft.est[N] for ft, N in zip(fts, combo)],
            [ft.kern.get(N, ft.total[N]) for ft, N in zip(fts, combo)],
        )
        e = float(np.max(tot)) if np.size(tot) else 0.0
        key_any = (e, sum(combo))
        if best_any is None or key_any < best_any[0]:
            best_any = (key_any, combo, tot)
        if e <= tol:
            key = (sum(combo), e)
            if best_ok is None or key < best_ok[0]:
                best_ok = (key, combo, tot)
    if best_ok is not None:
        return best_ok[1], best_ok[2], True
    assert best_any is not None  # every option list is non-empty: there is at least one combo
    return best_any[1], best_any[2], False


def combine(est: Sequence[np.ndarray], kern: Sequence[np.ndarray]) -> np.ndarray:
    """Error components of several flexures together: truncation estimates add; kernel bounds
    add for positions and angles (errors accumulate along a chain) and take the largest for the
    compliances (a relative bound on the Jacobian as a whole)."""
    out = sum(est) if len(est) else 0.0
    if len(kern):
        K = np.array(kern)
        k = K.sum(axis=0)
        k[2::3] = K[:, 2::3].max(axis=0)
        out = out + k
    return np.asarray(out, dtype=float)


def _greedy(ft: FlexureTable, opts: list[int], share: float) -> int:
    for N in opts:
        if float(np.max(ft.total[N])) <= share:
            return N
    return opts[-1]


def _handed_over(pb: _Problem, solved: Solved) -> Result:
    """The Result of a solved choice, for one Selection to own and write (its tolerance,
    estimate and warnings): no longer cached, so that another tolerance selected from the same
    table (select_from_table) makes its own (review: a second tolerance's warnings piled onto
    the first selection's Result)."""
    res = pb.result(solved)
    solved.made = None
    return res


def _finish(table: Table, tol: float, t0: float) -> Selection:
    pb, scene = table.problem, table.problem.scene
    if table.reason is not None:
        why = f"no answer to estimate the error of: {table.reason}"
        if table.rich is None:  # no kernel for the rich models: not even a failed result
            raise ValueError(why)
        res = _handed_over(pb, table.rich)
        res.tolerance, res.error_estimate = tol, None
        if res.converged:
            res.warnings.append(why)
        return Selection(tol, {}, math.inf, False, res, pb.solves, time.perf_counter() - t0, why)
    modes, tot, met = choose(table, tol)
    fts = {ft.name: ft for ft in table.flexures}
    order = list(pb.names)
    rich = table.rich
    # no reason: _rich_modes found a rich answer with a stable equilibrium
    assert rich is not None and rich.outputs is not None
    rich_outputs = rich.outputs
    rich_tot = combine(
        [fts[n].est[fts[n].rich] for n in order],
        [fts[n].kern.get(fts[n].rich, fts[n].total[fts[n].rich]) for n in order],
    )

    def direct(modes) -> tuple[Solved, np.ndarray]:
        """err(chosen) <= |chosen - rich| + err(rich): measured, plus the rich model's estimate
        (and the bounds of any kernel the rich model does not use)."""
        s = pb.solve(modes, q0=rich.q)
        if s.outputs is None:
            return s, np.full_like(rich_tot, math.inf)
        extra = [
            kernel_term(scene, k, N, s.kernels[k], table.refs, table.scales)
            for k, N in enumerate(modes)
            if s.kernels[k] != rich.kernels[k]
        ]
        e = SAFETY * error_components(s.outputs, rich_outputs, table.scales) + rich_tot
        return s, e + combine([], extra) if extra else e

    chosen, tot = direct(modes)
    for _ in range(sum(ft.rich for ft in table.flexures) + 1):
        if float(np.max(tot)) <= tol or not met:
            break
        # interaction pushed the estimate over T: give a mode to the flexure with most error
        grow = [
            (float(np.max(fts[n].total[N])), k)
            for k, (n, N) in enumerate(zip(order, modes))
            if N < fts[n].rich
        ]
        if not grow:
            break
        _, k = max(grow)
        modes = tuple(N + (j == k) for j, N in enumerate(modes))
        chosen, tot = direct(modes)
    if met and float(np.max(tot)) <= tol:
        # the predictor (a sum over flexures) is conservative: take modes away while the
        # measured estimate still meets T
        improved = True
        while improved:
            improved = False
            for k in sorted(range(len(modes)), key=lambda k: -modes[k]):
                if modes[k] <= 1:
                    continue
                fewer = tuple(N - (j == k) for j, N in enumerate(modes))
                if any(pb.kernel_choice(j, N) is None for j, N in enumerate(fewer)):
                    continue
                if float(np.max(fts[order[k]].total.get(fewer[k], math.inf))) > tol:
                    continue  # this flexure alone already misses T at one mode fewer
                s2, t2 = direct(fewer)
                if float(np.max(t2)) <= tol:
                    modes, chosen, tot, improved = fewer, s2, t2, True
                    break
    est = float(np.max(tot)) if np.size(tot) else 0.0
    reached = est <= tol
    res = _handed_over(pb, chosen)
    choices = {}
    for k, (name, N) in enumerate(zip(pb.names, modes)):
        share = float(np.max(fts[name].total[N])) if np.size(tot) else 0.0
        choices[name] = FlexureChoice(name, N, chosen.kernels[k], share, fts[name].rich)
        info = dict(res.model.get(name, {"kind": "scm"}))
        info.update(modes=N, kernel=chosen.kernels[k], error_estimate=share)
        res.model[name] = info
    res.tolerance, res.error_estimate = tol, est
    # each output point's share, in the shape every answer's estimate has (flexgen.estimate)
    for k, ref in enumerate(table.refs):
        point = res.points.get(ref)
        if point is not None and np.size(tot):
            point.error_estimate = {
                "pose": float(max(tot[3 * k], tot[3 * k + 1])),
                "compliance": float(tot[3 * k + 2]),
            }
    _stress_estimates(pb, chosen, res)
    from .validity import BEND_LIMIT

    msg = None
    past = [(name, bend) for name, bend in res.bend.items() if bend > BEND_LIMIT]
    if reached and past:
        # no accuracy is claimed past BEND_LIMIT (flexgen.validity: the estimate's Gauss kernels
        # are certified to there; a multi-turn roll-up's compliance was 28 % off with an
        # estimate of 6.9 %): T is not claimed either, whatever the estimate (review)
        reached = False
        name, bend = max(past, key=lambda nb: nb[1])
        msg = (
            f"tolerance {tol:.3g} is not claimed: flexure {name!r} is bent "
            f"{math.degrees(bend):.0f} deg, past the {math.degrees(BEND_LIMIT):.0f} deg to "
            f"which the error estimate is certified"
        )
        res.warnings.append(msg)
    elif not reached:
        M = ", ".join(f"{ft.name} {ft.rich}" for ft in table.flexures)
        msg = (
            f"tolerance {tol:.3g} is out of reach: the best estimate is {est:.3g} with the "
            f"richest models available ({M} modes; polynomial kernels up to {MAX_MODES} modes "
            f"within their range, Gauss kernels up to {pb.gauss_max} past it)"
        )
        res.warnings.append(msg)
    if res.converged:  # the validity warnings flexgen.solve gives (review: `flexgen select`
        from .validity import check  # and solve_to_tolerance dropped them)

        check(scene, res)
    return Selection(tol, choices, est, reached, res, pb.solves, time.perf_counter() - t0, msg)


def _stress_estimates(pb: _Problem, chosen: Solved, res: Result) -> None:
    """The chosen answer's flexures with their curvature (so stress) estimates, as every
    answer's (flexgen.estimate: the chosen models against N + 2 from the answer; the selection's
    own comparison is with its richest models, whose own curvature error it does not bound),
    and the safety-factor warnings those may add."""
    from .solver import Solver
    from .stress import safety_warnings

    solver = Solver(pb.scene, pb.models(chosen.modes), pb.settings)
    again = solver.solve(q0=res.q, estimate=True)  # the same equilibrium: Newton from it
    if not again.converged:
        return
    res.flexures = again.flexures
    res.warnings.extend(w for w in safety_warnings(pb.scene, res.flexures) if w not in res.warnings)


def select_models(scene, tolerance: float, /, **solve_kwargs) -> Selection:
    """Choose the fewest modes per flexure that meet ``tolerance`` (see the module docstring).

    ``scene``: a Scene (or a path/dict, as ``flexgen.solve`` takes); ``solve_kwargs`` go to
    every chain solve (``tol`` there is the residual tolerance of the equilibrium, not this one).
    Raises SelectionError for a tolerance not in (0, 1) or a flexure that is not "scm"."""
    from .scene import as_scene

    tol = check_tolerance(tolerance)
    scene = as_scene(scene)
    t0 = time.perf_counter()
    table = estimate_table(scene, stop_at=tol, **solve_kwargs)
    return _finish(table, tol, t0)


def select_from_table(table: Table, tol: float) -> Selection:
    """``select_models`` for one more tolerance on an already computed (full) table."""
    return _finish(table, check_tolerance(tol), time.perf_counter())


def solve_to_tolerance(scene, tolerance: float, /, **solve_kwargs) -> Result:
    """Solve ``scene`` with the fewest modes per flexure that meet ``tolerance``: a Result whose
    ``model[flexure]`` has ``modes``, ``kernel`` and ``error_estimate`` and whose
    ``error_estimate`` covers the whole answer (``to_json`` then includes them). If ``tol`` is
    out of reach the Result has the best estimate and a warning saying so. ``solve_kwargs`` go
    to every chain solve (``flexgen.solver.solve_models``: ``settings``, ``tol``, ...)."""
    return select_models(scene, tolerance, **solve_kwargs).result


# -- cost --------------------------------------------------------------------------------------

_COST = re.compile(r"Cost:\s*(\d+)\s*ops")


def kernel_ops(modes: int, kernel: str) -> int | None:
    """Operation count per call of the C kernel (from the generated source's header), if known."""
    name = kernels.kernel_name(modes, kernel)
    path = kernels.GENERATED / "c" / f"{name}.c"
    try:
        m = _COST.search(path.read_text()[:4000])
    except OSError:
        return None
    return int(m[1]) if m else None


def time_per_solve(
    scene: Scene, modes: Mapping[str, int], repeat: int = 5, **solve_kwargs
) -> float:
    """Seconds per solve (equilibrium + compliance, continuation from the unloaded state) with
    the given modes through a prepared solver, the best of ``repeat`` after one untimed call."""
    from .solver import Solver, make_settings

    pb = _Problem(scene, solve_kwargs)
    solver = Solver(scene, pb.models([modes[n] for n in pb.names]), make_settings(**pb.kw))
    solver.solve()
    best = math.inf
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        solver.solve()
        best = min(best, time.perf_counter() - t0)
    return best


__all__ = [
    "solve_to_tolerance",
    "select_models",
    "select_from_table",
    "estimate_table",
    "choose",
    "Selection",
    "FlexureChoice",
    "SelectionError",
    "scene_tolerance",
    "error",
    "compliance_error",
    "error_components",
    "pose_parts",
    "outputs_of",
    "outputs_of_exact",
    "length_scales",
    "time_per_solve",
    "kernel_ops",
]
