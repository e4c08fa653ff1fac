"""Argument checks of the Python API and of `flexgen solve`: what one front door refuses, the
others refuse too, with one line naming the option (docs/solve.md, Python API).

- ``flexgen.solve``: ``tolerance`` with ``modes``/``elements`` (as ``--tol`` with ``--modes``),
  a count the model kind does not use (``model="cc", modes=3``), a non-bool ``estimate``;
- ``flexgen.Solver(...).solve``: loads, tensions and q0 checked as the scene and
  ``flexgen.solve`` check them; ``flexgen.Solver(models=...)`` as ``flexgen.solve``;
- ``flexgen solve --model cc --modes 3``: exit 2, one line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import flexgen
from flexgen.cli import main
from flexgen.models.registry import build_model

EX = Path(__file__).resolve().parents[1] / "examples"
FINGER = EX / "two_link_finger.toml"


@pytest.fixture(scope="module")
def finger():
    return flexgen.load_scene(FINGER)


def one_line(exc: pytest.ExceptionInfo) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


# ---- tolerance with modes or elements ---------------------------------------------------------


@pytest.mark.parametrize("count", [{"modes": 3}, {"elements": 8}], ids=["modes", "elements"])
def test_tolerance_with_modes_or_elements_is_refused(finger, count):
    """The selection would choose the modes and drop the count given (it did, silently)."""
    with pytest.raises(ValueError) as exc:
        flexgen.solve(finger, tolerance=1e-6, **count)
    text = one_line(exc)
    assert text.startswith("tolerance:") and next(iter(count)) in text


def test_modes_still_clear_the_scenes_tolerance(tmp_path):
    """A tolerance of the scene file gives way to modes given as a keyword (documented)."""
    path = tmp_path / "finger.toml"  # a scene gives modes or a tolerance, not both
    path.write_text(FINGER.read_text().replace("modes = 3", "tolerance = 1e-4"))
    scene = flexgen.load_scene(path)
    assert flexgen.solve(scene).tolerance == 1e-4  # the scene's tolerance selects the modes
    r = flexgen.solve(scene, modes=2)
    assert r.tolerance is None
    assert {spec["modes"] for spec in r.model.values()} == {2}


# ---- a count the model kind does not use ------------------------------------------------------


@pytest.mark.parametrize(
    "kw, option",
    [
        (dict(model="cc", modes=3), "modes"),
        (dict(model="prb", modes=3), "modes"),
        (dict(model="fem", modes=3), "modes"),
        (dict(model="scm", elements=8), "elements"),
        (dict(model="cc", elements=8), "elements"),
    ],
)
def test_a_count_the_model_does_not_use_is_refused(finger, kw, option):
    with pytest.raises(flexgen.SceneError) as exc:
        flexgen.solve(finger, **kw)
    text = one_line(exc)
    assert text.startswith(f"{option}:") and repr(kw["model"]) in text
    with pytest.raises(flexgen.SceneError, match=f"^{option}:"):
        flexgen.Solver(finger, **kw)


def test_counts_the_model_uses_are_still_applied(finger):
    assert flexgen.solve(finger, model="scm", modes=5).model["proximal"]["modes"] == 5
    assert flexgen.solve(finger, model="fem", elements=8).model["proximal"]["elements"] == 8


@pytest.mark.parametrize(
    "args, option",
    [
        (["--model", "cc", "--modes", "3"], "--modes"),
        (["--model", "fem", "--modes", "3"], "--modes"),
        (["--model", "prb", "--elements", "4"], "--elements"),
    ],
)
@pytest.mark.parametrize("command", ["solve", "plot"])
def test_cli_refuses_a_count_the_model_does_not_use(capsys, tmp_path, command, args, option):
    out = ["-o", str(tmp_path / "f.png")] if command == "plot" else []
    assert main([command, str(FINGER), *args, *out]) == 2
    captured = capsys.readouterr()
    (line,) = captured.err.splitlines()
    assert option in line and args[1] in line and "Traceback" not in captured.err
    assert list(tmp_path.iterdir()) == []


# ---- estimate must be a bool ------------------------------------------------------------------


@pytest.mark.parametrize("value", ["no", 0, None, 1.0])
def test_estimate_must_be_a_bool(finger, value):
    with pytest.raises(TypeError) as exc:
        flexgen.solve(finger, estimate=value)
    assert one_line(exc).startswith("estimate:")
    with pytest.raises(TypeError, match="^estimate:"):
        flexgen.Solver(finger).solve(estimate=value)


def test_estimate_false_and_true_still_work(finger):
    assert flexgen.solve(finger, estimate=False).error_estimate is None
    assert flexgen.solve(finger, estimate=np.True_).error_estimate is not None


# ---- the prepared Solver checks as the scene and flexgen.solve do -----------------------------


BAD_SOLVES = {
    "negative tension": (
        dict(tensions=[-5.0]),
        ValueError,
        "tensions[0]: must be zero or a positive number <= 1e+100, got -5.0",
    ),
    "nan tension": (dict(tensions=[math.nan]), ValueError, "tensions[0]: must be zero"),
    "tension a string": (dict(tensions="x"), ValueError, "tensions: expected (1,) numbers"),
    "loads a string": (dict(loads="x"), ValueError, "loads: expected (1, 3) numbers"),
    "infinite load": (dict(loads=[[0.0, math.inf, 0.0]]), ValueError, "loads[0][1]: must be"),
    "huge load": (dict(loads=[[0.0, 0.0, 1e101]]), ValueError, "loads[0][2]: must be"),
    "q0 nan": (
        dict(q0={"proximal": [math.nan] * 3}),
        ValueError,
        "q0['proximal']: must be a list of finite numbers",
    ),
    "q0 2-d": (dict(q0={"proximal": [[1, 2], [3, 4]]}), ValueError, "q0['proximal']: must be"),
    "q0 a string": (dict(q0={"proximal": "abc"}), ValueError, "q0['proximal']: must be"),
    "q0 a list": (dict(q0=[1, 2, 3]), TypeError, "q0: expected a dict {flexure: ...}, got list"),
}


@pytest.mark.parametrize("case", BAD_SOLVES, ids=list(BAD_SOLVES))
def test_prepared_solver_refuses_what_the_scene_and_solve_refuse(finger, case):
    kw, kind, start = BAD_SOLVES[case]
    solver = flexgen.Solver(finger)
    with pytest.raises(kind) as exc:
        solver.solve(**kw)
    assert one_line(exc).startswith(start)
    # nothing of the refused call stays: the next solve is the scene's own answer
    assert solver.solve().q == flexgen.solve(finger, estimate=False).q


@pytest.mark.parametrize("case", [c for c in BAD_SOLVES if c.startswith("q0")])
def test_solve_and_solver_give_one_message_for_a_bad_q0(finger, case):
    kw, kind, _ = BAD_SOLVES[case]
    with pytest.raises(kind) as by_solve:
        flexgen.solve(finger, **kw)
    with pytest.raises(kind) as by_solver:
        flexgen.Solver(finger).solve(**kw)
    assert str(by_solve.value) == str(by_solver.value)


def test_the_scene_refuses_a_negative_tension_as_the_solver_does(finger):
    """The rule is the scene's: its own message for its key."""
    with pytest.raises(flexgen.SceneError, match=r"tendon\[0\]\.tension: must be zero or"):
        finger.with_value("tendon.0.tension", -5.0)


