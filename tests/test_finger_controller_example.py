"""The checked-in finger controller (examples/controller/two_link_finger, emitted by `flexgen
generate --scene examples/two_link_finger.toml`): a fresh emission reproduces it byte for byte,
it compiles with the strict flags, and a control loop over tendon tensions and pad forces agrees
with flexgen.solve: slack, the scene's 10 N, a distal flexure bent past the polynomial kernel's
90 degrees (the Gauss kernel answers; at 60 N past its certified 180 degrees, flagged as the library warns), and a tension with no equilibrium (the same failure)."""

from __future__ import annotations

import shutil
import subprocess
from dataclasses import replace

import numpy as np
import pytest
from cbuild import STRICT

import flexgen
from flexgen.codegen.controller import controller_files
from flexgen.kernels import GENERATED, load_numpy

ROOT = GENERATED.parent
FOLDER = ROOT / "examples" / "controller" / "two_link_finger"
SCENE = ROOT / "examples" / "two_link_finger.toml"

LOOP = r"""
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "two_link_finger.h"
/* argv: tension and pad force y pairs; one line per pair, warm state kept between them */
int main(int argc, char **argv)
{
    two_link_finger_inputs in;
    two_link_finger_state state;
    two_link_finger_outputs out;
    int k, status;
    memset(&state, 0, sizeof state);
    two_link_finger_inputs_default(&in);
    for (k = 1; k + 1 < argc; k += 2) {
        in.tension[0] = atof(argv[k]);
        in.load[TWO_LINK_FINGER_LOAD_FINGERTIP_PAD][1] = atof(argv[k + 1]);
        status = two_link_finger_solve(&in, &state, &out);
        printf("%d %d %.17g %.17g %.17g %.17g %d %d %.17g %.17g\n", status, out.failure,
               out.pose[TWO_LINK_FINGER_OUT_FINGERTIP_PAD][0],
               out.pose[TWO_LINK_FINGER_OUT_FINGERTIP_PAD][1],
               out.compliance[TWO_LINK_FINGER_OUT_FINGERTIP_PAD][1][1],
               out.bend[TWO_LINK_FINGER_FLEX_DISTAL], out.kernel[TWO_LINK_FINGER_FLEX_DISTAL],
               out.flags, out.failure_load_factor,
               out.kernel_error[TWO_LINK_FINGER_FLEX_DISTAL]);
    }
    return 0;
}
"""


def test_checked_in_controller_is_a_fresh_emission():
    files = controller_files(SCENE)
    assert sorted(files) == sorted(p.name for p in FOLDER.iterdir())
    for name, text in files.items():
        assert (FOLDER / name).read_text() == text, f"{name} is stale: run `make regen`"


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_control_loop_agrees_with_flexgen_solve(tmp_path):
    (tmp_path / "loop.c").write_text(LOOP)
    exe = tmp_path / "loop"
    sources = [str(FOLDER / "two_link_finger.c"), str(tmp_path / "loop.c")]
    subprocess.run(["gcc", *STRICT, f"-I{FOLDER}", *sources, "-lm", "-o", str(exe)], check=True)
    cases = [(0.0, -0.2), (10.0, -0.2), (10.0, -0.3), (30.0, 0.0), (60.0, -0.2), (400.0, -0.2)]
    args = [str(v) for case in cases for v in case]
    rows = subprocess.check_output([str(exe), *args], text=True).splitlines()
    scene = flexgen.load_scene(SCENE)
    kernels_seen = set()
    failures = 0
    for (tension, fy), row in zip(cases, rows):
        status, failure, x, y, cyy, bend, kernel, flags, lam, kerr = row.split()
        s = replace(
            scene,
            tendons=(replace(scene.tendons[0], tension=tension),),
            loads=(replace(scene.loads[0], force=(0.0, fy)),),
        )
        r = flexgen.solve(s)
        assert (status == "0") == r.converged, (tension, fy, r.reason, row)
        if not r.converged:
            failures += 1
            assert int(failure) > 0 and float(lam) < 1.0
            assert f"{float(lam):.4g}"[:4] in r.reason or "load factor" in r.reason
            continue
        ref = r.points["fingertip.pad"]
        assert abs(float(x) - ref.pose[0]) < 1e-12 * 0.02
        assert abs(float(y) - ref.pose[1]) < 1e-12 * 0.02
        assert float(cyy) == pytest.approx(ref.compliance[1][1], rel=1e-10)
        assert float(bend) == pytest.approx(r.bend["distal"], rel=1e-12)
        kernels_seen.add(int(kernel))
        # the kernel's certified pose bound times the distal flexure's length (15 mm)
        kernel_of = {1: "scm3", 3: "scm3_gauss25", 5: "scm3_local9"}
        bound = load_numpy(kernel_of[int(kernel)]).ERROR_BOUND
        assert float(kerr) == pytest.approx(bound * 0.015, rel=1e-6)
        warned = " ".join(r.warnings)
        past = "error bound does not hold" in warned or "wrong by any amount" in warned
        assert bool(int(flags) & 1) == past, (tension, warned)  # 60 N: proximal past 180 deg
        if int(flags) & 8:
            assert "no accuracy is claimed" in warned
    assert failures == 1  # 400 N: no equilibrium
    # the local kernel, and the Gauss kernel past what it certifies and past 90 degrees
    assert kernels_seen >= {5, 3}
    np.testing.assert_equal(len(rows), len(cases))


