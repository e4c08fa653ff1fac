"""The C finger controller example (examples/controller/finger_controller.c) compiles with the
strict flags, embeds the compiled chain solver with the scm3 / scm3_gauss25 kernels, and agrees
with flexgen.solve on examples/two_link_finger.toml, also past a kernel switch; a tendon
tension with no equilibrium ends with the reason (status "no_equilibrium", exit 3)."""

import json
import re
import subprocess
from dataclasses import replace

import numpy as np
import pytest

import flexgen
from flexgen.chain import Chain
from flexgen.kernels import C_FLAGS, GENERATED, load_numpy
from flexgen.models.registry import build_models
from flexgen.scene import load_scene

ROOT = GENERATED.parent
EXAMPLE = ROOT / "examples" / "controller" / "finger_controller.c"
SCENE = ROOT / "examples" / "two_link_finger.toml"
SOLVER = ROOT / "flexgen" / "compiled"
OUTPUTS = ("middle.pad", "fingertip.pad")


def build(exe, *defines):
    subprocess.run(
        [
            "gcc",
            *C_FLAGS,
            *defines,
            f"-I{SOLVER}",
            f"-I{GENERATED / 'c'}",
            str(EXAMPLE),
            str(SOLVER / "chain_solver.c"),
            str(GENERATED / "c" / "scm3.c"),
            str(GENERATED / "c" / "scm3_gauss25.c"),
            "-lm",
            "-o",
            str(exe),
        ],
        check=True,
    )
    return exe


@pytest.fixture(scope="module")
def controller(tmp_path_factory):
    return build(tmp_path_factory.mktemp("finger") / "finger_controller")


def run(exe, *args):
    out = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True, timeout=60)
    return out.returncode, json.loads(out.stdout)


def finger(tension=None, pad_fy=None):
    """The TOML finger, with the tension / pad force replaced."""
    scene = load_scene(SCENE)
    if tension is not None:
        scene = replace(
            scene, tendons=tuple(replace(t, tension=float(tension)) for t in scene.tendons)
        )
    if pad_fy is not None:
        (load,) = scene.loads
        assert load.point == "fingertip.pad"
        scene = replace(scene, loads=(replace(load, force=(load.force[0], float(pad_fy))),))
    return scene


def python_solve(tension=None, pad_fy=None):
    """flexgen.solve's answer for the TOML finger, with the tension / pad force replaced."""
    return flexgen.solve(finger(tension, pad_fy))


def reference_residual(scene, q):
    """|grad of the potential| / the scale of its terms at the packed q, by the reference
    kinematics (flexgen.chain, the NumPy kernels)."""
    chain = Chain(scene, build_models(scene))
    g = chain.energy_gradient(q)
    scale = np.linalg.norm(g)
    gt = chain.tendon_potential(q)[1]
    g, scale = g + gt, scale + np.linalg.norm(gt)
    for ld in scene.loads:
        J = chain.point(ld.point, q).J
        w = J[0] * ld.force[0] + J[1] * ld.force[1] + J[2] * ld.moment
        g, scale = g - w, scale + np.linalg.norm(w)
    return np.linalg.norm(g) / scale


@pytest.mark.parametrize(
    "args, tension, pad_fy",
    [((), None, None), ((0.0, -0.5), 0.0, -0.5), ((12.0,), 12.0, None)],
    ids=["defaults", "slack-tendon", "continuation"],
)
def test_matches_flexgen_solve(controller, args, tension, pad_fy):
    """The full load at once (10 N, 0 N) and, at 12 N, the load continuation (the direct solve's
    path check fails there): the example's hand-filled problem is flexgen's, so the same
    equilibrium, poses, compliances and Newton iterations; and that equilibrium has a zero
    residual in the reference kinematics."""
    code, out = run(controller, *args)
    ref = python_solve(tension, pad_fy)
    assert ref.converged and not ref.warnings
    assert code == 0 and out["status"] == "solved" and out["converged"] is True
    q = np.concatenate([ref.q["proximal"], ref.q["distal"]])
    np.testing.assert_allclose(out["q"], q, rtol=0, atol=1e-9)
    assert set(out["points"]) == set(OUTPUTS)
    for name in OUTPUTS:
        got, want = out["points"][name], ref.points[name]
        np.testing.assert_allclose(got["pose"], want.pose, rtol=0, atol=1e-9)
        np.testing.assert_allclose(got["compliance"], want.compliance, rtol=1e-7, atol=0)
    assert out["iterations"] == ref.iterations
    assert out["us_per_solve"] > 0
    assert reference_residual(finger(tension, pad_fy), np.asarray(out["q"])) <= 1e-10


