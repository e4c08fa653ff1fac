"""The compiled solver core (``flexgen.solver.Solver``, ``flexgen.solve``), against independent
references: the closed forms and the exact elastica (``flexgen.models.exact``, the values of
model-notes.md), and finite differences computed here from the reference kinematics of
``flexgen.chain.Chain`` (Python, the NumPy kernels) or from repeated solves.

Covered: Euler buckling of columns in several orientations (the critical load factor against
(2k - 1)^2 pi^2/4 EI/L^2, the post-buckled tip against the exact elastica, the side taken); an
asymmetric bifurcation under a tendon (the side of lower potential, computed here); a
snap-through (its load factor against the exact elastica's fold, the final state against the
stable exact equilibria at the full load); kernel switches of the "auto" scm kernel; warm starts;
the compliance against finite differences of solves; the generalized stiffness against finite
differences of the residual (and the compliance against J K^-1 J^T); ``Solver.solve`` with other
loads and tensions; settings and options reaching the core; the C source (strict C99, no heap, no
writable globals); a workspace that carries nothing from one solve to the next.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
from dataclasses import replace
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from cbuild import STRICT

import flexgen
from flexgen.chain import Chain
from flexgen.models import exact
from flexgen.models.fem import FEMModel
from flexgen.models.prb import PRBModel
from flexgen.models.registry import build_models
from flexgen.models.scm import SCMModel
from flexgen.scene import Load, load_scene, scene_from_dict
from flexgen.settings import SolverSettings
from flexgen.solver import BUCKLING_SIDES, Solver, buckling_note, snap_note, solve_models

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "flexgen" / "compiled"
KERNELS = ROOT / "generated" / "c"
EXAMPLES = ROOT / "examples"
SOURCE = ROOT / "flexgen" / "compiled" / "chain_solver.c"

EULER = math.pi**2 / 4  # the first Euler load of a cantilever, EI = L = 1
ELASTICA = 3.4375929  # the load of examples/rectangular_elastica.toml
ELASTICA_TIP = (0.456947, 0.762760)
SNAP = dict(force=(-1.74574099, -4.67920763), moment=3.478735754260268)  # a fold near 0.5457
WHY = dict(zip(("only", "lower", "y", "ccw"), BUCKLING_SIDES))


# -- models and scenes ----------------------------------------------------------------------------


def scm(modes: int, kernel: str = "auto"):
    return lambda f: SCMModel(f.length, f.EI, modes, kernel=kernel, name=f.name)


def fem(elements: int):
    return lambda f: FEMModel(f.length, f.EI, elements)


def prb():
    return lambda f: PRBModel(f.length, f.EI)


FACTORIES = {
    "scm3 gauss": scm(3, "gauss"),
    "scm5 gauss": scm(5, "gauss"),
    "scm6 gauss": scm(6, "gauss"),
    "fem4": fem(4),
    "fem16": fem(16),
    "prb": prb(),
    "scm3": scm(3),
    "scm4": scm(4),
}


def models(scene, label):
    """A fresh model per flexure of ``scene`` (FACTORIES[label])."""
    return build_models(scene, None, FACTORIES[label])


def solve(scene, label, **kwargs):
    return solve_models(scene, models(scene, label), **kwargs)


def example(name: str):
    return load_scene(EXAMPLES / f"{name}.toml")


def cantilever(force=(0.0, 0.0), moment=0.0, L=1.0, EI=1.0, angle=0.0):
    return scene_from_dict(
        {
            "name": "cantilever",
            "flexure": [{"name": "beam", "length": L, "EI": EI, "at": [0.0, 0.0, angle]}],
            "load": [{"point": "beam.tip", "force": list(force), "moment": moment}],
            "output": {"points": ["beam.tip"]},
        }
    )


def column(P: float, angle: float):
    """A cantilever along ``angle`` under the axial compressive tip load P."""
    return cantilever(force=(-P * math.cos(angle), -P * math.sin(angle)), angle=angle)


def tendon_column(T: float, ry: float):
    """A tendon from base point (0, ry) to the tip of a flexure along x, and the dead tip load
    that cancels its transverse pull: the straight state stays an equilibrium, but the tendon
    turns with the tip and a dead load does not, so the bifurcation is not a symmetric one (the
    sides differ in potential energy)."""
    return scene_from_dict(
        {
            "name": "tendon column",
            "flexure": [{"name": "a", "length": 1.0, "EI": 1.0}],
            "base": {"points": {"r0": [0.0, ry]}},
            "tendon": [{"tension": T, "route": ["base.r0", "a.tip"]}],
            "load": [
                {"point": "a.tip", "force": [0.0, -T * ry / math.hypot(1.0, ry)], "moment": 0.0}
            ],
            "output": {"points": ["a.tip"]},
        }
    )


# base -> a -> link l1 -> b -> link l2; a's tip frame also carries flexure c; a tendon through
# both links, loads with moments on two bodies
TREE = scene_from_dict(
    {
        "name": "tree",
        "base": {"points": {"r0": [0.0, 0.25]}},
        "flexure": [
            {"name": "a", "length": 1.0, "EI": 1.0, "at": [0.1, 0.2, 0.3]},
            {"name": "b", "parent": "l1", "length": 0.7, "EI": 0.6, "at": [0.5, -0.1, 0.4]},
            {"name": "c", "parent": "a", "length": 0.5, "EI": 0.3, "at": [0.05, 0.0, -0.6]},
        ],
        "link": [
            {"name": "l1", "parent": "a", "points": {"p": [0.3, 0.1], "hole": [0.2, 0.08]}},
            {"name": "l2", "parent": "b", "points": {"pad": [0.2, 0.05], "anchor": [0.3, -0.04]}},
        ],
        "load": [
            {"point": "l2.pad", "force": [0.3, -0.5], "moment": 0.1},
            {"point": "c.tip", "force": [0.0, 0.2], "moment": -0.15},
        ],
        "tendon": [{"tension": 0.8, "route": ["base.r0", "l1.hole", "l2.anchor"]}],
        "output": {"points": ["l2.pad", "c.tip"]},
    }
)

# a chain of two flexures with a tendon
TENDON_CHAIN = scene_from_dict(
    {
        "name": "tendon chain",
        "base": {"points": {"r": [0.0, 0.15]}},
        "flexure": [
            {"name": "p", "length": 1.0, "EI": 1.0},
            {"name": "d", "parent": "m", "length": 0.8, "EI": 0.7, "at": [0.3, 0.0, 0.2]},
        ],
        "link": [
            {"name": "m", "parent": "p", "points": {"hole": [0.05, 0.1]}},
            {"name": "t", "parent": "d", "points": {"pad": [0.2, 0.05], "anchor": [0.25, 0.08]}},
        ],
        "load": [{"point": "t.pad", "force": [0.2, -0.6], "moment": 0.05}],
        "tendon": [{"tension": 0.5, "route": ["base.r", "m.hole", "t.anchor"]}],
        "output": {"points": ["t.pad"]},
    }
)

SCENES = {
    "cantilever_tip_load": lambda: example("cantilever_tip_load"),
    "two_link_finger": lambda: example("two_link_finger"),
    "arc_moment": lambda: example("arc_moment"),
    "tree": lambda: TREE,
    "tendon_chain": lambda: TENDON_CHAIN,
}


# -- independent references -----------------------------------------------------------------------


def potential_gradient(scene, ms, q: np.ndarray) -> tuple[np.ndarray, float]:
    """grad of the total potential (elastic energy + tendons - work of the dead loads) at the
    packed q, by the reference kinematics; and the scale of its terms (for a relative residual)."""
    chain = Chain(scene, ms)
    g = chain.energy_gradient(q)
    scale = float(np.linalg.norm(g))
    _, gt, _ = chain.tendon_potential(q)
    g = g + gt
    scale += float(np.linalg.norm(gt))
    for ld in scene.loads:
        J = chain.point(ld.point, q).J
        w = J[0] * ld.force[0] + J[1] * ld.force[1] + J[2] * ld.moment
        g = g - w
        scale += float(np.linalg.norm(w))
    return g, scale


def potential(scene, ms, q: np.ndarray) -> float:
    """The total potential at the packed q (reference kinematics)."""
    chain = Chain(scene, ms)
    V, _, _ = chain.tendon_potential(q)
    work = 0.0
    for ld in scene.loads:
        x, y, th = chain.pose(ld.point, q)
        work += ld.force[0] * x + ld.force[1] * y + ld.moment * th
    return chain.energy(q) + V - work


def sides(result) -> list[str]:
    """The why of each bifurcation note ("only", "lower", "y", "ccw"), or "snap"."""
    out = []
    for w in result.notes:
        if w.startswith("snap-through"):
            out.append("snap")
        elif w.startswith("buckling"):
            out.append(next(k for k, why in WHY.items() if w.endswith(f"({why})")))
    return out


def in_column_frame(pose, angle):
    """Tip (along, across, turn) in the frame of a column turned by ``angle``."""
    x, y, th = pose
    c, s = math.cos(angle), math.sin(angle)
    return c * x + s * y, -s * x + c * y, th - angle


def test_cantilever_tip_load_against_bisshopp_drucker():
    """examples/cantilever_tip_load.toml (alpha = 2): x/L = 0.83936, deflection/L = 0.49346,
    tip angle 0.78175 (model-notes.md); scm3 is within 2e-4 of it, in one direct solve."""
    r = flexgen.solve(example("cantilever_tip_load"))
    assert r.converged and r.stable and r.critical_load_factors == [] and r.solver == "core"
    x, y, th = r.points["beam.tip"].pose
    assert abs(x - 0.83936) < 2e-4 and abs(y + 0.49346) < 2e-4 and abs(th + 0.78175) < 2e-4
    assert r.residual <= 1e-12


# -- 1. Euler buckling ------------------------------------------------------------------------------

# the first buckling load of the N-mode model is off by (model-notes.md) 1.4e-4 (N = 3),
# 8.6e-9 (N = 5), 4e-11 (N = 6); the 16-element chain by less than 1e-3
CRITICAL_TOL = {"scm3 gauss": 2e-4, "scm5 gauss": 2e-8, "scm6 gauss": 1e-9, "fem16": 1e-3}
# the rectangular elastica's tip: model-notes' tip x errors (2.6e-3, 2.2e-6, 7e-7 relative of
# x = 0.457) with margin; the 16-element chain as the paper's FEM (within 2e-3)
TIP_TOL = {"scm3 gauss": 2e-3, "scm5 gauss": 1e-5, "scm6 gauss": 1e-5, "fem16": 2e-3}


@pytest.mark.parametrize("label", list(CRITICAL_TOL))
@pytest.mark.parametrize(
    "angle, side",
    [
        (0.0, "y"),
        (0.3, "y"),
        (2.0, "y"),
        (math.pi, "y"),  # buckles to larger world y
        (math.pi / 2, "ccw"),
        (-math.pi / 2, "ccw"),  # y the same: counter-clockwise
    ],
)
def test_euler_column_buckles_onto_the_exact_post_buckled_branch(label, angle, side):
    """A cantilever turned by ``angle`` under the rectangular elastica's axial load: one
    bifurcation at the Euler load, the side by convention (BUCKLING_SIDES), and the tip of
    the exact elastica on that side."""
    r = solve(column(ELASTICA, angle), label)
    assert r.converged and r.stable, r.reason
    assert len(r.critical_load_factors) == 1
    assert r.critical_load_factors[0] * ELASTICA == pytest.approx(EULER, rel=CRITICAL_TOL[label])
    assert sides(r) == [side]
    assert r.notes == [buckling_note(r.critical_load_factors[0], WHY[side])] and not r.warnings
    along, across, turn = in_column_frame(r.points["beam.tip"].pose, angle)
    # the side taken: larger world y, or (a vertical column) counter-clockwise
    x, y, th = r.points["beam.tip"].pose
    if side == "y":
        assert y > 0.5 * math.cos(angle) ** 2
    else:
        assert th > angle
    tol = TIP_TOL[label]
    assert along == pytest.approx(ELASTICA_TIP[0], abs=tol)
    assert abs(across) == pytest.approx(ELASTICA_TIP[1], abs=tol)
    assert abs(turn) == pytest.approx(math.pi / 2, abs=5 * tol)
    assert r.residual <= 1e-12


@pytest.mark.parametrize("label", list(CRITICAL_TOL))
def test_rectangular_elastica_example_buckles(label):
    scene = example("rectangular_elastica")
    r = solve(scene, label)
    assert r.converged and r.stable
    assert r.critical_load_factors[0] == pytest.approx(
        exact.euler_load(1.0, 1.0) / ELASTICA, rel=CRITICAL_TOL[label]
    )
    assert sides(r) == ["y"]
    x, y, th = r.points["beam.tip"].pose
    assert (x, y) == (
        pytest.approx(ELASTICA_TIP[0], abs=TIP_TOL[label]),
        pytest.approx(ELASTICA_TIP[1], abs=TIP_TOL[label]),
    )
    assert th == pytest.approx(math.pi / 2, abs=1e-2)


# far beyond the Euler load (16 Euler loads at P = 40), against the exact elastica's post-buckled
# branch: the models' tip errors grow with the bend (the tip turns by 165 to 179 degrees here):
# six modes within 1e-4 at P = 12 and 1e-3 beyond, five modes 2e-3, the 16-element chain 5e-3
FAR = {
    ("scm6 gauss", 12.0): 1e-4,
    ("scm6 gauss", 25.0): 1e-3,
    ("scm6 gauss", 40.0): 1e-3,
    ("scm5 gauss", 12.0): 2e-3,
    ("scm5 gauss", 25.0): 2e-3,
    ("scm5 gauss", 40.0): 2e-3,
    ("fem16", 12.0): 5e-3,
    ("fem16", 25.0): 5e-3,
    ("fem16", 40.0): 5e-3,
}


@pytest.mark.parametrize("label, P", list(FAR))
@pytest.mark.parametrize("angle", [0.0, 2.0])
def test_loads_far_beyond_the_euler_load(label, P, angle):
    r = solve(column(P, angle), label)
    assert r.converged and r.stable, r.reason
    assert r.critical_load_factors[0] * P == pytest.approx(EULER, rel=CRITICAL_TOL[label])
    assert sides(r)[0] == "y"
    ref = exact.cantilever(1.0, 1.0, (-P, 0.0))
    assert ref.converged and ref.branch == "post-buckled"
    along, across, turn = in_column_frame(r.points["beam.tip"].pose, angle)
    tol = FAR[label, P]
    assert along == pytest.approx(ref.pose[0], abs=tol)
    assert abs(across) == pytest.approx(abs(ref.pose[1]), abs=tol)
    assert abs(turn) == pytest.approx(abs(ref.pose[2]), abs=tol)


@pytest.mark.parametrize("label", ["fem16", "scm5 gauss", "prb"])
@pytest.mark.parametrize("angle", [0.0, 2.0])
def test_below_the_euler_load_the_column_stays_straight(label, angle):
    """0.9 Euler loads: no bifurcation, no warning, the straight column (inextensible: the tip
    where it was) with a positive definite stiffness."""
    r = solve(column(0.9 * EULER, angle), label)
    assert r.converged and r.stable and r.critical_load_factors == [] and r.warnings == []
    x, y, th = r.points["beam.tip"].pose
    assert (x, y, th) == (
        pytest.approx(math.cos(angle), abs=1e-12),
        pytest.approx(math.sin(angle), abs=1e-12),
        pytest.approx(angle, abs=1e-12),
    )
    assert np.all(np.linalg.eigvalsh(r.stiffness) > 0)


# -- 2. an asymmetric bifurcation ------------------------------------------------------------------


@pytest.mark.parametrize(
    "label, T, ry, side, other",
    [
        ("prb", 8.0, 1.5, "lower", True),
        ("fem4", 8.0, 1.5, "lower", False),
        ("fem16", 8.0, 1.5, "lower", False),
        ("prb", 20.0, -3.0, "lower", True),
        ("scm5 gauss", 20.0, 1.5, "lower", True),
        ("fem4", 20.0, 0.5, "only", False),
        ("fem16", 20.0, 0.5, "only", False),
    ],
)
def test_asymmetric_bifurcation_under_a_tendon(label, T, ry, side, other):
    """A bifurcation whose sides differ in potential energy: the answer is a stable equilibrium
    (zero gradient of the potential and positive definite stiffness, both computed here) of lower
    potential than the equilibrium on the other side, found here by minimizing the potential
    (BFGS, reference kinematics) from the mirrored state; ``other``: that one exists."""
    from scipy.optimize import minimize

    scene = tendon_column(T, ry)
    ms = models(scene, label)
    r = solve_models(scene, ms)
    assert r.converged and r.stable, r.reason
    assert len(r.critical_load_factors) >= 1 and sides(r)[0] == side
    q = np.asarray(r.q["a"])
    g, scale = potential_gradient(scene, ms, q)
    assert np.linalg.norm(g) <= 1e-9 * scale
    assert np.all(np.linalg.eigvalsh(r.stiffness) > 0)
    found = minimize(
        lambda x: potential(scene, ms, x),
        -q,
        jac=lambda x: potential_gradient(scene, ms, x)[0],
        method="BFGS",
        options=dict(gtol=1e-10),
    )
    go, so = potential_gradient(scene, ms, found.x)
    distinct = np.linalg.norm(go) <= 1e-6 * so and np.max(np.abs(found.x - q)) > 1e-3
    if other:
        assert distinct, found
    if distinct:
        assert potential(scene, ms, q) < potential(scene, ms, found.x)


@pytest.mark.parametrize("label, T, ry", [("fem16", 8.0, 1.5), ("scm5 gauss", 20.0, 1.5)])
def test_a_warm_start_on_the_other_side_of_a_bifurcation(label, T, ry):
    """q0 mirrored: a stable equilibrium all the same (the other side's, or the continuation's
    answer when the warm start is rejected)."""
    scene = tendon_column(T, ry)
    ms = models(scene, label)
    solver = Solver(scene, ms)
    q = np.asarray(solver.solve().q["a"])
    r = solver.solve(q0={"a": (-q).tolist()})
    assert r.converged and r.stable, r.reason
    g, scale = potential_gradient(scene, ms, np.asarray(r.q["a"]))
    assert np.linalg.norm(g) <= 1e-9 * scale
    assert np.all(np.linalg.eigvalsh(r.stiffness) > 0)


# -- 3. a snap-through -----------------------------------------------------------------------------


@cache
def exact_equilibria(force, moment, n=601, span=12.0):
    """Every exact equilibrium of the unit cantilever under the dead tip load: the roots of the
    tip-moment residual in the root moment mu0 on [-span, span] (a fine scan, then Brent), as
    (tip pose, stable by the Jacobi test)."""
    from scipy.optimize import brentq

    fx, fy = force

    def R(mu0):
        return float(exact._shoot(mu0, fx, fy).y[3, -1]) - moment

    mus = np.linspace(-span, span, n)
    vals = np.array([R(m) for m in mus])
    out = []
    for a, b, ra, rb in zip(mus[:-1], mus[1:], vals[:-1], vals[1:]):
        if np.sign(ra) != np.sign(rb):
            mu = brentq(R, a, b, xtol=1e-14)
            sol = exact._shoot(mu, fx, fy)
            out.append((sol.y[:3, -1].copy(), exact._stability(sol)[0]))
    return out


@pytest.mark.parametrize("label, tol", [("scm5 gauss", 1e-3), ("scm6 gauss", 1e-3)])
def test_snap_through(label, tol):
    """A tip force and moment whose proportional path has a fold near load factor 0.5457: the
    critical load factor is the exact elastica's fold; the solve goes on to a stable state at the
    full load, which is one of the stable exact equilibria there (not the branch it left)."""
    scene = cantilever(**SNAP)
    r = solve(scene, label)
    assert r.converged and r.stable, r.reason
    ref = exact.cantilever(1.0, 1.0, SNAP["force"], SNAP["moment"])
    assert not ref.converged and ref.critical_load_factor is not None  # the path ends
    assert len(r.critical_load_factors) == 1
    assert r.critical_load_factors[0] == pytest.approx(ref.critical_load_factor, rel=1e-4)
    assert sides(r) == ["snap"]
    assert r.notes == [snap_note(r.critical_load_factors[0])] and not r.warnings
    pose = np.asarray(r.points["beam.tip"].pose)
    found = exact_equilibria(SNAP["force"], SNAP["moment"])
    stable = [p for p, st in found if st]
    assert stable, found
    best = min(stable, key=lambda p: np.max(np.abs(p - pose)))
    assert np.max(np.abs(best - pose)) <= tol, (pose, stable)


# -- 4. kernel switches ----------------------------------------------------------------------------


@pytest.mark.parametrize("modes, tol", [(3, 2e-3), (5, 1e-5)])
def test_rectangular_elastica_with_the_auto_kernel_switches(modes, tol):
    """The scene's own model (scm "auto") passes the polynomial kernel's range (90 degrees) on
    the way: the switch is reported, and the answer is the exact elastica's (to the model's
    error, model-notes.md)."""
    r = flexgen.solve(example("rectangular_elastica"), modes=modes)
    assert r.converged and r.stable, r.reason
    switch = [w for w in r.notes if "switched to the Gauss kernel" in w]
    assert len(switch) == 1 and "'beam'" in switch[0] and f"scm{modes}" in switch[0]
    assert switch[0] == SCMModel(1.0, 1.0, modes, name="beam").switch_note(r.q["beam"])
    assert len(r.critical_load_factors) == 1
    x, y, th = r.points["beam.tip"].pose
    assert (x, y) == (
        pytest.approx(ELASTICA_TIP[0], abs=tol),
        pytest.approx(ELASTICA_TIP[1], abs=tol),
    )
    assert th == pytest.approx(math.pi / 2, abs=1e-2)


def test_poly_kernel_past_its_range():
    """A tip moment that would bend scm3 (poly only: |phi| <= 90 deg) to 150 degrees: no
    equilibrium, and the reason says why; "auto" (the local kernel, which certifies its bound
    there) gives the closed form (a pure moment: the tip turns by M L/EI exactly, the arc)."""
    M = math.radians(150.0)
    poly = solve_models(
        cantilever(moment=M), {"beam": SCMModel(1.0, 1.0, 3, kernel="poly", name="beam")}
    )
    assert poly.converged is False and poly.q == {} and poly.points == {}
    assert "bent past the range of the polynomial kernel" in poly.reason
    auto = solve_models(cantilever(moment=M), {"beam": SCMModel(1.0, 1.0, 3, name="beam")})
    assert auto.converged and auto.stable
    assert auto.kernel == {"beam": "local"} and auto.notes == []  # certified at 150 degrees
    x, y, th = auto.points["beam.tip"].pose
    assert th == pytest.approx(M, abs=1e-9)


@pytest.mark.parametrize("degrees", [150.0, 200.0, 300.0])
def test_gauss_kernel_past_its_certified_range(degrees):
    """kernel="gauss" is certified for |phi| <= 180 degrees; a pure moment past it is still
    reached (by the continuation) and is the arc: tip angle M L/EI, x = sin(M)/M, y = (1 -
    cos M)/M."""
    M = math.radians(degrees)
    r = solve(cantilever(moment=M), "scm3 gauss")
    assert r.converged and r.stable, r.reason
    x, y, th = r.points["beam.tip"].pose
    assert th == pytest.approx(M, abs=1e-9)
    assert x == pytest.approx(math.sin(M) / M, abs=1e-9)
    assert y == pytest.approx((1 - math.cos(M)) / M, abs=1e-9)


def test_a_reused_model_does_not_carry_a_switch_warning():
    """One SCMModel instance solved past its local kernel's certificate, then within it: the
    second answer has no switch note (the core reports switches per solve)."""
    model = SCMModel(1.0, 1.0, 3, name="beam")
    first = solve_models(cantilever(moment=math.radians(330.0)), {"beam": model})
    assert any("switched to the Gauss kernel" in w for w in first.notes)
    second = solve_models(cantilever(moment=math.radians(30.0)), {"beam": model})
    assert second.converged and second.warnings == [] and second.notes == []
    assert second.points["beam.tip"].pose[2] == pytest.approx(math.radians(30.0), abs=1e-12)


# -- 5. warm starts ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, warm, label",
    [
        ("cantilever_tip_load", "scm3", "scm3"),
        ("cantilever_tip_load", "scm3", "scm4"),  # q0 padded with zeros
        ("two_link_finger", "scm4", "scm3"),  # q0 truncated
        ("tree", "scm3", "scm3 gauss"),
        ("tendon_chain", "fem4", "fem4"),
        ("rectangular_elastica", "scm5 gauss", "scm5 gauss"),  # a buckled answer
    ],
)
def test_warm_start_gives_the_same_equilibrium(name, warm, label):
    scene = example(name) if name == "rectangular_elastica" else SCENES[name]()
    q0 = solve(scene, warm).q
    cold = solve(scene, label)
    hot = solve(scene, label, q0=q0)
    assert cold.converged and hot.converged and hot.stable, hot.reason
    for p in cold.points:
        assert np.allclose(
            hot.points[p].pose,
            cold.points[p].pose,
            rtol=0,
            atol=1e-9 * max(f.length for f in scene.flexures),
        )
    if warm == label and name != "rectangular_elastica":
        # from the answer itself, whose load path is simple: Newton at the full load, no path
        assert hot.iterations <= cold.iterations and hot.critical_load_factors == []
    if name == "rectangular_elastica":
        # a buckled answer is past a bifurcation, off the direct solve's path samples: the warm
        # start is refused and the cold solve answers, its critical load with it; without the
        # samples (warm_on_path = 0) Newton from the answer keeps it, no path followed
        assert hot.critical_load_factors == cold.critical_load_factors != []
        kept = solve(scene, label, q0=q0, warm_on_path=0)
        assert kept.iterations <= cold.iterations and kept.critical_load_factors == []


def test_a_warm_start_near_another_stable_equilibrium_gives_the_load_paths():
    """Where several stable equilibria hold the load, a warm start from a previous answer at
    other loads may lie nearer another one than the load path from the unloaded state reaches
    (found by review in a sweep: the thin finger's rows from F = -0.556 N on sat on another
    branch than flexgen.solve's, 140 mm away). A warm start is accepted only on the load path
    (the direct solve's path samples): without them (direct_samples = 0) the same warm start
    lands on the other branch, so this test can tell."""
    scene = example("two_link_finger").with_values(
        {"flexure.proximal.length": 0.0225, "flexure.proximal.thickness": 0.0002}
    )
    before, after = [[0.0, -0.4444444444444444, 0.0]], [[0.0, -0.5555555555555556, 0.0]]
    prev = flexgen.Solver(scene)
    prev.run(loads=before)
    q0 = {name: prev.workspace.q[sl].copy() for name, sl in prev.problem.chain.slices.items()}
    cold = flexgen.Solver(scene).solve(loads=after)
    unchecked = flexgen.Solver(scene, direct_samples=0).solve(loads=after, q0=q0)
    warm = flexgen.Solver(scene).solve(loads=after, q0=q0)
    pad = "fingertip.pad"
    assert unchecked.stable and abs(unchecked.points[pad].pose[2] - cold.points[pad].pose[2]) > 1
    assert warm.converged and warm.stable
    assert np.allclose(warm.points[pad].pose, cold.points[pad].pose, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "name, q0",
    [
        ("cantilever_tip_load", {"beam": [3.0, -1.0, 0.5]}),  # far off: Newton leaves max_dq
        ("two_link_finger", {}),  # all zeros: Newton at the full load
        ("rectangular_elastica", {}),  # zeros: the unstable straight state
        ("rectangular_elastica", {"beam": [-1.5]}),  # the mirrored post-buckled branch
        ("rectangular_elastica", {"beam": [1.5]}),  # near the post-buckled branch
    ],
)
def test_a_poor_warm_start_still_reaches_the_stable_equilibrium(name, q0):
    """Whatever q0, the answer is a stable equilibrium; where the warm start is rejected, the
    one the continuation from the unloaded state reaches."""
    scene = example(name)
    cold = solve(scene, "scm3")
    r = solve(scene, "scm3", q0=q0)
    assert r.converged and r.stable, r.reason
    ms = models(scene, "scm3")
    q = Chain(scene, ms).pack(r.q)
    g, scale = potential_gradient(scene, ms, q)
    assert np.linalg.norm(g) <= 1e-9 * scale
    if name == "rectangular_elastica" and q0.get("beam", [0.0])[0] < 0:
        # the mirror image of the cold answer is as good an equilibrium: either is right
        x, y, _ = r.points["beam.tip"].pose
        assert abs(y) == pytest.approx(cold.points["beam.tip"].pose[1], abs=1e-9)
    else:
        for p in cold.points:
            assert np.allclose(r.points[p].pose, cold.points[p].pose, rtol=0, atol=1e-9)


def test_a_non_finite_warm_start_is_refused_and_the_core_survives_one():
    """Python refuses a NaN q0 as flexgen.solve does (one line naming it); the core, given one
    anyway (a C caller), rejects the warm start and answers cold."""
    from flexgen import core
    from flexgen.solver import Solver

    scene = example("cantilever_tip_load")
    cold = solve(scene, "scm3")
    s = Solver(scene, models(scene, "scm3"))
    with pytest.raises(ValueError, match=r"^q0\['beam'\]: must be a list of finite numbers"):
        s.solve(q0={"beam": [float("nan")] * 3})
    ws = s.workspace
    ws.q0[:] = float("nan")
    s.problem.struct.q0 = ws.q0_ptr
    status = core.lib.fg_solve(s.problem.struct, ws.work_ptr, ws.iwork_ptr, ws.answer)
    s.problem.struct.q0 = core.ffi.NULL
    assert status == core.SOLVED and ws.answer.stable and not ws.answer.warm
    assert np.allclose(ws.pose[0], cold.points["beam.tip"].pose, rtol=0, atol=1e-9)


# -- 6. compliance and stiffness -------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, label",
    [
        ("cantilever_tip_load", "scm3"),
        ("two_link_finger", "scm4"),
        ("tree", "fem16"),  # a 3-flexure tree with a tendon and moments
        ("tree", "scm3 gauss"),
        ("tendon_chain", "prb"),
    ],
)
def test_compliance_matches_finite_differences_of_solves(name, label):
    """compliance3 = d(pose)/d(fx, fy, m) at each output point: central differences of solves
    under a small extra load at the point."""
    scene = SCENES[name]()
    f0 = scene.flexures[0]
    fscale, mscale = f0.EI / f0.length**2, f0.EI / f0.length
    base = solve(scene, label)
    assert base.converged and base.stable, base.reason
    for ref in base.points:
        C = np.asarray(base.points[ref].compliance3)
        fd = np.zeros((3, 3))
        for j, (unit, h) in enumerate(
            (((1, 0, 0), 1e-5 * fscale), ((0, 1, 0), 1e-5 * fscale), ((0, 0, 1), 1e-5 * mscale))
        ):
            poses = []
            for sign in (1.0, -1.0):
                extra = Load(ref, (sign * h * unit[0], sign * h * unit[1]), sign * h * unit[2])
                r = solve(replace(scene, loads=tuple(scene.loads) + (extra,)), label)
                assert r.converged
                poses.append(np.asarray(r.points[ref].pose))
            fd[:, j] = (poses[0] - poses[1]) / (2 * h)
        rel = np.linalg.norm(C - fd, 2) / np.linalg.norm(C, 2)
        assert rel <= 1e-6, (ref, rel, C, fd)
        assert np.allclose(base.points[ref].compliance, C[:2, :2], rtol=0, atol=0)


@pytest.mark.parametrize(
    "name, label",
    [
        ("cantilever_tip_load", "scm3"),
        ("two_link_finger", "scm4"),
        ("arc_moment", "scm5 gauss"),
        ("tree", "fem16"),
        ("tree", "scm3 gauss"),
        ("tendon_chain", "prb"),
        ("rectangular_elastica", "scm5 gauss"),
    ],
)
def test_stiffness_is_the_derivative_of_the_residual(name, label):
    """At the answer: the residual (grad of the potential, from the reference kinematics) is
    zero; Result.stiffness is its derivative (central differences); the compliance of every
    output point is J K^-1 J^T; stable means K positive definite."""
    scene = example(name) if name == "rectangular_elastica" else SCENES[name]()
    ms = models(scene, label)
    r = solve_models(scene, ms)
    assert r.converged and r.stable, r.reason
    chain = Chain(scene, ms)
    q = chain.pack(r.q)
    g, scale = potential_gradient(scene, ms, q)
    assert np.linalg.norm(g) <= 1e-9 * scale
    K = np.asarray(r.stiffness)
    assert K.shape == (chain.ndof, chain.ndof)
    E = np.eye(chain.ndof)
    h = 1e-6
    Kfd = np.stack(
        [
            (
                potential_gradient(scene, ms, q + h * e)[0]
                - potential_gradient(scene, ms, q - h * e)[0]
            )
            / (2 * h)
            for e in E
        ],
        1,
    )
    assert np.linalg.norm(K - Kfd) <= 1e-6 * np.linalg.norm(K)
    assert np.allclose(K, K.T, rtol=0, atol=1e-12 * np.abs(K).max())
    assert np.all(np.linalg.eigvalsh(K) > 0)
    for ref, pr in r.points.items():
        J = chain.point(ref, q).J
        C = J @ np.linalg.solve(K, J.T)
        C3 = np.asarray(pr.compliance3)
        assert np.linalg.norm(C - C3) <= 1e-9 * np.linalg.norm(C3), ref


def test_the_validity_margin_from_the_stiffness_is_the_one_it_recomputes():
    """validity.stiffness_margin from Result.stiffness equals the one it solves again for; below
    the Euler load it is 1 - P/P_cr."""
    from flexgen import validity

    scene = example("two_link_finger")
    ms = models(scene, "scm3")
    r = solve_models(scene, ms)
    reused = validity.stiffness_margin(scene, ms, r.q, r.stiffness)
    fresh = validity.stiffness_margin(scene, ms, r.q, None)
    assert reused == pytest.approx(fresh, rel=1e-9) and 0 < reused < 1
    col = column(0.5 * EULER, 0.0)
    ms = models(col, "scm5 gauss")
    r = solve_models(col, ms)
    assert validity.stiffness_margin(col, ms, r.q, r.stiffness) == pytest.approx(0.5, rel=1e-7)


# -- 7. Solver.solve with other loads and tensions ---------------------------------------------------


def test_solver_solve_with_loads_and_tensions_equals_a_fresh_solve():
    scene = example("two_link_finger")
    solver = flexgen.Solver(scene)
    for loads, tensions in (
        ([[0.0, -0.5, 0.0]], [5.0]),
        ([[0.1, -0.1, 1e-3]], [20.0]),
        (None, [0.0]),
        ([[0.0, 0.0, 0.0]], None),
    ):
        r = solver.solve(loads=loads, tensions=tensions)
        new_loads = (
            scene.loads
            if loads is None
            else tuple(
                replace(ld, force=(row[0], row[1]), moment=row[2])
                for ld, row in zip(scene.loads, loads)
            )
        )
        new_tendons = (
            scene.tendons
            if tensions is None
            else tuple(replace(t, tension=T) for t, T in zip(scene.tendons, tensions))
        )
        fresh = solve_models(replace(scene, loads=new_loads, tendons=new_tendons))
        assert r.converged and fresh.converged
        assert r.q == fresh.q and r.iterations == fresh.iterations
        for p in fresh.points:
            assert r.points[p].pose == fresh.points[p].pose
            assert r.points[p].compliance3 == fresh.points[p].compliance3
    # and back to the scene's own loads
    again = solver.solve()
    assert again.q == solve_models(scene).q


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(loads=[[0.0, -0.5]]),  # one value short
        dict(loads=[[0.0, -0.5, 0.0], [1.0, 0.0, 0.0]]),
        dict(loads=[0.0, -0.5, 0.0, 1.0]),
        dict(tensions=[1.0, 2.0]),
        dict(tensions=[]),
        dict(loads=[[0.0, float("nan"), 0.0]]),
        dict(tensions=[float("inf")]),
    ],
)
def test_bad_loads_or_tensions_are_a_value_error(kwargs):
    solver = flexgen.Solver(example("two_link_finger"))
    with pytest.raises(ValueError, match="loads|tensions"):
        solver.solve(**kwargs)
    assert solver.solve().converged  # the solver is still usable


def test_a_workspace_carries_nothing_between_solves():
    """Solve twice, with garbage in the workspace, and with another solver's solve in between:
    the same answer, bit for bit (no state kept from one solve to the next, no globals)."""
    solver = Solver(TREE, models(TREE, "fem16"))

    def answer(r):
        return (
            r.q,
            {p: (v.pose, v.compliance3) for p, v in r.points.items()},
            r.iterations,
            r.energy,
            r.residual,
            r.warnings,
            r.critical_load_factors,
        )

    first = answer(solver.solve())
    assert answer(solver.solve()) == first
    ws = solver.workspace
    ws.work[:] = np.nan
    ws.iwork[:] = -7
    ws.q[:] = np.inf
    ws.K[:] = np.nan
    assert answer(solver.solve()) == first
    other = Solver(column(ELASTICA, 0.0), models(column(ELASTICA, 0.0), "scm5 gauss"))
    assert other.solve().critical_load_factors
    assert answer(solver.solve()) == first


LAPACK_CASES = {
    "rectangular_elastica": lambda: example("rectangular_elastica"),
    "tree": lambda: TREE,
    "column 25": lambda: column(25.0, 0.0),
    "column vertical": lambda: column(ELASTICA, math.pi / 2),
    "snap": lambda: cantilever(**SNAP),
    "tendon lower": lambda: tendon_column(8.0, 1.5),
    "tendon only": lambda: tendon_column(20.0, 0.5),
}


@pytest.mark.parametrize(
    "name, label",
    [
        ("rectangular_elastica", "scm5 gauss"),
        ("rectangular_elastica", "fem16"),
        ("tree", "fem16"),
        ("column 25", "scm5 gauss"),
        ("column vertical", "fem16"),
        ("snap", "scm5 gauss"),
        ("tendon lower", "fem4"),
        ("tendon only", "fem4"),
    ],
)
def test_lapack_and_builtin_factorizations_agree(name, label):
    """From lapack_min_size coordinates on the core calls SciPy's LAPACK (factorizations and
    dsyev); its built-in factorizations and Jacobi eigen-solver must give the same answer,
    bifurcations and snap-throughs included."""
    from flexgen.core import lapack

    if not lapack():
        pytest.skip("SciPy's LAPACK routines are not available")
    scene = LAPACK_CASES[name]()
    a = solve(scene, label, lapack_min_size=1)
    b = solve(scene, label, lapack_min_size=10**9)
    assert a.converged and b.converged
    assert sides(a) == sides(b)
    assert a.critical_load_factors == pytest.approx(b.critical_load_factors, rel=1e-9)
    for p in a.points:
        assert np.allclose(a.points[p].pose, b.points[p].pose, rtol=0, atol=1e-11)
        Ca, Cb = np.asarray(a.points[p].compliance3), np.asarray(b.points[p].compliance3)
        assert np.linalg.norm(Ca - Cb) <= 1e-9 * np.linalg.norm(Ca)


# a chain of six flexures of mixed models: a tendon from the base to f1's tip (f0 and f1 keep
# every coordinate), f2 a 4-element chain, a branch g off f3, loads with moments
MIXED = scene_from_dict(
    {
        "name": "mixed chain",
        "base": {"points": {"r0": [0.0, 0.2]}},
        "flexure": [
            {
                "name": f"f{i}",
                "parent": "base" if i == 0 else f"f{i - 1}",
                "length": 0.4,
                "EI": 1.0 + 0.1 * i,
                "at": [0.0, 0.0, 0.1],
            }
            for i in range(6)
        ]
        + [{"name": "g", "parent": "f3", "length": 0.3, "EI": 0.5, "at": [0.0, 0.05, -0.4]}],
        "link": [{"name": "h", "parent": "f1", "points": {"hole": [0.02, 0.06]}}],
        "load": [
            {"point": "f5.tip", "force": [0.4, -1.1], "moment": 0.2},
            {"point": "g.tip", "force": [-0.3, 0.5], "moment": -0.1},
        ],
        "tendon": [{"tension": 0.9, "route": ["base.r0", "h.hole"]}],
        "output": {"points": ["f5.tip", "g.tip"]},
    }
)
MIXED_MODELS = {"f2": fem(4), "f4": scm(5), "g": scm(4, "gauss")}


def mixed_models(scene):
    return build_models(scene, None, lambda f: MIXED_MODELS.get(f.name, scm(3))(f))


ELIMINATION_CASES = {
    "tree": (lambda: TREE, "scm3"),
    "tree gauss": (lambda: TREE, "scm5 gauss"),
    "tendon chain": (lambda: TENDON_CHAIN, "scm4"),
    "finger": (lambda: example("two_link_finger"), "scm3"),
    "column buckling": (lambda: column(25.0, 0.3), "scm5 gauss"),
    "snap": (lambda: cantilever(**SNAP), "scm3"),
    "rectangular elastica": (lambda: example("rectangular_elastica"), "scm6 gauss"),
    "mixed": (lambda: MIXED, None),
}


@pytest.mark.parametrize("name", list(ELIMINATION_CASES))
def test_the_factorization_in_elimination_order_agrees_with_the_dense_one(name):
    """From elimination_min_size coordinates on the core factorizes K after eliminating each
    kernel flexure's non-angle coordinates (those no tendon reaches): the answer (poses,
    compliances, stiffness, stability, the sides taken at bifurcations and snap-throughs) must
    be the dense factorization's to rounding, tendons, branches and fem flexures included."""
    factory, label = ELIMINATION_CASES[name]
    scene = factory()
    ms = (lambda: mixed_models(scene)) if label is None else (lambda: models(scene, label))
    a = solve_models(scene, ms(), elimination_min_size=0)
    b = solve_models(scene, ms(), elimination_min_size=10**9)
    assert a.converged and b.converged
    assert a.stable == b.stable and sides(a) == sides(b)
    assert a.critical_load_factors == pytest.approx(b.critical_load_factors, rel=1e-9)
    for p in a.points:
        assert np.allclose(a.points[p].pose, b.points[p].pose, rtol=0, atol=1e-11)
        Ca, Cb = np.asarray(a.points[p].compliance3), np.asarray(b.points[p].compliance3)
        assert np.linalg.norm(Ca - Cb) <= 1e-9 * np.linalg.norm(Cb)
    Ka, Kb = np.asarray(a.stiffness), np.asarray(b.stiffness)
    assert np.linalg.norm(Ka - Kb) <= 1e-9 * np.linalg.norm(Kb)


