"""Documented calls of the public API against values computed without them: Solver.margin_above
(docs/solve.md) against Euler's buckling load and NumPy's eigenvalues, Result.to_dict against the
JSON of the same answer, and a model's one name in plots, warnings and the Result."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import flexgen
from flexgen.models import registry
from flexgen.scene import scene_from_dict

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
# Euler: a cantilever (fixed-free) of length 1 and EI 1 buckles at P = pi^2 EI / (4 L^2)
EULER = math.pi**2 / 4


def column(load_fraction: float, model: dict) -> flexgen.Solver:
    """A straight cantilever along +x under an axial compressive tip force of load_fraction of
    Euler's load: solved straight, with margin 1 - P/P_cr (../shared/model-notes.md)."""
    scene = scene_from_dict(
        {
            "model": model,
            "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
            "load": [{"point": "beam.tip", "force": [-load_fraction * EULER, 0.0]}],
        }
    )
    solver = flexgen.Solver(scene)
    assert solver.solve().converged
    return solver


@pytest.mark.parametrize("fraction", [0.3, 0.7])
def test_margin_above_on_an_axial_load_below_euler(fraction):
    solver = column(fraction, {"kind": "scm", "modes": 5})
    margin = 1 - fraction  # the closed form; scm5's critical load is Euler's to < 1e-6
    assert solver.margin_above(margin - 1e-3)
    assert not solver.margin_above(margin + 1e-3)


def test_margin_above_against_numpy_on_a_bent_finger():
    """The margin of K against the elastic stiffness D (diagonal): the smallest eigenvalue of
    D^-1/2 K D^-1/2, from the answer's stiffness."""
    solver = flexgen.Solver(EXAMPLES / "two_link_finger.toml")
    r = solver.solve()
    d = 1 / np.sqrt(np.asarray(solver.problem.stiffness, dtype=float))
    margin = np.linalg.eigvalsh(d[:, None] * np.asarray(r.stiffness) * d[None, :])[0]
    assert 0 < margin < 1
    assert solver.margin_above(margin * (1 - 1e-6))
    assert not solver.margin_above(margin * (1 + 1e-6))


def _plain(x):
    """Python data as JSON holds it: arrays as lists, non-finite numbers as None."""
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    if isinstance(x, float | np.floating):
        return float(x) if math.isfinite(x) else None
    return x


def _holds(full, part, where="result"):
    """Every entry of the JSON ``part`` is in ``full`` with the same value."""
    if isinstance(part, dict):
        assert isinstance(full, dict), where
        for k, v in part.items():
            assert k in full, f"{where}.{k}"
            _holds(full[k], v, f"{where}.{k}")
    else:
        assert full == part, where


def _no_numpy(x, where="result"):
    """Nothing in ``x`` is a NumPy array or scalar: "plain Python data", as to_dict promises."""
    assert not isinstance(x, np.ndarray | np.generic), where
    if isinstance(x, dict):
        for k, v in x.items():
            _no_numpy(v, f"{where}.{k}")
    elif isinstance(x, list | tuple):
        for i, v in enumerate(x):
            _no_numpy(v, f"{where}[{i}]")


def test_to_dict_holds_every_field_of_the_json():
    r = flexgen.solve(EXAMPLES / "two_link_finger.toml")
    _no_numpy(r.to_dict())
    full = _plain(r.to_dict())
    _holds(full, json.loads(r.to_json()))
    # and the fields the JSON leaves out: the curvature along each flexure, the core's bends
    assert len(full["flexures"]["proximal"]["curvature"]) == len(full["flexures"]["proximal"]["s"])
    assert set(full["bend"]) == {"proximal", "distal"}


@pytest.mark.parametrize(
    ("options", "name"),
    [({"model": "cc"}, "cc"), ({}, "scm3"), ({"model": "fem", "elements": 4}, "fem4")],
)
def test_one_name_per_model(options, name):
    """A one-mode smooth curvature flexure is "cc" in the drawing's title and the warnings, as
    the Result's entry names it."""
    from flexgen import drawing, validity
    from flexgen.models import registry

    path = EXAMPLES / "two_link_finger.toml"
    r = flexgen.solve(path, **options)
    assert drawing._model_label(r) == name
    models = validity.models_of(flexgen.load_scene(path), r)
    assert {registry.label(registry.model_info(m)) for m in models.values()} == {name}
    assert {validity.model_label(m).split()[0] for m in models.values()} == {name}


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (
            {"modes": 2, "range_deg": 200},
            "range_deg: the polynomial kernel needs a range below 180",
        ),
        ({"modes": 9}, "modes: must be an integer from 1 to 8"),
        ({"modes": 2, "nodes": 5}, "nodes: only for kernel gauss or local"),
        ({"modes": 2, "tol": 5.0}, "tol: must be in (0, 1)"),
        ({"modes": 2, "langs": ("rust",)}, "langs: a sequence of 'numpy', 'c'"),
        ({"modes": 2, "langs": "c"}, "langs: a sequence of 'numpy', 'c'"),
    ],
)
def test_generate_names_its_own_arguments_not_the_clis_options(kwargs, message):
    # review: flexgen.generate(modes=2, range_deg=200) said "--range: ...", an option a
    # Python caller never wrote; an unknown language was a bare KeyError
    with pytest.raises(ValueError) as exc:
        flexgen.generate(**kwargs)
    assert str(exc.value).startswith(message) and "--" not in str(exc.value)


