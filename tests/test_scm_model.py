"""The scm runtime model's kernel choice: polynomial in range, Gauss past it, and a clear answer
when no Gauss kernel exists for that many modes (7 and 8 ship polynomial kernels only)."""

import math

import numpy as np
import pytest

import flexgen
from flexgen.models.scm import SCMModel


def cantilever(force, moment=0.0):
    return {
        "flexure": [{"name": "b", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "b.tip", "force": list(force), "moment": moment}],
    }


@pytest.mark.parametrize("modes", [3, 7, 8])
@pytest.mark.parametrize("t", [1.2, 2.5, 4.0])
def test_more_modes_are_never_worse_past_90_degrees(modes, t):
    """Every mode count the polynomial family ships has a Gauss kernel, so scm7 and scm8 solve
    an end moment that rolls the flexure past 90 degrees wherever scm3 does: the exact arc."""
    model = SCMModel(1.0, 1.0, modes=modes)
    assert model.gauss is not None and model.no_gauss is None
    r = flexgen.solve(cantilever((0.0, 0.0), t), modes=modes)
    assert r.converged, r.reason
    np.testing.assert_allclose(
        r.points["b.tip"].pose, [math.sin(t) / t, (1 - math.cos(t)) / t, t], atol=1e-9
    )


def test_a_poly_only_kernel_past_its_range_says_so():
    scene = cantilever((0.0, 0.0), 2.5)
    scene["model"] = {"modes": 7, "kernel": "poly"}
    r = flexgen.solve(scene)
    assert not r.converged
    assert "'b'" in r.reason and "polynomial kernel scm7" in r.reason


def test_auto_switches_to_gauss_past_range_where_one_exists():
    r = flexgen.solve(cantilever((0.0, 0.0), 2.5), modes=5)
    t = 2.5
    np.testing.assert_allclose(
        r.points["b.tip"].pose, [math.sin(t) / t, (1 - math.cos(t)) / t, t], atol=1e-9
    )
    assert any("switched to the Gauss kernel" in w for w in r.notes)


def test_the_estimates_richer_model_uses_the_local_kernel_and_the_polynomial_without_one(
    monkeypatch,
):
    """``local=True`` (the error estimate's richer models) evaluates with the local Gauss kernel,
    certified at each q, and the certified Gauss kernel past it; with no local kernel in the
    kernel folder, with the polynomial one."""
    from flexgen import kernels

    model = SCMModel(1.0, 1.0, modes=5, local=True)
    assert model.poly_name.startswith("scm5_local") and model.gauss_name.startswith("scm5_gauss")
    assert model.poly is kernels.load_numpy(model.poly_name)
    real = kernels.gauss_kernel_name

    def no_local(modes, folder=kernels.GENERATED, family="gauss"):
        if family == "local":
            raise kernels.KernelNotFound("no local kernel")
        return real(modes, folder, family)

    monkeypatch.setattr(kernels, "gauss_kernel_name", no_local)
    assert SCMModel(1.0, 1.0, modes=5, local=True).poly_name == "scm5"