def test_the_elimination_order_keeps_what_tendons_and_other_models_couple():
    """The order the core factorizes in (fg_ws.perm, in iwork after the pivots and the four
    per-flexure arrays: bind): in MIXED, the non-angle coordinates of f3, f5 (scm3), f4 (scm5)
    and g (scm4) come first, flexure by flexure; f0 and f1 (under the tendon) and the fem f2
    keep every coordinate, the others their angle."""
    solver = Solver(MIXED, mixed_models(MIXED), SolverSettings(elimination_min_size=0))
    assert solver.solve().converged
    offsets, at = {}, 0
    for f in MIXED.flexures:
        offsets[f.name] = (at, solver.models[f.name].n_dof)
        at += offsets[f.name][1]
    n, nflex = at, len(MIXED.flexures)
    perm = list(solver.workspace.iwork[n + 1 + 4 * nflex :][:n])

    def coords(name, first, last=None):
        o, k = offsets[name]
        return list(range(o + first, o + (k if last is None else last)))

    eliminated = coords("f3", 1) + coords("f4", 1) + coords("f5", 1) + coords("g", 1)
    kept = (
        coords("f0", 0)
        + coords("f1", 0)
        + coords("f2", 0)
        + coords("f3", 0, 1)
        + coords("f4", 0, 1)
        + coords("f5", 0, 1)
        + coords("g", 0, 1)
    )
    assert perm == eliminated + kept


