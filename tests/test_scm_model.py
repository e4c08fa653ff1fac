"""The scm runtime model's kernel choice: polynomial in range, Gauss past it, and a clear answer
when no Gauss kernel exists for that many modes (7 and 8 ship polynomial kernels only)."""

import math

import numpy as np

import flexgen
from flexgen.models.scm import SCMModel


def cantilever(force, moment=0.0):
    return {
        "flexure": [{"name": "b", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "b.tip", "force": list(force), "moment": moment}],
    }


def test_seven_modes_in_range_solve_without_a_gauss_kernel():
    model = SCMModel(1.0, 1.0, modes=7)
    assert model.gauss is None and "7 modes" in model.no_gauss
    r = flexgen.solve(cantilever((0.0, 0.0), 1.2), modes=7)
    t = 1.2
    np.testing.assert_allclose(
        r.points["b.tip"].pose, [math.sin(t) / t, (1 - math.cos(t)) / t, t], atol=1e-10
    )


def test_seven_modes_past_range_say_which_kernel_is_missing():
    r = flexgen.solve(cantilever((0.0, 0.0), 2.5), modes=7)
    assert not r.converged
    assert "no Gauss kernel for 7 modes" in r.reason and "'b'" in r.reason


def test_auto_switches_to_gauss_past_range_where_one_exists():
    r = flexgen.solve(cantilever((0.0, 0.0), 2.5), modes=5)
    t = 2.5
    np.testing.assert_allclose(
        r.points["b.tip"].pose, [math.sin(t) / t, (1 - math.cos(t)) / t, t], atol=1e-9
    )
    assert any("switched to the Gauss kernel" in w for w in r.warnings)
