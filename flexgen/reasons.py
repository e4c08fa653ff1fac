"""Why a solve found no equilibrium: the core's failure codes as one line for the user.

The core (chain_solver.h) reports what failed (``failure``: FG_FAIL_*, at
``failure_load_factor``), the last error of its Newton solves (``last_error``: FG_ERR_*, with
the load factor and relative residual it happened at) and the flexure whose kernel could not be
evaluated last (``model_error_flexure``). The words live here, once.
"""

from __future__ import annotations

from typing import Any

from .core import lib


def _last_error(a: Any, settings: Any) -> str:
    lam, rel = a.last_error_load_factor, a.last_error_residual
    table = {
        lib.FG_ERR_STAGNATION: f"Newton stagnates at load factor {lam:.6g} "
        f"(relative residual {rel:.2e})",
        lib.FG_ERR_NOT_CONVERGED: f"Newton did not converge in {settings.max_iterations} "
        f"iterations (relative residual {rel:.2e})",
        lib.FG_ERR_LINE_SEARCH: f"line search failed at load factor {lam:.6g} "
        f"(relative residual {rel:.2e})",
        lib.FG_ERR_JUMP: f"the path jumped by more than {settings.max_dq} in q at load factor "
        f"{lam:.6g}",
        lib.FG_ERR_NONFINITE: "a model returned a non-finite value",
        lib.FG_ERR_TENDON: "a tendon segment has zero length",
    }
    return table.get(a.last_error, "")


def _model_error(solver: Any, a: Any) -> str | None:
    i = a.model_error_flexure
    if i < 0:
        return None
    name = solver.problem.flexure_order[i]
    range_error = getattr(solver.models[name], "range_error", None)
    return range_error() if range_error is not None else f"flexure {name!r} could not be evaluated"


def failure_reason(solver: Any, status: int) -> str:
    """The one-line reason of a failed solve (``Solver._result``)."""
    a = solver.workspace.answer
    lam = a.failure_load_factor
    last = _last_error(a, solver.settings)
    model = _model_error(solver, a)
    if a.last_error == lib.FG_ERR_KERNEL_RANGE and model:
        last = model
    what = {
        lib.FG_FAIL_UNLOADED: "no equilibrium of the unloaded scene",
        lib.FG_FAIL_STEPS: f"load continuation needed more than {solver.settings.max_steps} "
        f"steps (reached load factor {lam:.6g})",
        lib.FG_FAIL_BIFURCATION: f"no stable equilibrium found past the bifurcation near load "
        f"factor {lam:.6g}",
        lib.FG_FAIL_LIMIT: f"no equilibrium found beyond load factor {lam:.6g}",
    }.get(a.failure, f"no equilibrium found (core status {status})")
    reason = f"{what}: {last}" if last and a.failure != lib.FG_FAIL_STEPS else what
    if model and model not in reason:
        reason = f"{reason} (last model error: {model})"
    return reason