def test_critical_events_beyond_the_capacity_are_counted_and_said():
    """The caller gives the capacity of the critical arrays (fg_answer.max_critical): a path
    with more critical events than that is still solved; the first ones are listed and a
    warning counts the others."""
    # two independent columns from the base, 10x and 2x their Euler load: two bifurcations
    scene = scene_from_dict(
        {
            "name": "two columns",
            "flexure": [
                {"name": "a", "length": 1.0, "EI": 1.0},
                {"name": "b", "parent": "base", "at": [0.0, 1.0, 0.0], "length": 1.0, "EI": 1.0},
            ],
            "load": [
                {"point": "a.tip", "force": [-25.0, 0.0]},
                {"point": "b.tip", "force": [-5.0, 0.0]},
            ],
        }
    )
    solver = Solver(scene)
    full = solver.solve()
    assert full.converged and len(full.critical_load_factors) == 2  # two bifurcations
    euler = math.pi**2 / 4
    assert full.critical_load_factors == pytest.approx([euler / 25, euler / 5], rel=1e-3)
    solver.workspace.answer.max_critical = 1
    cut = solver.solve()
    assert cut.converged and cut.critical_load_factors == full.critical_load_factors[:1]
    assert cut.q == full.q
    assert "1 more critical events on the load path are not listed" in cut.notes
    solver.workspace.answer.max_critical = 2
    again = solver.solve()
    assert again.converged and again.critical_load_factors == full.critical_load_factors


