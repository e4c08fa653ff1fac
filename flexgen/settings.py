"""Every tuning constant of the chain solver, in one place.

``SolverSettings`` mirrors ``fg_settings`` of ``flexgen/compiled/chain_solver.h`` field for
field: the same names, in the same order, with the same types (float: ``double``, int: ``int``).
The C side holds no defaults: the solver copies these fields into the struct by name. The
defaults here are the values the solver has always used; ``__post_init__`` rejects a value the
solver cannot run with, naming the field (``settings.tol: must be ...``).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, fields

INT_MAX = 2**31 - 1
MAX_LAG = 64  # chain_solver.h: FG_MAX_LAG (Newton keeps that many residuals)


@dataclass(frozen=True)
class SolverSettings:
    tol: float = 1e-12  # relative residual of an accepted equilibrium
    # largest change of a coordinate in one step along the path; a warm start's distance from q0
    # and the path samples' corrections are the largest change of an angle along a flexure
    # (chain_solver.c: angle_change, a fem flexure's joint angles summed)
    max_dq: float = 0.5
    max_iterations: int = 50  # Newton iterations per load step
    max_steps: int = 500  # continuation steps (0: the solve fails at once)
    initial_step: float = 0.1  # first load-factor step of the continuation
    max_step: float = 0.25  # largest load-factor step
    min_step: float = 1e-5  # smallest load-factor step (then the path has ended)
    polish_target: float = 1e-14  # polishing: Newton steps while the residual is above this
    polish_steps: int = 3  # polishing: at most this many steps
    direct_max_iterations: int = 12  # direct solve: Newton iterations (at most max_iterations)
    direct_correction: float = 0.2  # direct solve: largest correction at a sample / max_dq
    direct_samples: int = 3  # direct solve: Hermite path samples at k / (samples + 1)
    stagnation_after: int = 8  # Newton stagnates: from this iteration on, the residual
    stagnation_ratio: float = 0.5  # above this fraction of
    stagnation_lag: int = 6  # the residual this many iterations earlier
    armijo: float = 1e-4  # sufficient-decrease factor of the line searches
    line_search_halvings: int = 30  # line search: at most this many step lengths tried
    expansion_doublings: int = 40  # descent: step doublings along negative curvature
    eigenvalue_floor: float = 1e-10  # descent: |eigenvalue| floored at this fraction of the top
    roundoff_tol: float = 1e-13  # descent: a change of Pi below this of |Pi| + |U| is rounding
    bifurcation_threshold: float = 1e-6  # |v . Q| <= this (|Q| + |lam S|): a bifurcation
    bracket_tol: float = 1e-13  # regula falsi: relative load-factor interval (and eigenvalue)
    bracket_iterations: int = 100  # regula falsi: at most this many trial load factors
    bracket_clamp: float = 0.01  # regula falsi: trial point kept in [clamp, 1 - clamp]
    descent_eps: float = 1e-3  # leaving a bifurcation: q +- eps max(1, |q|) v
    descent_iteration_factor: int = 20  # descent Newton: this many times max_iterations
    tie_tol: float = 1e-9  # two sides' potentials (mean y) equal to this relative tolerance
    fast_iterations: int = 3  # a step that took at most this many iterations:
    fast_growth: float = 2.0  # the next step this much longer;
    moderate_iterations: int = 6  # at most this many iterations:
    moderate_growth: float = 1.2  # this much longer
    step_shrink: float = 0.5  # after a failed step the next is this fraction of it
    lapack_min_size: int = 32  # LAPACK factorizations from this many coordinates on
    # the stiffness factorized by first eliminating, flexure by flexure, the coordinates that
    # couple only within their flexure and with the angles, from this many coordinates on
    elimination_min_size: int = 12
    bend_samples: int = 65  # points along a flexure where its bend is sampled
    circle_tol: float = 1e-14  # ellipse axes equal to this (relative): a circle, angle 0
    # Newton's last step taken unevaluated (its end linearized) from a residual of at most this
    # many tol, when the convergence seen predicts its end below tol and polish_target; the
    # compliance is then off by about that residual (0: every step evaluated)
    linearized_step: float = 30.0
    # a warm start (q0) accepted only on the load path from the unloaded state (the direct
    # solve's path samples: the answer a cold solve gives, where several stable equilibria hold
    # the load); 0: wherever Newton from q0 converges nearby (it follows q0's branch, as the
    # emitted controller does on purpose). A bool (0 and 1 are read as False and True)
    warm_on_path: bool = True

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if f.type == "bool":  # a flag: the core's struct takes it as int 0 or 1
                flag = isinstance(value, numbers.Integral) or type(value).__name__ == "bool"
                if not (flag and value in (0, 1)):  # (NumPy's bool is no Integral)
                    _bad(f.name, "must be True or False", value)
                object.__setattr__(self, f.name, bool(value))
            elif f.type == "int":
                if isinstance(value, bool) or not isinstance(value, numbers.Integral):
                    _bad(f.name, "must be an integer", value)
                value = int(value)  # a NumPy integer as the int the core's struct takes
                object.__setattr__(self, f.name, value)
                low = 0 if f.name in _ZERO_OK else 1
                if not low <= value <= INT_MAX:
                    _bad(f.name, f"must be an integer in [{low}, 2**31 - 1]", value)
            else:
                # any real number (a NumPy float32 or int64 too: review), stored as the float
                # the core's struct takes; a bool is no number here
                if isinstance(value, bool) or not isinstance(value, numbers.Real):
                    _bad(f.name, "must be a finite number", value)
                try:  # an int beyond a float's range (10**400) is no finite number either
                    value = float(value)
                except OverflowError:
                    _bad(f.name, "must be a finite number", value)
                object.__setattr__(self, f.name, value)
                lo, hi, what = _RANGES[f.name]
                if not (math.isfinite(value) and lo(value) and hi(value)):
                    _bad(f.name, f"must be a finite number {what}", value)
        if not self.min_step <= self.initial_step <= self.max_step:
            # all three named: which one the caller changed is not known here (review: a
            # min_step above max_step was blamed on the default initial_step)
            raise ValueError(
                f"settings: min_step <= initial_step <= max_step must hold, got min_step="
                f"{self.min_step!r}, initial_step={self.initial_step!r}, max_step="
                f"{self.max_step!r}"
            )
        if self.stagnation_lag > MAX_LAG:
            _bad(
                "stagnation_lag",
                f"must be at most {MAX_LAG} (chain_solver.h: FG_MAX_LAG)",
                self.stagnation_lag,
            )
        if self.stagnation_lag > self.stagnation_after:
            _bad(
                "stagnation_lag",
                f"must be at most stagnation_after ({self.stagnation_after})",
                self.stagnation_lag,
            )
        if self.moderate_iterations < self.fast_iterations:
            _bad(
                "moderate_iterations",
                f"must be at least fast_iterations ({self.fast_iterations})",
                self.moderate_iterations,
            )
        if self.descent_iteration_factor * self.max_iterations > INT_MAX:
            _bad(
                "descent_iteration_factor",
                "times max_iterations must be below 2**31",
                self.descent_iteration_factor,
            )


def _bad(name: str, what: str, value) -> None:
    raise ValueError(f"settings.{name}: {what}, got {value!r}")


def _pos(x):
    return x > 0


def _nonneg(x):
    return x >= 0


def _lt1(x):
    return x < 1


def _le1(x):
    return x <= 1


def _any(x):
    return True


# the int fields that may be 0 (0 disables what they count)
_ZERO_OK = {
    "max_steps",
    "polish_steps",
    "direct_samples",
    "expansion_doublings",
    "bracket_iterations",
    "fast_iterations",
    "moderate_iterations",
    "lapack_min_size",
    "elimination_min_size",
    "direct_max_iterations",
    "max_iterations",
}

# float fields: (lower test, upper test, the range in words)
_RANGES = {
    "tol": (_pos, _lt1, "in (0, 1)"),
    "max_dq": (_pos, _any, "> 0"),
    "initial_step": (_pos, _le1, "in (0, 1]"),
    "max_step": (_pos, _le1, "in (0, 1]"),
    "min_step": (_pos, _le1, "in (0, 1]"),
    "polish_target": (_nonneg, _lt1, "in [0, 1)"),
    "direct_correction": (_pos, _any, "> 0"),
    "stagnation_ratio": (_pos, _le1, "in (0, 1]"),
    "armijo": (_nonneg, _lt1, "in [0, 1)"),
    "eigenvalue_floor": (_pos, _lt1, "in (0, 1)"),
    "roundoff_tol": (_nonneg, _lt1, "in [0, 1)"),
    "bifurcation_threshold": (_pos, _lt1, "in (0, 1)"),
    "bracket_tol": (_pos, _lt1, "in (0, 1)"),
    "bracket_clamp": (_pos, lambda x: x < 0.5, "in (0, 0.5)"),
    "descent_eps": (_pos, _any, "> 0"),
    "tie_tol": (_nonneg, _lt1, "in [0, 1)"),
    "fast_growth": (lambda x: x >= 1, _any, ">= 1"),
    "moderate_growth": (lambda x: x >= 1, _any, ">= 1"),
    "step_shrink": (_pos, _lt1, "in (0, 1)"),
    "circle_tol": (_nonneg, _lt1, "in [0, 1)"),
    "linearized_step": (_nonneg, _any, ">= 0"),
}

DEFAULT = SolverSettings()

__all__ = ["SolverSettings", "DEFAULT"]
