"""The compiled solver core: the extension module ``flexgen._core``, its kernels and LAPACK.

``flexgen._core`` is built when flexgen is installed (cffi in API mode, from
``flexgen/compiled/_build_core.py``): the chain solver ``flexgen/compiled/chain_solver.c`` and
every shipped C kernel (``generated/c``) in one extension module. Nothing is compiled or loaded at
run time from any other folder. ``chain_solver.h`` is the one definition of the structs: Python
fills them by field name through ``ffi``.

This module only finds things in the extension: a kernel's function pointers, SciPy's LAPACK
routines by address, the status codes. Building a problem is ``flexgen.problem``; solving it is
``flexgen.solver``.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path
from typing import Any

from . import kernels
from .compiled.digest import sources_digest


class CoreUnavailable(ImportError):
    """The extension module is missing or older than its sources (a source checkout)."""


try:
    from flexgen._core import ffi, lib
except ImportError as exc:  # pragma: no cover - an install without its extension
    raise CoreUnavailable(
        "flexgen's compiled core (flexgen._core) is not built: install flexgen with pip "
        "(`pip install .`, or `make setup` in a checkout)"
    ) from exc

PACKAGE = Path(__file__).resolve().parent
SOURCES = PACKAGE / "compiled"

SOLVED: int = lib.FG_SOLVED
MODEL_ERROR: int = lib.FG_MODEL_ERROR  # a malformed fg_problem (flexgen.problem never builds one)
# fg_answer.critical_kind: the path snapped through at a limit point, or crossed a bifurcation
SNAP_THROUGH: int = lib.FG_SNAP_THROUGH


def check_fresh() -> None:
    """In a source checkout (an editable install), fail loudly if a C source changed after
    ``flexgen._core`` was built: a stale core would silently solve with the old code."""
    built = ffi.string(lib.fg_sources_digest()).decode()
    if built != sources_digest(SOURCES, kernels.GENERATED / "c"):
        raise CoreUnavailable(
            "flexgen._core is older than its C sources "
            "(flexgen/compiled, generated/c): rebuild it with `make setup`"
        )


def double_ptr(array: Any) -> Any:
    """A C ``double *`` to the data of a C-contiguous float64 NumPy array (the caller keeps the
    array alive while the core may use the pointer)."""
    return ffi.cast("double *", array.ctypes.data)


@cache
def kernel_functions(name: str) -> tuple[Any, Any]:
    """The C function pointers ``<name>_evaluate`` and ``<name>_in_range`` of a shipped kernel."""
    try:
        return (ffi.addressof(lib, f"{name}_evaluate"), ffi.addressof(lib, f"{name}_in_range"))
    except AttributeError:
        raise kernels.KernelNotFound(
            f"kernel {name!r} is not compiled into flexgen's core (its shipped kernels: "
            f"{', '.join(compiled_kernels())})"
        ) from None


def compiled_kernels() -> list[str]:
    """Names of the kernels compiled into the core."""
    return sorted({n[: -len("_evaluate")] for n in dir(lib) if n.endswith("_evaluate")})


@cache
def lapack() -> dict[str, Any]:
    """SciPy's dpotrf, dpotrs, dgetrf, dgetrs and dsyev as C function pointers
    (``scipy.linalg.cython_lapack`` exports them as capsules), or {} if that fails: the core
    then uses its built-in factorizations and eigen-decomposition."""
    import ctypes

    try:
        from scipy.linalg import cython_lapack

        name_of = ctypes.pythonapi.PyCapsule_GetName
        name_of.restype, name_of.argtypes = ctypes.c_char_p, [ctypes.py_object]
        pointer = ctypes.pythonapi.PyCapsule_GetPointer
        pointer.restype, pointer.argtypes = ctypes.c_void_p, [ctypes.py_object, ctypes.c_char_p]
        found = {}
        for routine in ("potrf", "potrs", "getrf", "getrs", "syev"):
            capsule = cython_lapack.__pyx_capi__["d" + routine]
            found[routine] = ffi.cast(f"fg_{routine}", pointer(capsule, name_of(capsule)))
    except (ImportError, AttributeError, KeyError, ValueError):
        return {}
    return found


if (PACKAGE.parent / "pyproject.toml").is_file():  # a source checkout: is the core current?
    check_fresh()