def test_result_says_which_solver_answered():
    scene = example("cantilever_tip_load")
    r = flexgen.solve(scene)
    assert r.solver == "core" and "solver" not in r.contract()
    assert isinstance(r.stiffness, np.ndarray)
    assert r.contract()["stiffness"] == r.stiffness.tolist()  # in the JSON since issue 11
    ex = flexgen.solve(scene, model="exact")
    assert ex.solver == "exact" and ex.stiffness is None and ex.contract()["stiffness"] is None


def test_every_shipped_kernel_is_compiled_into_the_core():
    """The core carries every C kernel of generated/c; a kernel it does not carry is a
    KernelNotFound naming the ones it has."""
    from flexgen import kernels
    from flexgen.core import compiled_kernels, kernel_functions

    shipped = sorted(p.stem for p in (kernels.GENERATED / "c").glob("scm*.c"))
    assert compiled_kernels() == shipped
    with pytest.raises(kernels.KernelNotFound, match="scm99.*scm3_gauss25"):
        kernel_functions("scm99")


def test_a_model_of_no_known_kind_is_refused():
    """The core evaluates the registry's model kinds only: another FlexureModel is a ModelError
    naming the kinds (not solved with something else)."""
    from flexgen.models.registry import ModelError

    class Mine:
        kind, n_dof, length, EI = "mine", 1, 1.0, 1.0

    with pytest.raises(ModelError, match="scm, cc, prb, fem"):
        flexgen.solve(example("cantilever_tip_load"), models={"beam": Mine()})