def test_a_prepared_solver_checks_the_loads_it_solved_not_the_scenes():
    # review: Solver.solve(loads=...) read the scene's own loads in its validity checks: a
    # moment given to a prb solve missed the pseudo-rigid-body caveat, 5000 N the units
    # warning, and a Solver of a 5000 N scene solved at 1 N still warned of 5000 N
    one = {"name": "c", "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}]}
    at_1 = {**one, "load": [{"point": "beam.tip", "force": [0.0, -1.0]}]}
    at_5000 = {**one, "load": [{"point": "beam.tip", "force": [0.0, -5000.0]}]}
    with_moment = {**one, "load": [{"point": "beam.tip", "force": [0.0, -1.0], "moment": 0.8}]}
    cases = [
        (at_1, {"model": "prb"}, [[0.0, -1.0, 0.8]], with_moment),
        (at_1, {}, [[0.0, -5000.0, 0.0]], at_5000),
        (at_5000, {}, [[0.0, -1.0, 0.0]], at_1),
        (with_moment, {"model": "prb"}, [[0.0, -1.0, 0.0]], at_1),
    ]
    for prepared, options, loads, same in cases:
        got = flexgen.Solver(prepared, **options).solve(loads=loads)
        want = flexgen.solve(same, **options)
        assert got.warnings == want.warnings, (loads, got.warnings, want.warnings)
    assert any("pseudo-rigid-body" in w for w in flexgen.solve(with_moment, model="prb").warnings)
    assert any("load level 5e+03" in w for w in flexgen.solve(at_5000).warnings)


def test_margin_of_no_answer_is_nan_and_not_above_anything():
    # review: margin() was 0.0 before any solve and the previous answer's after a failed one,
    # so margin_above told a controller that a mechanism with no equilibrium was safe
    s = flexgen.Solver(EXAMPLES / "two_link_finger.toml")
    assert math.isnan(s.margin()) and not s.margin_above(0.05)
    s.solve()
    assert s.margin() == pytest.approx(s.solve().stability_margin) and s.margin_above(0.05)
    failed = s.solve(tensions=[100.0])
    assert not failed.converged
    assert math.isnan(s.margin()) and not s.margin_above(0.05)


def test_a_solver_solving_is_not_entered_from_another_thread():
    # review: one Solver shared by 4 threads gave 28 wrong poses in 6000, with no error
    s = flexgen.Solver(EXAMPLES / "two_link_finger.toml")
    s._in_use.acquire()  # as while another thread is inside solve or run
    try:
        for call in (s.solve, s.run):
            with pytest.raises(RuntimeError, match="use one Solver per thread"):
                call()
    finally:
        s._in_use.release()
    assert s.solve().converged


@pytest.mark.parametrize("model, label", [("fem", "fem16"), ("cc", "cc"), ("prb", "prb")])
def test_a_model_kind_given_replaces_the_scenes_tolerance(model, label):
    # review: a Solver of a scene with [model] tolerance and model="fem" said "give modes
    # instead", which fem refuses, and flexgen.solve raised SelectionError: no way to solve it
    scene = {
        "model": {"tolerance": 1e-4},
        "flexure": [{"name": "b", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "b.tip", "force": [0.0, -1.0]}],
    }
    for result in (flexgen.solve(scene, model=model), flexgen.Solver(scene, model=model).solve()):
        assert result.converged and registry.label(result.model["b"]) == label
        # a note says so (contract review: nothing said the tolerance was not applied)
        assert any("tolerance 0.0001 is not applied" in n for n in result.notes), result.notes
    assert flexgen.solve(scene).model["b"]["kind"] == "scm"  # the tolerance's own selection
    assert not flexgen.solve(scene).notes


def test_a_boolean_load_or_tension_is_no_number():
    # review: loads=[[True, 0, 0]] solved as a force of 1 (NumPy reads the row as integers)
    s = flexgen.Solver(EXAMPLES / "two_link_finger.toml")
    for loads in (
        [[True, 0, 0]],
        [[True, -0.5, 0.0]],
        [[0.0, -2.0, False]],
        [[True, False, False]],
    ):
        with pytest.raises(ValueError, match=r"^loads: every value must be a number, got"):
            s.solve(loads=loads)  # (review of the change: a bool beside floats got through)
    with pytest.raises(ValueError, match=r"^tensions: every value must be a number, got"):
        s.solve(tensions=[True])
    assert s.solve(loads=[[0, -1, 0]]).converged  # integers are numbers


def test_a_quantity_with_units_is_refused_not_read_as_the_scenes_units():
    # review: Quantity(array of -200, "mN") was solved as -200 N (np.asarray drops the unit)
    from flexgen.units import registry

    u = registry()
    s = flexgen.Solver(EXAMPLES / "two_link_finger.toml")
    with pytest.raises(ValueError, match=r"^loads: give plain numbers in the scene's units"):
        s.solve(loads=u.Quantity(np.array([[0.0, -200.0, 0.0]]), "mN"))
    with pytest.raises(ValueError, match=r"^tensions: give plain numbers in the scene's units"):
        s.solve(tensions=u.Quantity(np.array([10000.0]), "mN"))
    assert s.solve(loads=[[0.0, -0.2, 0.0]]).converged
