"""Where the solver core comes from: only the package's own extension module, never a library
compiled or loaded at run time from any other folder.

The run-time compile cache is gone; the libraries it would have found are planted where it looked
(the shared temp dir, the home folder's cache), and the solve must work, write nothing and map
no flexgen library but the package's ``flexgen/_core``. No module of the runtime package (nor a
generated kernel it loads) may run a compiler or load a library by path.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import flexgen
from flexgen import core, kernels

ROOT = Path(__file__).resolve().parents[1]
FINGER = ROOT / "examples" / "two_link_finger.toml"

# a solve, then every shared object mapped into the process, as JSON on stdout
PROBE = """
import json, sys, flexgen
r = flexgen.solve(sys.argv[1])
maps = sorted({line.split()[-1] for line in open('/proc/self/maps')
               if line.rstrip().endswith('.so') or '.so.' in line.split()[-1]})
print(json.dumps({'converged': r.converged, 'x': r.points['fingertip.pad'].pose[0],
                  'maps': maps}))
"""


def probe(env: dict[str, str], cwd: Path) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(FINGER)], capture_output=True, text=True, env=env, cwd=cwd
    )
    assert out.returncode == 0, out.stderr
    assert "Traceback" not in out.stderr
    return json.loads(out.stdout)


def planted_library(folder: Path, content: bytes) -> None:
    """What another user (or a crash) could leave where the old cache looked for libraries."""
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("chain_solver-0123456789abcdef.so", "scm3-0123456789abcdef.so"):
        (folder / name).write_bytes(content)


def test_no_library_is_loaded_from_where_the_old_cache_looked(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith("FLEXGEN")}
    home, tmp = tmp_path / "home", tmp_path / "tmp"
    env["HOME"], env["TMPDIR"] = str(home), str(tmp)
    # an ELF header and garbage: loading either would fail the solve or show in the maps
    planted_library(tmp / f"flexgen-cache-{os.getuid()}", b"\x7fELF" + b"x" * 64)
    planted_library(home / ".cache" / "flexgen", b"\x7fELF\x02\x01\x01")
    before = sorted(tmp_path.rglob("*"))
    got = probe(env, tmp_path)
    assert got["converged"] and got["x"] == flexgen.solve(FINGER).points["fingertip.pad"].pose[0]
    flexgen_libs = [Path(m) for m in got["maps"] if "flexgen" in m or str(tmp_path) in m]
    assert len(flexgen_libs) == 1, flexgen_libs
    assert flexgen_libs[0].name.startswith("_core.")
    assert flexgen_libs[0].parent == Path(core.__file__).parent
    assert sorted(tmp_path.rglob("*")) == before  # nothing written


# running a program, or loading a shared library by path (``re.compile`` is not a compiler)
RUNS_OR_LOADS = re.compile(
    r"\bCDLL\b|\bcdll\b|PyDLL|LoadLibrary|dlopen|find_library|\bsubprocess\b|os\.system|"
    r"os\.exec|os\.spawn|os\.popen|Popen|ccompiler|\bffi\w*\.compile\(|\.verify\("
)


def test_the_runtime_never_compiles_or_loads_a_library_by_path():
    """Every module of the runtime package and every generated kernel it loads. The one exception
    is the build recipe ``flexgen/compiled/_build_core.py``, which setuptools runs at install time
    (setup.py) and which no runtime module imports."""
    build_recipe = ROOT / "flexgen" / "compiled" / "_build_core.py"
    runtime = [p for p in (ROOT / "flexgen").rglob("*.py") if p != build_recipe]
    runtime += sorted((kernels.GENERATED / "numpy").glob("*.py"))
    assert len(runtime) > 50
    for path in runtime:
        text = path.read_text()
        found = RUNS_OR_LOADS.search(text)
        assert found is None, f"{path}: {found[0] if found else ''}"
        assert not re.search(r"import\s+_build_core|from\s+\S*_build_core\s+import", text), path


@pytest.mark.parametrize(
    "code",
    [
        "lib = ctypes.CDLL(str(library))",  # the compile-and-load code kernels.py had
        "subprocess.run(['gcc', str(source)])",
        "ffi.dlopen(path)",
        "ffibuilder.compile(verbose=True)",
    ],
)
def test_the_guard_rejects_compiling_and_loading(code):
    assert RUNS_OR_LOADS.search(code)


def test_the_guard_accepts_a_regular_expression():
    assert RUNS_OR_LOADS.search("_NAME = re.compile(r'x')") is None