def test_the_solver_cache_tells_models_and_settings_apart():
    """flexgen.solve keeps prepared solvers per scene object: every model override and setting
    that changes the answer gets its own (one scene object, solved in turns, twice over)."""
    scene = cantilever(moment=math.radians(330.0))  # past the local kernel: no direct solve
    variants = [
        dict(),
        dict(modes=5),
        dict(model="prb"),
        dict(model="fem", elements=8),
        dict(model="cc"),
        dict(tol=1e-6),
        dict(max_steps=1),
        dict(max_dq=1e-3),
        dict(models={"beam": SCMModel(1.0, 2.0, 3, kernel="gauss", name="beam")}),
    ]
    first = [flexgen.solve(scene, **kw) for kw in variants]
    # the variants differ where they should: fresh solves of each are the reference
    for kw, r in zip(variants, first):
        kw = dict(kw)
        ms = kw.pop("models", None)
        sc = flexgen.api.override(
            scene, kw.pop("model", None), kw.pop("modes", None), kw.pop("elements", None)
        )
        fresh = Solver(sc, ms, SolverSettings(**kw)).solve()
        assert (r.converged, r.q, r.iterations) == (fresh.converged, fresh.q, fresh.iterations), kw
    assert first[0].converged and first[6].converged is False and first[7].converged is False
    assert first[8].points["beam.tip"].pose[2] == pytest.approx(math.radians(165.0), abs=1e-9)
    second = [flexgen.solve(scene, **kw) for kw in variants]
    assert [r.q for r in second] == [r.q for r in first]


