"""Compile, cache and load the shared libraries of the compiled solver and the C kernels.

Each C source (``flexgen/compiled/chain_solver.c``, ``generated/c/<kernel>.c``) is compiled once
with the strict flags of ``flexgen.kernels.C_FLAGS`` into ``<cache>/<name>-<hash>.so``, the hash
covering the source, its header and the flags, so an edited or regenerated source is rebuilt and
an unchanged one is loaded again. ``<cache>`` is ``$FLEXGEN_CACHE`` or ``~/.cache/flexgen`` (a
folder in the temp dir when the home folder is not writable).
The ctypes structs here mirror ``chain_solver.h``.
"""
from __future__ import annotations

import ctypes
import dataclasses
import hashlib
import os
import tempfile
from functools import lru_cache
from pathlib import Path

from .. import kernels
from ..settings import SolverSettings

HERE = Path(__file__).resolve().parent
_c_double_p = ctypes.POINTER(ctypes.c_double)
_c_int_p = ctypes.POINTER(ctypes.c_int)


class CompileError(RuntimeError):
    """gcc is missing or failed; the message says which source."""


class Flexure(ctypes.Structure):
    _fields_ = [("kind", ctypes.c_int), ("ndof", ctypes.c_int), ("offset", ctypes.c_int),
                ("parent", ctypes.c_int), ("at", ctypes.c_double * 3),
                ("length", ctypes.c_double), ("gamma", ctypes.c_double),
                ("poly", ctypes.c_void_p), ("in_range", ctypes.c_void_p),
                ("gauss", ctypes.c_void_p), ("gauss_in_range", ctypes.c_void_p)]


class Point(ctypes.Structure):
    _fields_ = [("frame", ctypes.c_int), ("x", ctypes.c_double), ("y", ctypes.c_double)]


class Lapack(ctypes.Structure):
    _fields_ = [("potrf", ctypes.c_void_p), ("potrs", ctypes.c_void_p),
                ("getrf", ctypes.c_void_p), ("getrs", ctypes.c_void_p),
                ("syev", ctypes.c_void_p)]


class Settings(ctypes.Structure):
    """fg_settings: the fields of flexgen.settings.SolverSettings, in order (float: double)."""
    _fields_ = [(f.name, ctypes.c_int if f.type == "int" else ctypes.c_double)
                for f in dataclasses.fields(SolverSettings)]


class Problem(ctypes.Structure):
    _fields_ = [("ndof", ctypes.c_int), ("nflex", ctypes.c_int), ("npoints", ctypes.c_int),
                ("nloads", ctypes.c_int), ("ntendons", ctypes.c_int), ("noutputs", ctypes.c_int),
                ("flex", ctypes.POINTER(Flexure)), ("points", ctypes.POINTER(Point)),
                ("load_point", _c_int_p), ("load", _c_double_p), ("tension", _c_double_p),
                ("route_start", _c_int_p), ("route_len", _c_int_p), ("route", _c_int_p),
                ("outputs", _c_int_p), ("stiffness", _c_double_p), ("settings", Settings),
                ("lapack", Lapack), ("q0", _c_double_p)]


class Answer(ctypes.Structure):
    _fields_ = [("q", _c_double_p), ("pose", _c_double_p), ("compliance", _c_double_p),
                ("stiffness", _c_double_p),
                ("energy", ctypes.c_double), ("residual", ctypes.c_double),
                ("iterations", ctypes.c_int), ("stable", ctypes.c_int),
                ("critical", _c_double_p), ("critical_kind", _c_int_p),
                ("max_critical", ctypes.c_int), ("ncritical", ctypes.c_int),
                ("switched", _c_int_p),
                ("failure", ctypes.c_int), ("failure_load_factor", ctypes.c_double),
                ("last_error", ctypes.c_int), ("last_error_load_factor", ctypes.c_double),
                ("last_error_residual", ctypes.c_double),
                ("last_error_iterations", ctypes.c_int), ("last_error_flexure", ctypes.c_int),
                ("last_error_route", ctypes.c_int), ("model_error", ctypes.c_int),
                ("model_error_flexure", ctypes.c_int), ("model_error_route", ctypes.c_int),
                ("evaluations", ctypes.c_int)]


MODEL_KERNEL, MODEL_FEM, MODEL_PRB = 0, 1, 2
SOLVED, NO_EQUILIBRIUM, MODEL_ERROR = 0, 1, 2
# Answer.failure (FG_FAIL_*) and Answer.last_error / model_error (FG_ERR_*)
FAIL_NONE, FAIL_UNLOADED, FAIL_STEPS, FAIL_BIFURCATION, FAIL_LIMIT = range(5)
(ERR_NONE, ERR_STAGNATION, ERR_NOT_CONVERGED, ERR_LINE_SEARCH, ERR_JUMP, ERR_NONFINITE,
 ERR_KERNEL_RANGE, ERR_TENDON) = range(8)