def test_valid_loads_and_tensions_solve_as_the_scene_with_them(finger):
    solver = flexgen.Solver(finger)
    r = solver.solve(loads=np.array([[0.0, -0.5, 0.0]]), tensions=[0.0])
    scene = finger.with_values({"load.0.force.1": -0.5, "tendon.0.tension": 0.0})
    np.testing.assert_allclose(
        r.q["proximal"], flexgen.solve(scene).q["proximal"], rtol=0, atol=1e-10
    )
    # a start of the other loads' q (distal as one number): the scene's own equilibrium again
    warm = solver.solve(q0={"proximal": np.array(r.q["proximal"]), "distal": 0.0})
    cold = flexgen.solve(finger)
    assert warm.converged
    for name in ("proximal", "distal"):
        np.testing.assert_allclose(warm.q[name], cold.q[name], rtol=0, atol=1e-10)


def test_solver_refuses_a_model_that_is_no_flexure_model(finger):
    with pytest.raises(TypeError) as exc:
        flexgen.Solver(finger, models={"proximal": "x"})
    assert one_line(exc).startswith("models['proximal']: expected a flexure model")
    with pytest.raises(ValueError, match="^models: unknown flexure 'wrist'"):
        flexgen.Solver(finger, models={"wrist": "x"})


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(loads=[[0.0, -0.2], [0.0, 0.0], [0.0, 0.0]]),  # the same size, another shape
        dict(loads=[0.0, -0.2, 0.0]),  # flat
        dict(loads=[["0", "-0.2", "0"]]),  # strings
        dict(loads=[[False, True, False]]),  # booleans, which the scene refuses
        dict(tensions=["1"]),
        dict(tensions=1.0),
        dict(tensions=[[1.0]]),
    ],
)
def test_solver_loads_and_tensions_have_their_exact_shape_and_numbers(kwargs):
    """One (fx, fy, moment) row per [[load]], one number per [[tendon]]: anything else would be
    reshaped or converted into other inputs than meant, so it is a ValueError naming it."""
    solver = flexgen.Solver(EX / "two_link_finger.toml")
    # (booleans: "every value must be a number", the Solver's own words for them)
    with pytest.raises(ValueError, match=r"^(loads|tensions): (expected|every value must be a)"):
        solver.solve(**kwargs)
    assert solver.solve().converged


