"""The shipped C headers work from C++: a C++ program includes the solver core's header and a
kernel's, links the objects gcc compiled from the C sources with the strict flags, and calls
both (the headers' extern "C" guards are what makes the symbols link)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from cbuild import STRICT

from flexgen import kernels

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "flexgen" / "compiled"

PROGRAM = r"""
#include <cstdio>
#include "chain_solver.h"
#include "scm3.h"

int main() {
    double q[3] = {0.5, -0.1, 0.02}, pose[3], J[9], H[27];
    scm3_evaluate(q, pose, J, H);
    std::printf("%.17g %.17g %.17g %d\n", pose[0], pose[1], pose[2], scm3_in_range(q));
    double C[4] = {2.0, 0.5, 0.5, 1.0}, e[3];
    fg_ellipse(C, 1e-14, e);
    std::printf("%.17g\n", e[0]);
    return 0;
}
"""


@pytest.mark.skipif(
    shutil.which("g++") is None or shutil.which("gcc") is None, reason="needs gcc and g++"
)
def test_cplusplus_includes_and_links_the_core_and_a_kernel(tmp_path):
    gen = kernels.GENERATED / "c"
    objects = []
    for src in (CORE / "chain_solver.c", gen / "scm3.c"):
        obj = tmp_path / (src.stem + ".o")
        subprocess.run(
            ["gcc", *STRICT, f"-I{CORE}", f"-I{gen}", "-c", str(src), "-o", str(obj)], check=True
        )
        objects.append(str(obj))
    cpp = tmp_path / "main.cpp"
    cpp.write_text(PROGRAM)
    exe = tmp_path / "main"
    build = subprocess.run(
        [
            "g++",
            "-Wall",
            "-Wextra",
            "-Werror",
            f"-I{CORE}",
            f"-I{gen}",
            str(cpp),
            *objects,
            "-lm",
            "-o",
            str(exe),
        ],
        capture_output=True,
        text=True,
    )
    assert build.returncode == 0, build.stderr
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    pose, J, H = kernels.load_numpy("scm3").evaluate(__import__("numpy").array([0.5, -0.1, 0.02]))
    assert [float(x) for x in out[:3]] == pytest.approx(list(pose), rel=0, abs=1e-15)
    assert out[3] == "1"
    assert float(out[4]) == pytest.approx((3 + 2**0.5) / 2, rel=1e-15)
