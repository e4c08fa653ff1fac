"""Why a solve found no equilibrium: the core's failure codes as one line for the user.

The core (chain_solver.h) reports what failed (``failure``: FG_FAIL_*, at
``failure_load_factor``), the last error of its Newton solves (``last_error``: FG_ERR_*, with
the load factor, relative residual, iteration limit, flexure or tendon segment it concerns) and
the last model error (a kernel past its range, a zero-length tendon segment). The words live
here, once.
"""

from __future__ import annotations

from typing import Any

from .core import lib


def _model_message(solver: Any, code: int, flexure: int, entry: int) -> str | None:
    """The text of a model error: a kernel evaluated past its range, a degenerate tendon."""
    if code == lib.FG_ERR_KERNEL_RANGE and flexure >= 0:
        name = solver.problem.flexure_order[flexure]
        range_error = getattr(solver.models[name], "range_error", None)
        return range_error() if range_error else f"flexure {name!r} could not be evaluated"
    if code == lib.FG_ERR_TENDON and entry >= 0:
        return f"{_segment(solver, entry)} has zero length"
    return None


def _segment(solver: Any, entry: int) -> str:
    """The tendon segment starting at ``entry`` of the core's route array, in words."""
    route = [ref for t in solver.scene.tendons for ref in t.route]
    return f"tendon segment {route[entry]!r} -> {route[entry + 1]!r}"


def _last_error(solver: Any, a: Any) -> str:
    e, lam, rel = a.last_error, a.last_error_load_factor, a.last_error_residual
    if e == lib.FG_ERR_STAGNATION:
        return f"Newton stagnates at load factor {lam:.6g} (relative residual {rel:.2e})"
    if e == lib.FG_ERR_NOT_CONVERGED:
        # a residual of 0 is one the failed search never evaluated (review: "did not converge
        # ... (relative residual 0.00e+00)" read as a contradiction): not quoted
        return f"Newton did not converge in {a.last_error_iterations} iterations" + (
            f" (relative residual {rel:.2e})" if rel > 0.0 else ""
        )
    if e == lib.FG_ERR_LINE_SEARCH:
        return f"line search failed at load factor {lam:.6g} (relative residual {rel:.2e})"
    if e == lib.FG_ERR_JUMP:
        return (
            f"the path jumped (by more than {solver.settings.max_dq} in q, against its "
            f"tangent onto another branch, or off the path between its ends) at load factor "
            f"{lam:.6g}"
        )
    if e == lib.FG_ERR_NONFINITE:
        return "a model returned a non-finite value"
    return str(_model_message(solver, e, a.last_error_flexure, a.last_error_route))


def failure_reason(solver: Any, status: int) -> str:
    """The one-line reason of a failed solve (``Solver._result``)."""
    if status == lib.FG_MODEL_ERROR:
        return (
            "the solver core refused the problem as malformed (a count, an index, an array, a "
            "kernel or a setting it cannot run with)"
        )
    a = solver.workspace.answer
    lam = a.failure_load_factor
    if a.failure == lib.FG_FAIL_STEPS:
        reason = (
            f"load continuation needed more than {solver.settings.max_steps} steps "
            f"(reached load factor {lam:.6g})"
        )
    model = _model_message(solver, a.model_error, a.model_error_flexure, a.model_error_route)
    if a.failure == lib.FG_FAIL_LIMIT and a.model_error == lib.FG_ERR_KERNEL_RANGE and model:
        # the path ran out of the kernel's range, which is the cause to read first, not a
        # limit point (review: a pure end moment under kernel "poly" read as a limit point)
        reason = (
            f"no equilibrium found beyond load factor {lam:.6g}, where {model}: "
            f"{_last_error(solver, a)}"
        )
    elif a.failure == lib.FG_FAIL_LIMIT and a.model_error == lib.FG_ERR_TENDON and model:
        # the path ended where a tendon's ends meet (the core's name_short_tendon): its pull
        # turns there, which is the cause, not a limit point (review)
        segment = _segment(solver, a.model_error_route)
        reason = (
            f"no equilibrium found beyond load factor {lam:.6g}, where {segment} is pulled to "
            f"nearly zero length (its ends meet and its pull turns about): "
            f"{_last_error(solver, a)}"
        )
        model = None  # said above
    elif a.failure != lib.FG_FAIL_STEPS:
        what = {
            lib.FG_FAIL_UNLOADED: "no equilibrium of the unloaded scene",
            lib.FG_FAIL_BIFURCATION: "no stable equilibrium found past the bifurcation near "
            f"load factor {lam:.6g}",
            lib.FG_FAIL_LIMIT: f"no equilibrium found beyond load factor {lam:.6g} (the load "
            "path may end there at a limit point with no stable state to snap to, or Newton "
            "could not follow it)",
        }.get(a.failure, f"the solver core could not run this problem (status {status})")
        reason = f"{what}: {_last_error(solver, a)}"
    if model and model not in reason:
        reason = f"{reason} (last model error: {model})"
    return reason
