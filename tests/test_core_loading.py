"""Where the solver core comes from: only the package's own extension module, never a library
compiled or cached at run time.

The run-time compile cache is gone. These tests replay the faults it had (a predictable folder in
the shared temp dir that another user could fill first, a truncated or empty cached library, a
read-only or non-folder cache path, no home folder) and check that none of them can matter any
more: the solve works, prints the normal answer, writes nothing, and the only flexgen library
mapped into the process is the package's ``flexgen/_core``.
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

import flexgen
from flexgen import core

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


@pytest.fixture()
def reference() -> float:
    return flexgen.solve(FINGER).points["fingertip.pad"].pose[0]


@pytest.mark.parametrize(
    "fault",
    [
        "no-home",
        "read-only-home",
        "cache-is-a-file",
        "read-only-cache",
        "planted-in-temp",
        "truncated-library",
        "empty-library",
    ],
)
def test_no_library_is_loaded_from_a_cache_whatever_it_holds(fault, tmp_path, reference):
    env = {k: v for k, v in os.environ.items() if not k.startswith("FLEXGEN")}
    home = tmp_path / "home"
    home.mkdir()
    env["HOME"] = str(home)
    env["TMPDIR"] = str(tmp_path / "tmp")
    (tmp_path / "tmp").mkdir()
    cache = tmp_path / "cache"
    if fault == "no-home":
        env.pop("HOME")
    elif fault == "read-only-home":
        home.chmod(stat.S_IRUSR | stat.S_IXUSR)
    elif fault == "cache-is-a-file":
        cache.write_text("not a folder")
        env["FLEXGEN_CACHE"] = str(cache)
    elif fault == "read-only-cache":
        cache.mkdir()
        cache.chmod(stat.S_IRUSR | stat.S_IXUSR)
        env["FLEXGEN_CACHE"] = str(cache)
    elif fault == "planted-in-temp":  # the old fallback folder, filled by someone else
        planted_library(tmp_path / "tmp" / f"flexgen-cache-{os.getuid()}", b"\x7fELF" + b"x" * 64)
    elif fault == "truncated-library":
        planted_library(home / ".cache" / "flexgen", b"\x7fELF\x02\x01\x01")
        env["FLEXGEN_CACHE"] = str(home / ".cache" / "flexgen")
    elif fault == "empty-library":
        planted_library(cache, b"")
        env["FLEXGEN_CACHE"] = str(cache)
    before = sorted(p for p in tmp_path.rglob("*"))
    got = probe(env, tmp_path)
    home.chmod(stat.S_IRWXU)
    assert got["converged"] and got["x"] == reference
    flexgen_libs = [Path(m) for m in got["maps"] if "flexgen" in m or str(tmp_path) in m]
    assert len(flexgen_libs) == 1, flexgen_libs
    assert flexgen_libs[0].name.startswith("_core.")
    assert flexgen_libs[0].parent == Path(core.__file__).parent
    assert sorted(p for p in tmp_path.rglob("*")) == before  # nothing written


def test_the_runtime_never_compiles_or_loads_a_library_by_path():
    """No module of the runtime package runs a compiler or dlopens a file: the core is the
    extension module, imported like any other (kernels.compile_c, for tests and benchmarks,
    compiles into a folder its caller owns and is not used by the solver)."""
    runtime = [
        p
        for p in (ROOT / "flexgen").rglob("*.py")
        if p.name not in ("_build_core.py", "kernels.py")
    ]
    for path in runtime:
        text = path.read_text()
        for needle in ("CDLL(", "gcc_shared", "compile_c(", "subprocess"):
            assert needle not in text, f"{path.relative_to(ROOT)} uses {needle}"