FAILING = r"""
#include <stdio.h>
#include <string.h>
#include <time.h>
#include "two_link_finger.h"
/* the finger at a tension of 100 N, cold: status, failure, evaluations, milliseconds */
int main(void)
{
    two_link_finger_inputs in;
    static two_link_finger_state state;
    two_link_finger_outputs out;
    clock_t start;
    int status;
    two_link_finger_inputs_default(&in);
    in.tension[0] = 100.0;
    state.solved = 0;
    start = clock();
    status = two_link_finger_solve(&in, &state, &out);
    printf("%d %d %d %.3f\n", status, out.failure, out.evaluations,
           1e3 * (double)(clock() - start) / CLOCKS_PER_SEC);
    return 0;
}
"""


def evaluation_bound(s) -> int:
    """The most chain evaluations one NAME_solve may make under the settings ``s``, as the core
    (flexgen/compiled/chain_solver.c) spends them; docs/controller.md, "Worst-case time"."""
    newton = 1 + s.max_iterations * s.line_search_halvings  # its start, then line searches
    descent = 1 + s.descent_iteration_factor * s.max_iterations * (
        s.line_search_halvings + s.expansion_doublings
    )
    direct = min(s.direct_max_iterations, s.max_iterations) * s.line_search_halvings
    bifurcation = s.bracket_iterations * newton + 2 * descent
    step = 2 * newton + max(bifurcation, descent)
    return newton + 1 + direct + s.direct_samples + s.max_steps * step + s.polish_steps


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_a_failed_solve_is_costly_and_within_the_bound(tmp_path):
    """The worst case docs/controller.md quotes: the finger at 100 N has no equilibrium
    (FAIL_LIMIT, as flexgen.solve), found after tens of thousands of chain evaluations (printed
    with the time: pytest -s), within the bound the settings imply (146,553,868)."""
    from flexgen.settings import DEFAULT

    bound = evaluation_bound(DEFAULT)
    assert bound == 146_553_868  # the number docs/controller.md states
    doc = (ROOT / "docs" / "controller.md").read_text()
    assert f"{bound:,}" in doc
    (tmp_path / "failing.c").write_text(FAILING)
    exe = tmp_path / "failing"
    sources = [str(FOLDER / "two_link_finger.c"), str(tmp_path / "failing.c")]
    subprocess.run(["gcc", *STRICT, f"-I{FOLDER}", *sources, "-lm", "-o", str(exe)], check=True)
    status, failure, evaluations, ms = subprocess.check_output([str(exe)], text=True).split()
    print(f"finger at 100 N: {evaluations} evaluations, {ms} ms, status {status}")
    scene = flexgen.load_scene(SCENE)
    r = flexgen.solve(replace(scene, tendons=(replace(scene.tendons[0], tension=100.0),)))
    assert not r.converged and (int(status), int(failure)) == (1, 4)  # FAIL_LIMIT
    assert 10_000 < int(evaluations) <= bound