def test_defaults_are_the_toml_finger(controller):
    """The example's defaults are the TOML's 10 N and -0.2 N: the same answer as given explicitly."""
    scene = load_scene(SCENE)
    (tendon,), (load,) = scene.tendons, scene.loads
    _, default = run(controller)
    _, explicit = run(controller, repr(tendon.tension), repr(load.force[1]))
    assert default["q"] == explicit["q"] and default["points"] == explicit["points"]


def test_energy_weights_are_the_generated_ones():
    source = EXAMPLE.read_text()
    found = re.findall(r"energy_weights\[SCM3_N\]\s*=\s*\{([^}]*)\}", source)
    assert len(found) == 1
    weights = [float(v) for v in found[0].split(",")]
    expected = load_numpy("scm3").ENERGY_WEIGHTS
    assert len(weights) == len(expected)
    np.testing.assert_allclose(weights, expected, rtol=0, atol=1e-15)


def test_a_kernel_switch_is_solved_in_c(controller):
    """15 N bends the distal flexure past the polynomial kernel's range: the Python solver
    switches to the Gauss kernel (and warns); the C solver does the same (the example takes no
    switch flags: answer.switched NULL, not reported) and gives the same answer."""
    ref = python_solve(15.0)
    assert ref.converged and any("switched to the Gauss kernel" in w for w in ref.warnings)
    code, out = run(controller, 15.0)
    assert code == 0 and out["status"] == "solved"
    q = np.concatenate([ref.q["proximal"], ref.q["distal"]])
    np.testing.assert_allclose(out["q"], q, rtol=0, atol=1e-9)
    assert out["iterations"] == ref.iterations


def test_no_equilibrium_exits_3_with_the_reason(controller):
    """At 400 N both flexures pass the polynomial range and the continuation finds no equilibrium
    beyond a load factor of about 0.16: the C solver says so (FG_FAIL_LIMIT, that load factor)."""
    ref = python_solve(400.0)
    assert not ref.converged and ref.reason.startswith("no equilibrium found beyond load factor")
    code, out = run(controller, 400.0)
    assert code == 3
    assert out["status"] == "no_equilibrium" and out["converged"] is False
    assert out["failure"] == 4  # FG_FAIL_LIMIT
    assert out["load_factor"] == ref.load_factor


def test_settings_are_the_python_defaults():
    """default_settings fills every field of fg_settings with flexgen.settings' default."""
    from dataclasses import fields

    from flexgen.settings import DEFAULT

    source = EXAMPLE.read_text()
    found = dict(re.findall(r"s->(\w+) = ([^;]+);", source))
    assert list(found) == [f.name for f in fields(DEFAULT)]
    for f in fields(DEFAULT):
        assert float(found[f.name]) == getattr(DEFAULT, f.name), f.name


def test_bad_arguments_are_refused(controller):
    out = subprocess.run([str(controller), "ten"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and out.stdout == "" and "usage" in out.stderr


def test_a_too_small_workspace_is_refused(tmp_path):
    """The stack workspace is checked against fg_work_size before any solve."""
    exe = build(tmp_path / "finger_controller", "-DWORK_MAX=100")
    out = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 1 and out.stdout == "" and "workspace too small" in out.stderr
