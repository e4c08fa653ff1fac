"""Every default and tuning constant of the solver core, in one frozen dataclass passed to C.

(Interim: the solver branch replaces this file with the full set of tuning constants.)
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SolverSettings:
    tol: float = 1e-12             # relative residual of an accepted equilibrium
    max_dq: float = 0.5            # largest change of a coordinate in one step along the path
    max_iterations: int = 50       # Newton iterations per load step
    max_steps: int = 500           # continuation steps
    initial_step: float = 0.1      # first load-factor step of the continuation
    max_step: float = 0.25         # largest load-factor step
    min_step: float = 1e-5         # smallest load-factor step before the path is said to end
    lapack_min_size: int = 32      # LAPACK (SciPy's) from this many coordinates on


DEFAULT = SolverSettings()
