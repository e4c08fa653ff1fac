"""Find and load the generated kernels (NumPy modules); name them.

Generated modules never import flexgen; flexgen loads them from ``generated/`` by file path, so
they need not be on sys.path. Kernel names: ``scm{N}`` (polynomial, 90 degrees),
``scm{N}_gauss{G}`` (Gauss-Legendre quadrature certified on a range) and ``scm{N}_local{G}``
(Gauss-Legendre quadrature certified at each q).
"""

from __future__ import annotations

import importlib.util
import os
import re
from functools import cache, lru_cache
from pathlib import Path
from types import ModuleType

_PACKAGE = Path(__file__).resolve().parent
# installed: the package's own copy (flexgen/generated); a source checkout: the top-level folder
GENERATED = (
    _PACKAGE / "generated" if (_PACKAGE / "generated").is_dir() else _PACKAGE.parent / "generated"
)
_NAME = re.compile(r"^scm(\d+)(?:_(gauss|local)(\d+))?$")


class KernelNotFound(LookupError):
    """No generated kernel of that name; the message says how to generate one."""


def available(folder: Path = GENERATED) -> list[str]:
    """Names of the NumPy kernels in folder/numpy, sorted by modes then family."""
    names = [p.stem for p in (folder / "numpy").glob("scm*.py") if _NAME.match(p.stem)]
    return sorted(names, key=lambda n: (int(_kernel_match(n)[1]), n))


def name_parts(name: str) -> tuple[int, str, int | None] | None:
    """(modes, family, nodes) of a kernel name (``scm3_local9``: 3, "local", 9; ``scm3``: 3,
    "poly", None); None if it is not a kernel name."""
    match = _NAME.match(name)
    if match is None:
        return None
    return int(match[1]), match[2] or "poly", int(match[3]) if match[3] else None


def _kernel_match(name: str) -> re.Match[str]:
    """The _NAME match of a name already filtered by _NAME (so it matches)."""
    match = _NAME.match(name)
    assert match is not None, name
    return match


def gauss_kernel_name(modes: int, folder: Path = GENERATED, family: str = "gauss") -> str:
    """The Gauss kernel for this many modes with the most nodes (the most accurate); with
    ``family="local"``, the local kernel (certified at each q) with the most nodes.

    The folder is scanned once per (folder, its modification time): a kernel generated into it
    later (``flexgen generate`` writes the file, which updates the folder's mtime) is seen."""
    numpy_dir = _NUMPY_DIRS.get(folder)
    if numpy_dir is None:
        numpy_dir = _NUMPY_DIRS[folder] = os.path.join(os.fspath(folder), "numpy")
    try:
        stamp = os.stat(numpy_dir).st_mtime_ns
    except OSError:
        stamp = None
    return _gauss_kernel_name(modes, folder, stamp, family)


def kernel_name(modes: int, family: str = "poly", folder: Path = GENERATED) -> str:
    """The shipped kernel of a family for this many modes: ``scm{N}`` (poly), else the Gauss or
    local kernel with the most nodes (``gauss_kernel_name``)."""
    if family == "poly":
        return f"scm{modes}"
    return gauss_kernel_name(modes, folder, family)


_NUMPY_DIRS: dict = {}


@lru_cache(maxsize=256)
def _gauss_kernel_name(modes: int, folder: Path, stamp, family: str) -> str:
    found = [
        n
        for n in available(folder)
        if _kernel_match(n)[1] == str(modes) and _kernel_match(n)[2] == family
    ]
    if not found:
        what = "Gauss" if family == "gauss" else "local Gauss"
        raise KernelNotFound(
            f"no {what} kernel for {modes} modes in {folder}/numpy; run "
            f"`flexgen generate --modes {modes} --kernel {family}`"
        )
    return max(found, key=lambda n: int(_kernel_match(n)[3]))


@cache
def load_numpy(name: str, folder: Path = GENERATED) -> ModuleType:
    """Import generated/numpy/<name>.py as a module."""
    path = folder / "numpy" / f"{name}.py"
    if not path.is_file():
        match = _NAME.match(name)
        hint = (
            f"`flexgen generate --modes {match[1]}"
            + (f" --kernel {match[2]} --nodes {match[3]}`" if match and match[2] else "`")
            if match
            else "a name like scm3 or scm3_gauss25"
        )
        raise KernelNotFound(
            f"kernel {name!r} not found in {folder}/numpy; generate it with {hint}"
        )
    spec = importlib.util.spec_from_file_location(f"flexgen_generated_{name}", path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load kernel {name!r} from {path} as a module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