# -- 8. settings and options --------------------------------------------------------------------------


def test_settings_reach_the_core():
    elastica = example("rectangular_elastica")
    default = flexgen.solve(elastica)
    loose = flexgen.solve(elastica, tol=1e-6)
    assert default.converged and loose.converged
    assert default.residual <= 1e-12 and loose.residual <= 1e-6
    assert loose.iterations < default.iterations  # fewer Newton iterations per step
    x, y, _ = loose.points["beam.tip"].pose
    assert (x, y) == (
        pytest.approx(ELASTICA_TIP[0], abs=2e-3),
        pytest.approx(ELASTICA_TIP[1], abs=2e-3),
    )
    assert (
        flexgen.Solver(elastica, settings=SolverSettings(tol=1e-6)).solve().iterations
        == loose.iterations
    )
    scene = example("cantilever_tip_load")
    # no Newton iteration allowed: no equilibrium
    none = flexgen.solve(scene, max_iterations=0)
    assert none.converged is False and none.reason
    # the same through a SolverSettings and through flexgen.Solver
    assert flexgen.solve(scene, settings=SolverSettings(max_iterations=0)).converged is False
    assert flexgen.Solver(scene, max_iterations=0).solve().converged is False


def test_max_steps_on_a_buckling_scene():
    """The rectangular elastica needs the continuation: one step is not enough, and the reason
    says the continuation ran out of steps."""
    scene = example("rectangular_elastica")
    r = flexgen.solve(scene, max_steps=1)
    assert r.converged is False and r.q == {} and r.points == {}
    assert "load continuation needed more than 1 steps" in r.reason
    assert flexgen.solve(scene).converged  # the cache tells the settings apart