# Answer.critical_kind: the path snapped through at a limit point, or crossed a bifurcation and
# took the side chosen for the reason equilibrium.BUCKLING_SIDES[kind - 1]
SNAP_THROUGH = 0


def cache_dir() -> Path:
    """$FLEXGEN_CACHE, else ~/.cache/flexgen, else (no writable home) a folder in the temp dir."""
    if os.environ.get("FLEXGEN_CACHE"):
        return Path(os.environ["FLEXGEN_CACHE"])
    home = Path.home() / ".cache" / "flexgen"
    try:
        home.mkdir(parents=True, exist_ok=True)
        if os.access(home, os.W_OK):
            return home
    except OSError:
        pass
    return Path(tempfile.gettempdir()) / f"flexgen-cache-{os.getuid()}"


def _shared_library(source: Path, headers: tuple[Path, ...] = ()) -> ctypes.CDLL:
    """Compile ``source`` (once per content) and load it."""
    digest = hashlib.sha256()
    for path in (source, *headers):
        digest.update(path.read_bytes())
    digest.update(" ".join(kernels.C_FLAGS).encode())
    folder = cache_dir()
    target = folder / f"{source.stem}-{digest.hexdigest()[:16]}.so"
    if not target.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(suffix=".so", dir=folder)
        os.close(fd)
        try:
            proc = kernels.gcc_shared(source, tmp)
        except OSError as exc:
            os.unlink(tmp)
            raise CompileError(f"cannot compile {source.name}: {exc}") from exc
        if proc.returncode != 0:
            os.unlink(tmp)
            first = (proc.stderr.strip().splitlines() or ["gcc failed"])[0]
            raise CompileError(f"cannot compile {source.name}: {first}")
        os.replace(tmp, target)      # atomic: a concurrent build of the same source is harmless
    return ctypes.CDLL(str(target))


@lru_cache(maxsize=None)
def solver_library() -> ctypes.CDLL:
    lib = _shared_library(HERE / "chain_solver.c", (HERE / "chain_solver.h",))
    for name in ("fg_work_size", "fg_iwork_size"):
        fn = getattr(lib, name)
        fn.argtypes = [ctypes.POINTER(Problem)]
        fn.restype = ctypes.c_size_t
    lib.fg_solve.argtypes = [ctypes.POINTER(Problem), _c_double_p, _c_int_p,
                             ctypes.POINTER(Answer)]
    lib.fg_solve.restype = ctypes.c_int
    return lib


@lru_cache(maxsize=None)
def kernel_functions(name: str, folder: Path = kernels.GENERATED) -> tuple[int, int]:
    """Addresses of ``<name>_evaluate`` and ``<name>_in_range`` in the compiled C kernel."""
    source = folder / "c" / f"{name}.c"
    if not source.is_file():
        raise kernels.KernelNotFound(f"C kernel {name!r} not found in {folder}/c")
    lib = _shared_library(source, (folder / "c" / f"{name}.h",))
    _loaded.append(lib)              # keep the library (and so the addresses) alive
    evaluate = ctypes.cast(getattr(lib, f"{name}_evaluate"), ctypes.c_void_p).value
    in_range = ctypes.cast(getattr(lib, f"{name}_in_range"), ctypes.c_void_p).value
    return evaluate, in_range


_loaded: list[ctypes.CDLL] = []

# From this many coordinates on the solver factorizes with LAPACK (the one SciPy ships, the same
# code numpy.linalg and scipy.linalg run for the Python solver); below it the built-in unblocked
# factorizations are faster (no call overhead). Measured with benchmarks/solver_speed.py
# (docs/solver-speed.md): built-in faster at 16 coordinates (fem16), LAPACK from 32 on.
# (SolverSettings.lapack_min_size, the setting the solver reads, defaults to it.)
LAPACK_MIN_SIZE = SolverSettings().lapack_min_size


@lru_cache(maxsize=None)
def lapack() -> Lapack:
    """SciPy's dpotrf, dpotrs, dgetrf, dgetrs and dsyev by address (scipy.linalg.cython_lapack
    exports them as capsules); all None if that fails, and the solver uses its built-in
    factorizations and eigen-decomposition (Jacobi)."""
    table = Lapack()
    try:
        from scipy.linalg import cython_lapack
        name_of = ctypes.pythonapi.PyCapsule_GetName
        name_of.restype, name_of.argtypes = ctypes.c_char_p, [ctypes.py_object]
        pointer = ctypes.pythonapi.PyCapsule_GetPointer
        pointer.restype, pointer.argtypes = ctypes.c_void_p, [ctypes.py_object, ctypes.c_char_p]
        found = {}
        for routine in ("potrf", "potrs", "getrf", "getrs", "syev"):
            capsule = cython_lapack.__pyx_capi__["d" + routine]
            found[routine] = pointer(capsule, name_of(capsule))
    except (ImportError, AttributeError, KeyError, ValueError):
        return table
    table.potrf, table.potrs = found["potrf"], found["potrs"]
    table.getrf, table.getrs = found["getrf"], found["getrs"]
    table.syev = found["syev"]
    return table
