"""Build recipe of the extension module ``flexgen._core`` (run by setuptools at install time).

cffi in API mode compiles the chain solver (``chain_solver.c``) and every shipped C kernel
(``generated/c/*.c``) into one extension module, so an installed flexgen needs no compiler and
loads no library from any folder but its own. ``chain_solver.h`` is the one definition of the
solver's structs: its text (preprocessor lines removed) is the cffi declaration, so Python fills
the structs by field name and nothing mirrors them by hand. The kernels are declared by name
(``<kernel>_evaluate``, ``<kernel>_in_range``): the solver takes them as function pointers.

Used from setup.py (``cffi_modules``); paths are relative to the project root, as setuptools
wants them.
"""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

from cffi import FFI

ROOT = Path(__file__).resolve().parents[2]
SOLVER = Path("flexgen") / "compiled"
KERNELS = Path("generated") / "c"

# Python's own CFLAGS, which extensions inherit, carry -fwrapv (signed overflow defined to wrap).
# It keeps GCC from vectorizing a loop whose int index starts at another's (j + 1 .. n: the
# triangular solves, the stiffness rows), as it does without; the solver and kernels do not rely
# on wrapping (the emitted controller compiles without the flag).
EXTRA_COMPILE_ARGS = [] if sys.platform == "win32" else ["-fno-wrapv"]


def kernel_names() -> list[str]:
    """The shipped C kernels (generated/c/<name>.c with its header), sorted."""
    return sorted(
        p.stem
        for p in (ROOT / KERNELS).glob("scm*.c")
        if (ROOT / KERNELS / f"{p.stem}.h").is_file()
    )


def solver_declarations() -> str:
    """chain_solver.h without its preprocessor lines, C++ guards and linkage macro (cffi's cdef
    syntax)."""
    text = (ROOT / SOLVER / "chain_solver.h").read_text()
    text = re.sub(r"#ifdef __cplusplus.*?#endif", "", text, flags=re.S)
    text = text.replace("FG_API ", "")  # the linkage macro: external in the core
    text = text.replace("typedef FG_REAL fg_real;", "typedef double fg_real;")
    return "\n".join(line for line in text.splitlines() if not line.lstrip().startswith("#"))


def kernel_declarations(names: list[str]) -> str:
    return "\n".join(
        f"void {n}_evaluate(const double *q, double *pose, double *J, double *H);\n"
        f"int {n}_in_range(const double *q);"
        for n in names
    )


def sources_digest() -> str:
    """The digest of the C sources (digest.py beside this file, loaded by path: flexgen itself
    cannot be imported before its core is built), compiled into the core so that a stale build
    is an error, not an old answer."""
    spec = importlib.util.spec_from_file_location(
        "flexgen_digest", Path(__file__).with_name("digest.py")
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.sources_digest(ROOT / SOLVER, ROOT / KERNELS)


def make_ffi() -> FFI:
    names = kernel_names()
    ffi = FFI()
    ffi.cdef(
        solver_declarations()
        + "\n"
        + kernel_declarations(names)
        + "\nconst char *fg_sources_digest(void);"
    )
    includes = "\n".join(f'#include "{n}.h"' for n in ["chain_solver", *names])
    includes += f'\nconst char *fg_sources_digest(void) {{ return "{sources_digest()}"; }}'
    ffi.set_source(
        "flexgen._core",
        includes,
        sources=[str(SOLVER / "chain_solver.c"), *(str(KERNELS / f"{n}.c") for n in names)],
        include_dirs=[str(SOLVER), str(KERNELS)],
        libraries=["m"],
        extra_compile_args=EXTRA_COMPILE_ARGS,
    )
    return ffi


ffibuilder = make_ffi()

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