def test_a_prepared_solver_refuses_a_scene_tolerance_without_modes(tmp_path):
    """flexgen.Solver does not select modes: on a tolerance scene it would solve the default
    modes silently. Refused, unless modes are given (they clear the tolerance)."""
    scene = {
        "model": {"tolerance": 1e-6},
        "flexure": [{"name": "b", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "b.tip", "force": [0.0, -1.0]}],
    }
    with pytest.raises(flexgen.SceneError, match="^Solver: the scene asks for a tolerance"):
        flexgen.Solver(scene)
    assert flexgen.Solver(scene, modes=4).solve().model["b"]["modes"] == 4


def test_numpy_integer_counts_are_counts(finger):
    """What np.arange or an array element gives: the same model as the Python int."""
    r = flexgen.solve(finger, modes=np.int64(4))
    assert r.model["proximal"] == {"kind": "scm", "modes": 4}
    assert r.q["proximal"] == flexgen.solve(finger, modes=4).q["proximal"]
    s = flexgen.Solver(finger, model="fem", elements=np.int32(6))
    assert len(s.solve().q["proximal"]) == 6
    with pytest.raises(flexgen.SceneError, match=r"modes: must be an integer"):
        flexgen.solve(finger, modes=np.float64(4.0))


def test_a_files_text_for_a_scene_is_one_line_naming_it():
    text = FINGER.read_text()
    with pytest.raises(flexgen.SceneError) as caught:
        flexgen.solve(text)
    assert "\n" not in str(caught.value) and "several lines" in str(caught.value)


def test_a_client_that_is_no_client_is_a_value_error_naming_it(finger):
    with pytest.raises(ValueError, match=r"client: expected a dask.distributed.Client, got str"):
        flexgen.sweep(finger, {"load.0.force.1": [-1.0]}, client="tcp://127.0.0.1:1")


def test_the_exact_solver_checks_the_settings_it_ignores():
    with pytest.raises(ValueError, match=r"settings.max_steps"):
        flexgen.solve(EX / "rectangular_elastica.toml", model="exact", max_steps=-1)


# -- review (API): checks that depended on the path taken, NumPy values ------------------------


def test_estimate_is_checked_on_the_loop_path_too(finger):
    """A solve of the same Scene object takes the cached solver's fast path, which accepted
    estimate="no" (truthy) and ran the estimate: the check depended on what ran before."""
    flexgen.solve(finger)  # the scene's solver is now cached
    for bad in ("no", 1, [0]):
        with pytest.raises(TypeError, match="estimate: must be True or False"):
            flexgen.solve(finger, estimate=bad)
    assert flexgen.solve(finger, estimate=np.True_).error_estimate is not None