def test_max_iterations_and_steps_limit_no_equilibrium_is_reported_not_raised():
    scene = example("rectangular_elastica")
    r = flexgen.solve(scene, modes=5, max_iterations=1, max_steps=3)
    assert r.converged is False and r.reason
    assert "not converged" in r.table().lower()


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda s: flexgen.solve(s, bogus_option=1), "bogus_option"),
        (lambda s: flexgen.solve(s, backend="c"), "backend"),  # the deleted backend=
        (lambda s: flexgen.solve(s, model_factory=None), "model_factory"),
        (lambda s: flexgen.Solver(s, bogus_option=1), "bogus_option"),
        (lambda s: solve_models(s, bogus_option=1), "bogus_option"),
    ],
)
def test_an_unknown_option_is_a_type_error_naming_it(call, name):
    with pytest.raises(TypeError, match=f"'{name}'"):
        call(example("cantilever_tip_load"))


def test_settings_must_be_solver_settings():
    with pytest.raises(TypeError, match="SolverSettings"):
        flexgen.solve(example("cantilever_tip_load"), settings={"tol": 1e-8})


# -- 9. the C source ------------------------------------------------------------------------------


def _strip_comments(text: str) -> str:
    return re.sub(r"/\*.*?\*/|//[^\n]*", " ", text, flags=re.S)


