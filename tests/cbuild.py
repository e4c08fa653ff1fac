"""Building C in the tests: the strict flags, and a generated kernel compiled and loaded.

Only the tests compile C; the runtime package never does (tests/test_core_loading.py). Every
library is built into a folder the test owns (pytest's tmp_path), never a shared one.
"""

from __future__ import annotations

import ctypes
import subprocess
from pathlib import Path

from flexgen.kernels import GENERATED

# what the project promises of emitted and shipped C (README, docs/controller.md)
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2"]


def compile_kernel(name: str, build_dir: Path) -> ctypes.CDLL:
    """generated/c/<name>.c built with the strict flags into build_dir/lib<name>.so, loaded,
    with the argument types of its <name>_evaluate, <name>_evaluate_f and <name>_in_range."""
    source = GENERATED / "c" / f"{name}.c"
    library = build_dir / f"lib{name}.so"
    subprocess.run(
        [
            "gcc",
            *STRICT,
            "-shared",
            "-fPIC",
            f"-I{source.parent}",
            str(source),
            "-lm",
            "-o",
            str(library),
        ],
        check=True,
    )
    lib = ctypes.CDLL(str(library))
    double_p, float_p = ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_float)
    for suffix, ptr in (("", double_p), ("_f", float_p)):
        fn = getattr(lib, f"{name}_evaluate{suffix}")
        fn.argtypes = [ptr] * 4
        fn.restype = None
    in_range = getattr(lib, f"{name}_in_range")
    in_range.argtypes = [double_p]
    in_range.restype = ctypes.c_int
    return lib