def test_numpy_numbers_are_numbers_for_settings_and_tolerance(finger):
    """np.float32 and np.int64 were "must be a finite number" (a float field tested int and
    float), while NumPy integers were accepted for the integer fields."""
    settings = flexgen.SolverSettings(tol=np.float32(1e-10), max_dq=np.int64(1))
    assert type(settings.tol) is float and type(settings.max_dq) is float
    assert settings == flexgen.SolverSettings(tol=float(np.float32(1e-10)), max_dq=1.0)
    plain = flexgen.solve(finger, tolerance=1e-3)
    numpy = flexgen.solve(finger, tolerance=np.float32(1e-3), max_dq=np.int64(1))
    assert numpy.to_json() == plain.to_json()
    for bad in (True, np.True_, "1e-10", float("nan")):
        with pytest.raises(ValueError, match="settings.tol: must be a finite number"):
            flexgen.SolverSettings(tol=bad)


def test_the_exact_model_checks_tolerance_and_refuses_models(finger):
    """With model="exact" a tolerance of 'abc' or -5 was accepted (the exact branch returned
    before the check; the CLI's --tol refused them), a good one and a scene's tolerance beside
    kind exact were dropped (scene.md: exit 2, as cc's), and models were dropped silently."""
    for bad in ("abc", -5.0, 1.0):
        with pytest.raises(ValueError, match=r"tolerance: must be a number in \(0, 1\)"):
            flexgen.solve(finger, model="exact", tolerance=bad)
    with pytest.raises(ValueError, match="a tolerance chooses smooth curvature modes"):
        flexgen.solve(finger, model="exact", tolerance=1e-3)  # as with model="cc"
    exact_scene = flexgen.scene_from_dict(
        {
            "model": {"kind": "exact", "tolerance": 1e-6},
            "flexure": [{"name": "b", "length": 1.0, "EI": 1.0}],
        }
    )
    with pytest.raises(ValueError, match=r"flexure\[0\]\.kind: a tolerance chooses"):
        flexgen.solve(exact_scene)
    models = {"proximal": build_model(finger.flexures[0])}
    with pytest.raises(ValueError, match="models: the exact model solves every flexure"):
        flexgen.solve(finger, model="exact", models=models)


def test_numpy_booleans_are_not_numbers(finger):
    """np.True_ in a load row and a Python bool in q0 were read as 1 (the docs: booleans are not
    numbers), while np.True_ as a tension and a bool in a load row were refused."""
    solver = flexgen.Solver(finger)
    with pytest.raises(ValueError, match="loads: every value must be a number"):
        solver.solve(loads=[[np.True_, 0.0, 0.0]])
    for q0 in ([True], np.array([True]), [np.True_]):
        with pytest.raises(ValueError, match=r"q0\['proximal'\]: must be a list of finite"):
            solver.solve(q0={"proximal": q0})


def test_with_value_takes_numpy_arrays(finger):
    """A NumPy vector was NumPy's own "can only convert an array of size 1" (``.item()``), and
    a one-element array for a scalar key was silently unwrapped."""
    assert finger.with_value("load.0.force", np.array([0.0, -1.0])) == finger.with_value(
        "load.0.force", [0.0, -1.0]
    )
    with pytest.raises(flexgen.SceneError, match=r"load\.0\.force\.1: .*got \[-1\.0\]"):
        finger.with_value("load.0.force.1", np.array([-1.0]))
    assert finger.with_value("load.0.force.1", np.array(-1.0)).loads[0].force == (0.0, -1.0)


def test_with_value_takes_a_list_of_numpy_scalars(finger):
    """Review: a NumPy array was taken, a list of NumPy scalars refused ("must be a finite
    number ..., got np.float32(0.0)")."""
    given = [np.float32(0.0), np.int64(-1)]
    assert finger.with_value("load.0.force", given) == finger.with_value("load.0.force", [0, -1])
