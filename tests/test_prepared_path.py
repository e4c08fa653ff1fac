"""The loop path of ``flexgen.solve`` (the same Scene object again: its cached prepared solver)
gives exactly the answer of the first, uncached solve, warnings included: ``validity.calm``
skips ``validity.check`` only when check would add nothing. And an answer of a prepared solver
keeps its own values after the solver's next solve (it is built lazily from copies)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import flexgen
from flexgen import api, validity
from flexgen.api import override
from flexgen.scene import scene_from_dict
from flexgen.solver import Solver

FINGER = Path(__file__).resolve().parents[1] / "examples" / "two_link_finger.toml"
P_EULER = math.pi**2 / 4  # of a cantilever with EI = L = 1


def cantilever(kind="scm", kernel="auto", force=(0.0, -1.0), moment=0.0, EI=1.0):
    return scene_from_dict(
        {
            "name": "cantilever",
            "model": {"kind": kind, "kernel": kernel} if kind == "scm" else {"kind": kind},
            "flexure": [{"name": "beam", "length": 1.0, "EI": EI}],
            "load": [{"point": "beam.tip", "force": list(force), "moment": moment}],
            "output": {"points": ["beam.tip"]},
        }
    )


# (scene, a text one of its warnings holds, or None for an answer without warnings)
CASES = {
    "finger": (lambda: flexgen.load_scene(FINGER), None),
    "finger prb": (
        lambda: override(flexgen.load_scene(FINGER), model="prb"),
        "pseudo-rigid-body constants",
    ),
    "prb within 64 deg": (lambda: cantilever("prb", force=(0.0, -2.0)), None),
    "prb past 64 deg": (lambda: cantilever("prb", force=(0.0, -8.0)), "64 deg"),
    "poly past its range": (
        lambda: cantilever(kernel="poly", force=(-8.0, -8.0)),
        "polynomial kernel",
    ),
    "bent past 180 deg": (lambda: cantilever(moment=4.0), "no accuracy is claimed"),
    "scm near buckling": (lambda: cantilever(force=(-0.97 * P_EULER, 0.0)), "near a critical"),
    "fem near buckling": (
        lambda: cantilever("fem", force=(-0.97 * P_EULER, 0.0)),
        "near a critical",
    ),
    "wrong units": (lambda: cantilever(force=(0.0, -3.0), EI=1e-3), "check the units"),
    "wrong units, failed": (
        lambda: cantilever(kernel="poly", force=(0.0, -3.0), EI=1e-3),
        "check the units",
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_cached_solve_is_the_first_solve(case):
    make, expected = CASES[case]
    scene = make()
    first = flexgen.solve(scene)  # prepares and caches the solver; the full check
    solver = api._solvers[api._key(scene, flexgen.settings.DEFAULT)]
    assert solver.scene is scene
    again = flexgen.solve(scene)  # the loop path
    assert again is not first
    assert again.warnings == first.warnings and again.reason == first.reason
    assert again.to_json() == first.to_json()
    assert again.bend == first.bend and again.kernel == first.kernel
    if expected is None:
        assert first.converged and first.warnings == []
    else:
        assert any(expected in w for w in first.warnings + [first.reason or ""]), first.warnings


@pytest.mark.parametrize("case", sorted(CASES))
def test_calm_only_when_check_adds_nothing(case):
    make, expected = CASES[case]
    scene = make()
    solver = Solver(scene)  # the plain solver: calm and check called here, as flexgen.solve does
    result = solver.solve(estimate=True)
    if not result.converged:
        pytest.skip("check assesses converged answers only")
    result.stability_margin = solver.margin()
    calm = validity.calm(solver)  # the first answer: screened by fg_calm
    before = list(result.warnings)
    validity.check(scene, result, solver.models)
    added = result.warnings[len(before) :]
    assert calm == (added == []) if expected is None else (not calm and added)
    # from the second answer on fg_solve screens it (fg_answer.calm): the same verdict, and the
    # same as fg_calm's on that answer
    solver.solve(estimate=True)
    screen = solver._validity_screen
    assert validity.calm(solver) == calm
    if not screen.empty and not screen.always:  # (else calm decides without an answer)
        ws = solver.workspace
        lib = flexgen.core.lib
        assert (
            bool(lib.fg_calm(solver.problem.struct, ws.answer, ws.work_ptr, ws.iwork_ptr)) == calm
        )
        assert bool(ws.answer.calm) == calm


def test_a_kept_answer_is_not_changed_by_the_next_solve():
    """Nothing of the first answer is read before the second solve overwrites the workspace
    (every field of it is built afterwards, from its own copies)."""
    s = flexgen.Solver(FINGER)
    loads = s.problem.loads.copy()
    first = s.solve(estimate=True)  # nothing read
    s.solve(loads=loads * 3.0, estimate=True)
    fresh = flexgen.Solver(FINGER).solve(loads=loads, estimate=True)
    assert first.to_json() == fresh.to_json()
    assert first.q == fresh.q and first.bend == fresh.bend and first.kernel == fresh.kernel
    assert np.array_equal(first.stiffness, fresh.stiffness)
    assert first.error_estimate == fresh.error_estimate
    assert [p.error_estimate for p in first.points.values()] == [
        p.error_estimate for p in fresh.points.values()
    ]


@pytest.mark.parametrize("fy", [-0.5, -20.0, -30.0])
def test_a_prepared_solvers_answers_warn_as_flexgen_solves(fy):
    """flexgen.Solver runs flexgen.solve's validity check (where the core's screen finds a
    warning may apply): a prb flexure past its 64 deg warns from either (it did not from a
    prepared Solver), an answer within it from neither."""
    scene = {
        "name": "prb",
        "model": {"kind": "prb"},
        "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "beam.tip", "force": [0.0, -1.0]}],
    }
    solver = flexgen.Solver(scene)
    solver.solve()  # an earlier answer: the screen is the core's from then on
    prepared = solver.solve(loads=[[0.0, fy, 0.0]])
    scene["load"][0]["force"] = [0.0, fy]
    direct = flexgen.solve(scene)
    assert prepared.warnings == direct.warnings
    assert bool(direct.warnings) == (fy < -6.0)


@pytest.mark.parametrize("modes", [3, 8])
def test_a_warm_answer_says_what_the_cold_answer_says(modes):
    # review: along a random load walk on a two-flexure chain the warm answer carried a
    # kernel-switch note ("during the solve (the equilibrium is back in range)") from its
    # Newton from the previous answer, where the cold solve of the same loads had none
    import numpy as np

    scene = {
        "flexure": [
            {"name": "a", "length": 0.6, "EI": 1.0},
            {"name": "b", "parent": "a", "length": 0.4, "EI": 0.7},
        ],
        "load": [{"point": "b.tip", "force": [0.0, 0.0]}],
    }
    solver = flexgen.Solver(scene, modes=modes)
    rng = np.random.default_rng(9)
    force, previous = np.zeros(3), None
    for _ in range(300):
        force = np.clip(force + rng.normal(0.0, [1.0, 1.0, 0.5]), -8, 8)
        warm = solver.solve(loads=[force.tolist()], q0=previous)
        cold = solver.solve(loads=[force.tolist()])
        assert warm.converged == cold.converged
        if cold.converged:
            previous = warm.q
            assert (warm.notes, warm.warnings) == (cold.notes, cold.warnings), force