@pytest.mark.parametrize("opt", ["-O0", "-O2"])
def test_c_source_compiles_strictly_without_writable_globals(opt, tmp_path):
    if shutil.which("gcc") is None:
        pytest.skip("gcc is not available")
    obj = tmp_path / "chain_solver.o"
    proc = subprocess.run(
        [
            "gcc",
            *[flag for flag in STRICT if not flag.startswith("-O")],
            opt,
            f"-I{SOURCE.parent}",
            "-c",
            str(SOURCE),
            "-o",
            str(obj),
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    if shutil.which("nm") is None:
        pytest.skip("nm is not available")
    out = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout
    symbols = [line.split() for line in out.splitlines() if line.strip()]
    writable = [s for s in symbols if len(s) >= 2 and s[-2] in ("B", "D", "C", "b", "d")]
    assert writable == [], writable
    defined = {s[-1] for s in symbols if len(s) == 3 and s[1] == "T"}
    assert {"fg_solve", "fg_work_size", "fg_iwork_size"} <= defined


def test_c_source_uses_no_heap():
    code = _strip_comments(SOURCE.read_text())
    for name in ("malloc", "calloc", "realloc", "free", "alloca"):
        assert not re.search(rf"\b{name}\s*\(", code), name


def test_a_problem_the_core_refuses_is_a_reason_not_a_stale_answer():
    """FG_MODEL_ERROR (a malformed fg_problem, which flexgen.problem never builds; here a setting
    changed behind SolverSettings' back): no equilibrium, a reason saying so, and nothing left
    over from the previous solve."""
    s = flexgen.Solver(EXAMPLES / "rectangular_elastica.toml")
    assert s.solve().critical_load_factors  # buckles: a critical load factor
    s.problem.struct.settings.stagnation_lag = 0
    r = s.solve()
    assert not r.converged and "refused the problem as malformed" in r.reason
    assert r.critical_load_factors == [] and r.warnings == [] and r.points == {}


def test_solves_with_the_same_settings_reuse_one_prepared_solver():
    """flexgen.solve keeps one prepared solver per Scene object and settings value: options
    given by keyword (a new SolverSettings each call) do not fill the cache."""
    from flexgen import api

    scene = load_scene(EXAMPLES / "two_link_finger.toml")
    api._solvers.clear()  # other tests may have filled it to its capacity
    before = len(api._solvers)
    for _ in range(5):
        flexgen.solve(scene, tol=1e-10)
    flexgen.solve(scene)
    flexgen.solve(scene, settings=SolverSettings(tol=1e-10))
    assert len(api._solvers) - before == 2


@pytest.mark.parametrize("name", ["cantilever_tip_load", "two_link_finger", "steel_finger"])
def test_newton_last_step_linearized_against_evaluated(name):
    """Newton's last step taken unevaluated (settings.linearized_step, the default) against
    every step evaluated (linearized_step = 0): one evaluation fewer per Newton solve where it
    applies (the cantilever under a tip force: 7 against 8), and the same answer: q and poses
    to 1e-12, compliances to the linearization's order (the residual it starts from, at most
    30 tol, times the compliance's sensitivity: 1e-9 relative)."""
    path = Path(__file__).resolve().parents[1] / "examples" / f"{name}.toml"
    fast, full = flexgen.Solver(path), flexgen.Solver(path, linearized_step=0.0)
    a, b = fast.solve(), full.solve()
    assert a.converged and b.converged
    ea, eb = fast.workspace.answer.evaluations, full.workspace.answer.evaluations
    assert ea <= eb
    if name == "cantilever_tip_load":
        assert (ea, eb) == (7, 8)
    for n in a.q:
        np.testing.assert_allclose(a.q[n], b.q[n], rtol=0, atol=1e-12 * (1 + np.abs(b.q[n]).max()))
    for ref, pa in a.points.items():
        pb = b.points[ref]
        np.testing.assert_allclose(pa.pose, pb.pose, rtol=0, atol=1e-12)
        c = np.asarray(pb.compliance)
        np.testing.assert_allclose(pa.compliance, c, rtol=0, atol=1e-9 * np.abs(c).max())


def test_a_path_out_of_its_kernels_range_says_so_first_not_a_limit_point():
    """A pure end moment (no limit point: the arc bends uniformly) under kernel "poly" ends at
    90 degrees; its reason read "the load path ends there, a limit point" and named the kernel
    last (review)."""
    scene = {
        "model": {"kernel": "poly"},
        "flexure": [{"name": "a", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "a.tip", "force": [0.0, 0.0], "moment": 2.0}],
    }
    r = flexgen.solve(scene)
    assert not r.converged
    head = r.reason.split(":")[0]
    assert head.startswith("no equilibrium found beyond load factor 0.785")  # 90 deg of 2 rad
    assert "where flexure 'a'" in r.reason and "polynomial kernel scm3" in r.reason
    assert "limit point" not in r.reason


def test_a_rank_one_compliance_has_a_minor_axis_of_zero_not_minus_rounding():
    """prb (one coordinate) under an end moment: minor -1.08e-17, printed -0.000000 and a NaN
    semi-axis in the drawing (review). Zero within the compliance's rounding."""
    r = flexgen.solve(EXAMPLES / "arc_moment.toml", model="prb")
    for p in r.points.values():
        assert p.ellipse["minor"] == 0.0 and p.ellipse["major"] > 0.0
    # and +8.4e-20 under a force and a moment (a study's row showed it: review)
    beam = {
        "model": {"kind": "prb"},
        "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "beam.tip", "force": [0.0, -0.5], "moment": 0.5}],
    }
    assert flexgen.solve(beam).points["beam.tip"].ellipse["minor"] == 0.0


def test_no_loads_given_as_an_empty_list_for_a_scene_without_loads():
    """loads=[] on a scene with no [[load]] raised "expected (0, 3) numbers, got shape (0,)"
    (review): an empty list is the scene's zero loads."""
    s = flexgen.Solver({"flexure": [{"name": "a", "length": 1.0, "EI": 1.0}]})
    r = s.solve(loads=[], tensions=[])
    assert r.converged and r.points["a.tip"].pose == pytest.approx([1.0, 0.0, 0.0], abs=1e-14)
    with pytest.raises(ValueError, match="expected"):
        s.solve(loads=[[0.0, 1.0, 0.0]])


@pytest.mark.parametrize(
    "modes, kernel, force", [(4, "local", (0.0, -100.0)), (5, "auto", (-40.0, 0.01))]
)
def test_the_bend_is_the_largest_angle_not_the_largest_sample(modes, kernel, force):
    # review: where phi is not monotone the bend was the largest of 65 samples, up to 1.7e-4
    # rad short of the largest angle (an scm8 flexure bent past pi read below it, so no flag);
    # reference: phi of the answer's q on a grid of 200001 points, by NumPy's Legendre series
    from numpy.polynomial import legendre

    scene = flexgen.scene_from_dict(
        {
            "model": {"modes": modes, "kernel": kernel},
            "flexure": [{"name": "b", "length": 1.0, "EI": 1.0}],
            "load": [{"point": "b.tip", "force": list(force)}],
        }
    )
    r = flexgen.solve(scene)
    q = np.array(r.q["b"])
    s = np.linspace(0.0, 1.0, 200001)
    x = 2 * s - 1
    phi = q[0] * s
    for m in range(1, len(q)):
        up, down = legendre.legval(x, [0] * (m + 1) + [1]), legendre.legval(x, [0] * (m - 1) + [1])
        phi += q[m] * (up - down) / (2 * (2 * m + 1))
    largest = float(np.abs(phi).max())
    assert abs(phi[-1]) < largest - 1e-6  # not monotone: the largest angle is inside
    # the grid's own miss is at most phi'' (1 / 200000)^2 / 8, about 1e-10 here
    assert r.bend["b"] == pytest.approx(largest, abs=1e-9)


BEND_HARNESS = r"""
#include "chain_solver.c"
#include <stdio.h>
/* phi = c (2 s0 sigma - sigma^2): its largest value c s0^2 at sigma = s0 (scm8 coordinates:
 * q0 B_0 + q1 B_1, B_0 = sigma, B_1 = sigma^2 - sigma) */
static double bend_at(double s0)
{
    fg_flexure f;
    double scratch[64], c = 3.2 / (s0 * s0), q[8] = {0};
    memset(&f, 0, sizeof f);
    f.kind = FG_MODEL_KERNEL;
    f.ndof = 8;
    q[0] = c * (2 * s0 - 1);
    q[1] = -c;
    return flexure_bend(&f, q, 65, scratch);
}
int main(void)
{
    fg_flexure fl[2];
    fg_problem p;
    fg_ws w;
    double d[2] = {NAN, 0.001};
    memset(fl, 0, sizeof fl);
    memset(&p, 0, sizeof p);
    memset(&w, 0, sizeof w);
    fl[0].ndof = fl[1].ndof = 1;
    fl[1].offset = 1;
    p.nflex = p.ndof = 2;
    p.flex = fl;
    w.p = &p;
    printf("%.17g %.17g %.17g %d\n", bend_at(1.0 - 0.45 / 64), bend_at(0.5 + 0.5 / 64),
           bend_at(0.7), isnan(angle_change(&w, d)) ? 1 : 0);
    return 0;
}
"""


def test_the_bend_between_the_last_two_samples_and_a_nan_step_in_the_core(tmp_path):
    # review of the change: a largest angle between the last two of the 65 samples was still
    # read from the samples (1.6e-4 rad short: past pi unflagged); a NaN in one flexure's step
    # was replaced by a later flexure's finite change (angle_change)
    (tmp_path / "bend.c").write_text(BEND_HARNESS)
    exe = tmp_path / "bend"
    subprocess.run(
        ["gcc", "-std=c99", "-O2", f"-I{CORE}", f"-I{KERNELS}", str(tmp_path / "bend.c"), "-lm",
         "-o", str(exe)],
        check=True,
    )  # fmt: skip
    near_end, inside, middle, nan = subprocess.check_output([str(exe)], text=True).split()
    assert float(near_end) == pytest.approx(3.2, abs=1e-9)  # the closed form c s0^2
    assert float(inside) == pytest.approx(3.2, abs=1e-9)
    assert float(middle) == pytest.approx(3.2, abs=1e-9)
    assert nan == "1"
