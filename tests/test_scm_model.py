"""The scm runtime model's kernel choice: polynomial in range, Gauss past it, and a clear answer
when no Gauss kernel exists for that many modes (7 and 8 ship polynomial kernels only)."""

import math
from pathlib import Path

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


@pytest.mark.parametrize("t, kernel", [(2.5, "local"), (6.2, "gauss past its certified range")])
def test_auto_switches_to_gauss_past_the_local_kernels_certificate(t, kernel):
    """scm5 "auto": the local kernel on a 143-degree arc (past the polynomial kernel's 90
    degrees, a bend the local kernel certifies: no note), the Gauss kernel (with a note) on a
    355-degree one, which the local kernel does not certify; the exact arc either way."""
    r = flexgen.solve(cantilever((0.0, 0.0), t), modes=5)
    np.testing.assert_allclose(
        r.points["b.tip"].pose, [math.sin(t) / t, (1 - math.cos(t)) / t, t], atol=1e-9
    )
    assert r.kernel == {"b": kernel}
    switched = any("switched to the Gauss kernel" in w for w in r.notes)
    assert switched == (kernel != "local")


def test_each_kernel_choice_has_its_kernels_and_local_falls_back_to_the_polynomial(monkeypatch):
    """The kernels each choice tries, in order: "auto" the local, polynomial and Gauss kernels;
    "local" (also the error estimate's richer models) the local and Gauss kernels; "poly" and
    "gauss" theirs alone. With no local kernel in the kernel folder, "local" takes the
    polynomial kernel in its place and "auto" goes without."""
    from flexgen import kernels

    def names(m):
        return (m.local_name, m.poly_name, m.gauss_name)

    auto = SCMModel(1.0, 1.0, modes=5)
    assert auto.local_name.startswith("scm5_local") and auto.poly_name == "scm5"
    assert auto.gauss_name.startswith("scm5_gauss")
    assert auto.local is kernels.load_numpy(auto.local_name)
    assert names(SCMModel(1.0, 1.0, modes=5, kernel="local")) == (
        auto.local_name,
        None,
        auto.gauss_name,
    )
    assert names(SCMModel(1.0, 1.0, modes=5, kernel="poly")) == (None, "scm5", None)
    assert names(SCMModel(1.0, 1.0, modes=5, kernel="gauss")) == (None, None, auto.gauss_name)
    real = kernels.gauss_kernel_name

    def no_local(modes, folder=kernels.GENERATED, family="gauss"):
        if family == "local":
            raise kernels.KernelNotFound("no local kernel")
        return real(modes, folder, family)

    monkeypatch.setattr(kernels, "gauss_kernel_name", no_local)
    assert names(SCMModel(1.0, 1.0, modes=5, kernel="local")) == (None, "scm5", auto.gauss_name)
    assert names(SCMModel(1.0, 1.0, modes=5)) == (None, "scm5", auto.gauss_name)


def _arc_scene(t: float, kernel: str, modes: int = 3) -> dict:
    scene = cantilever((0.0, 0.0), t)
    scene["model"] = {"modes": modes, "kernel": kernel}
    return scene


@pytest.mark.parametrize("modes", [3, 5])
def test_kernel_local_certifies_smooth_bends_the_polynomial_kernel_does_not(modes):
    """A 143-degree arc (tip moment 2.5 EI/L): "local" and "auto" evaluate it with the local
    kernel (its bound certified there: no note), "poly" finds no equilibrium (past its 90
    degrees); both give the closed-form arc. A 355-degree arc is past the local kernel's
    certificate too: the Gauss kernel, with a note naming the local kernel."""
    t = 2.5
    arc = [math.sin(t) / t, (1 - math.cos(t)) / t, t]
    local = flexgen.solve(_arc_scene(t, "local", modes))
    auto = flexgen.solve(_arc_scene(t, "auto", modes))
    np.testing.assert_allclose(local.points["b.tip"].pose, arc, atol=1e-10)
    np.testing.assert_allclose(auto.points["b.tip"].pose, arc, atol=1e-10)
    assert local.kernel == {"b": "local"} and local.notes == [] and local.warnings == []
    assert auto.kernel == {"b": "local"} and auto.notes == [] and auto.warnings == []
    assert not flexgen.solve(_arc_scene(t, "poly", modes)).converged
    far = flexgen.solve(_arc_scene(6.2, "local", modes))
    assert far.converged and far.points["b.tip"].pose[2] == pytest.approx(6.2, abs=1e-9)
    assert far.kernel == {"b": "gauss past its certified range"}
    assert any(f"local kernel scm{modes}_local" in n for n in far.notes)


@pytest.mark.parametrize("scene", ["cantilever_tip_load", "two_link_finger", "steel_finger"])
def test_kernel_local_answers_as_auto_within_the_kernels_bounds(scene):
    """The same model through either kernel: the two kernels' errors (pose 1.3e-11 and 1e-11 of
    L, Jacobians 8e-10 and 1e-10) move the equilibrium by far less than 1e-9 of the length
    scale, and the compliance by less than 1e-8 relative."""
    from flexgen.scene import load_scene

    path = Path(__file__).resolve().parents[1] / "examples" / f"{scene}.toml"
    base = load_scene(path)
    local = flexgen.solve(base.with_value("model.kernel", "local"))
    auto = flexgen.solve(base)
    assert set(local.kernel.values()) == {"local"}
    L = sum(f.length for f in base.flexures)
    for name, p in auto.points.items():
        q = local.points[name]
        assert np.max(np.abs(np.subtract(q.pose[:2], p.pose[:2]))) <= 1e-9 * L
        assert abs(q.pose[2] - p.pose[2]) <= 1e-9
        C, Cl = np.asarray(p.compliance3), np.asarray(q.compliance3)
        assert np.max(np.abs(Cl - C)) <= 1e-8 * np.max(np.abs(C))
