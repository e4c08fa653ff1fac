"""The package as a user installs it: build a wheel, install it into a fresh virtual environment,
and from another folder (with no compiler on PATH) solve every example scene and generate a
kernel. This is the only test that sees flexgen as installed software rather than a checkout.

It needs the package index for the build requirements and the dependencies (pip's cache makes
repeated runs quick); set FLEXGEN_SKIP_WHEEL_TEST=1 to skip it offline.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))

pytestmark = pytest.mark.skipif(
    os.environ.get("FLEXGEN_SKIP_WHEEL_TEST") == "1", reason="FLEXGEN_SKIP_WHEEL_TEST=1"
)


def run(cmd, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kw)


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(venv folder, wheel path) of a wheel built from this checkout, installed fresh."""
    tmp = tmp_path_factory.mktemp("wheel")
    # build from a copy of the sources: a checkout's build/ folder may hold stale modules
    # that setuptools would pack into the wheel
    src = tmp / "src"
    shutil.copytree(
        ROOT,
        src,
        ignore=shutil.ignore_patterns(
            ".git", "build", "*.egg-info", "__pycache__", "*.so", ".pytest_cache", ".bench"
        ),
    )
    built = run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", tmp / "dist", src], cwd=tmp
    )
    assert built.returncode == 0, built.stderr[-3000:]
    wheel = next((tmp / "dist").glob("flexgen-*.whl"))
    venv = tmp / "venv"
    made = run([sys.executable, "-m", "venv", venv])
    assert made.returncode == 0, made.stderr
    got = run([venv / "bin" / "python", "-m", "pip", "install", "-q", wheel])
    assert got.returncode == 0, got.stderr[-3000:]
    return venv, wheel


def user_env(venv: Path) -> dict[str, str]:
    """A user's shell: the venv's bin first and nothing else on PATH (so no gcc), a home of
    its own."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "FLEXGEN"))}
    env["PATH"] = str(venv / "bin")
    return env


def test_wheel_ships_the_core_the_kernels_and_the_templates(installed):
    _, wheel = installed
    names = zipfile.ZipFile(wheel).namelist()
    assert any(n.startswith("flexgen/_core") and n.endswith(".so") for n in names)
    for rel in (
        "generated/numpy/scm3.py",
        "generated/c/scm3.c",
        "generated/c/scm3_gauss25.h",
        "templates/c/kernel.c.jinja",
        "templates/numpy/kernel.py.jinja",
        "templates/controller/controller.c.jinja",
        "compiled/chain_solver.c",
        "py.typed",
    ):
        assert f"flexgen/{rel}" in names, rel
    assert not any(n.startswith(("generated/", "templates/", "tests/")) for n in names)
    # the deleted Python twin of the solver is not shipped (a stale build/ would bring it back)
    assert not any(
        n.endswith(("equilibrium.py", "compiled/plan.py", "compiled/library.py")) for n in names
    )
    assert any(n.endswith("LICENSE") for n in names)


def test_installed_package_solves_every_example_from_another_folder(installed, tmp_path):
    venv, _ = installed
    env = user_env(venv)
    env["HOME"] = str(tmp_path / "home")
    (tmp_path / "home").mkdir()
    where = run(
        [venv / "bin" / "python", "-c", "import flexgen; print(flexgen.__file__)"],
        cwd=tmp_path,
        env=env,
    )
    assert where.returncode == 0, where.stderr
    assert str(venv) in where.stdout  # the wheel's copy, not the checkout
    for scene in EXAMPLES:
        out = run([venv / "bin" / "flexgen", "solve", scene, "--json"], cwd=tmp_path, env=env)
        assert out.returncode in (0, 1), (scene.name, out.stderr)
        data = json.loads(out.stdout)
        assert data["converged"] is (out.returncode == 0), scene.name
        assert "Traceback" not in out.stderr
    # nothing was compiled or cached anywhere: the home folder and the run folder stay empty
    assert list((tmp_path / "home").iterdir()) == []


def test_installed_cli_generates_a_kernel_and_reports_its_version(installed, tmp_path):
    venv, _ = installed
    env = user_env(venv)
    out = run(
        [venv / "bin" / "flexgen", "generate", "--modes", "4", "--out", "X"], cwd=tmp_path, env=env
    )
    assert out.returncode == 0, out.stderr[-2000:]
    for rel in ("numpy/scm4.py", "c/scm4.c", "c/scm4.h"):
        assert (tmp_path / "X" / rel).is_file(), rel
    shipped = run(
        [venv / "bin" / "python", "-c", "import flexgen.kernels as k; print(k.GENERATED)"],
        cwd=tmp_path,
        env=env,
    )
    # the regenerated kernel equals the one shipped in the package, byte for byte
    gen = Path(shipped.stdout.strip())
    assert (tmp_path / "X" / "c" / "scm4.c").read_text() == (gen / "c" / "scm4.c").read_text()
    # a scene's controller from the installed package: the same files as from this checkout
    scene = next(s for s in EXAMPLES if s.name == "two_link_finger.toml")
    out = run(
        [venv / "bin" / "flexgen", "generate", "--scene", scene, "--out", "C"],
        cwd=tmp_path,
        env=env,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    from flexgen.codegen.controller import controller_files

    for name, text in controller_files(scene).items():
        assert (tmp_path / "C" / name).read_text() == text, name
    version = run([venv / "bin" / "flexgen", "--version"], cwd=tmp_path, env=env)
    assert version.returncode == 0 and version.stdout.startswith("flexgen ")
