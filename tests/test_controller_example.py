"""The C controller example compiles with the strict flags, embeds scm3, and agrees with the
Python runtime and with the exact elastica (Bisshopp-Drucker alpha = 2, the 90-degree arc)."""

import json
import subprocess

import numpy as np
import pytest
from cbuild import STRICT

from flexgen.api import solve
from flexgen.kernels import GENERATED
from flexgen.scene import scene_from_dict

EXAMPLE = GENERATED.parent / "examples" / "controller" / "flexure_controller.c"


@pytest.fixture(scope="module")
def controller(tmp_path_factory):
    exe = tmp_path_factory.mktemp("controller") / "flexure_controller"
    subprocess.run(
        [
            "gcc",
            *STRICT,
            f"-I{GENERATED / 'c'}",
            str(EXAMPLE),
            str(GENERATED / "c" / "scm3.c"),
            "-lm",
            "-o",
            str(exe),
        ],
        check=True,
    )
    return exe


def run(exe, *args):
    out = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True)
    return out.returncode, json.loads(out.stdout)


def python_solve(force, moment):
    scene = scene_from_dict(
        {
            "model": {"kind": "scm", "modes": 3, "kernel": "poly"},
            "flexure": [{"name": "f", "length": 2.0, "EI": 3.0}],
            "load": [{"point": "f.tip", "force": list(force), "moment": moment}],
        }
    )
    return solve(scene).points["f.tip"]


def test_tip_load_matches_bisshopp_drucker_and_the_runtime(controller):
    L, EI = 2.0, 3.0
    P = 2.0 * EI / L**2  # alpha = 2
    code, out = run(controller, L, EI, 0.0, -P, 0.0)
    assert code == 0 and out["converged"] and out["in_range"]
    x, y, theta = out["pose"]
    # exact elastica (model-notes.md); 3 modes are within 2e-5 L of it here
    assert abs(x / L - 0.83936) < 2e-5 and abs(-y / L - 0.49346) < 2e-5
    assert abs(-theta - 0.78175) < 2e-5
    point = python_solve((0.0, -P), 0.0)
    np.testing.assert_allclose(out["pose"], point.pose, atol=1e-9)
    np.testing.assert_allclose(out["compliance"], point.compliance, rtol=1e-7)


def test_arc_compliance_matches_the_exact_eigenvalues(controller):
    code, out = run(controller, 1.0, 1.0, 0.0, 0.0, np.pi / 2)
    assert code == 0
    eig = np.linalg.eigvalsh(np.array(out["compliance"]))
    np.testing.assert_allclose(eig[::-1], [0.2876591, 0.0068858], rtol=2e-3)


def test_out_of_range_is_reported(controller):
    code, out = run(controller, 1.0, 1.0, 0.0, 0.0, 2.5)  # a 143-degree arc
    assert code == 1 and out["in_range"] == 0
