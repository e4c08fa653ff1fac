"""The compiled chain solver (``flexgen.compiled``, ``solve(..., backend="c")``).

The reference is the Python solver (``backend="python"``, tested elsewhere against the exact
elastica): on the examples and the seeded random chains and trees of ``flexgen.bench`` (forces,
moments, tendons), for scm 1..6 (kernels auto, poly, gauss), prb and fem, the C backend must give
the same flags, iterations, equilibrium, poses, compliances and warnings, and must take the C path
exactly where the Python solver's direct full-load solve is accepted. The C answers are also
checked on their own: the Python residual at the C equilibrium, and the C compliance against
central differences of C solves. Then: the C path really runs without the Python solver; the
losses of stability it handles as the Python solver does (bifurcations crossed: Euler columns in
every orientation, loads far beyond the Euler load, an asymmetric bifurcation under a tendon;
snap-throughs), with the built-in and the LAPACK eigen-solver, and the capacity of its critical
arrays; the fallbacks (kernel switches, custom models, warm starts, a poly kernel bent past its
range); the backend argument; the C source (strict C99, no heap, no writable globals); the reuse
of a plan, its cache per scene, and LAPACK against the built-in factorizations.

Two regressions are guarded: a kernel with no C source falls back instead of raising, and a
model instance reused across solves does not carry a kernel-switch warning from an earlier solve.
"""
from __future__ import annotations

import math
import re
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import flexgen.compiled.library as clib
import flexgen.compiled.solver as csolver
import flexgen.equilibrium as eq
from flexgen import bench, kernels
from flexgen.chain import Chain
from flexgen.compiled.plan import build_plan
from flexgen.equilibrium import solve
from flexgen.models.base import TipKinematics
from flexgen.models.fem import FEMModel
from flexgen.models.prb import PRBModel
from flexgen.models.registry import build_models
from flexgen.models.scm import SCMModel
from flexgen.scene import Load, load_scene, scene_from_dict

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SOURCE = Path(clib.__file__).resolve().parent / "chain_solver.c"
N_RANDOM = 10                     # seeded random bench scenes (about 3 s to draw)
TOL = 1e-12                       # the solve's default relative residual


# -- model factories ------------------------------------------------------------------------------

def scm(modes: int, kernel: str = "auto"):
    return lambda f: SCMModel(f.length, f.EI, modes, kernel=kernel, name=f.name)


def prb():
    return lambda f: PRBModel(f.length, f.EI)


def fem(elements: int):
    return lambda f: FEMModel(f.length, f.EI, elements)


FACTORIES = {f"scm{m} {k}": scm(m, k) for m in range(1, 7) for k in ("auto", "poly", "gauss")}
FACTORIES.update({"prb": prb(), "fem4": fem(4), "fem16": fem(16), "fem64": fem(64)})


# -- scenes ---------------------------------------------------------------------------------------

def example(name: str):
    return load_scene(EXAMPLES / f"{name}.toml")


def cantilever(force=(0.0, 0.0), moment=0.0, L=1.0, EI=1.0, angle=0.0):
    return scene_from_dict({
        "name": "cantilever",
        "flexure": [{"name": "beam", "length": L, "EI": EI, "at": [0.0, 0.0, angle]}],
        "load": [{"point": "beam.tip", "force": list(force), "moment": moment}],
        "output": {"points": ["beam.tip"]}})


@pytest.fixture(scope="module")
def scenes():
    """The bench suite: the four examples and the seeded random chains and trees."""
    ex = bench.example_scenes()
    assert sorted(n for n, _ in ex) == ["arc_moment", "cantilever_tip_load",
                                       "rectangular_elastica", "two_link_finger"]
    rnd = bench.random_scenes(N_RANDOM)
    assert len(rnd) == N_RANDOM
    # the random suite covers what it should: chains, trees, moments, tendons
    assert any(len(s.flexures) >= 3 and is_tree(s) for _, s in rnd)
    assert any(s.tendons for _, s in rnd)
    assert any(ld.moment != 0.0 for _, s in rnd for ld in s.loads)
    return ex + rnd


def is_tree(scene) -> bool:
    parents = [f.parent for f in scene.flexures]
    return len(set(parents)) < len(parents)


def richest(scenes):
    """The random scene with the most going on: a tree, a tendon, moments, most flexures."""
    return max((s for n, s in scenes if n.startswith("random")),
               key=lambda s: (is_tree(s), bool(s.tendons),
                              any(ld.moment for ld in s.loads), len(s.flexures)))


def chain_with_tendon(scenes):
    """A random two-flexure chain with a tendon (else the richest scene)."""
    for n, s in scenes:
        if n.startswith("random") and len(s.flexures) == 2 and s.tendons:
            return s
    return richest(scenes)


PICK = {"richest": richest, "chain_with_tendon": chain_with_tendon}


def pick(scenes, name):
    return PICK[name](scenes) if name in PICK else dict(scenes)[name]


# -- spying on which path a solve took ------------------------------------------------------------

@pytest.fixture
def spy(monkeypatch):
    """Records, per solve, whether the compiled solver returned an answer ("compiled") and
    whether the Python solver's direct full-load solve was accepted ("direct")."""
    log = {"compiled": [], "direct": []}
    real_compiled, real_direct = csolver.solve_compiled, eq._direct_solve

    def compiled(*args, **kwargs):
        got = real_compiled(*args, **kwargs)
        log["compiled"].append(got[0] is not None)
        return got

    def direct(*args, **kwargs):
        got = real_direct(*args, **kwargs)
        log["direct"].append(got is not None)
        return got

    monkeypatch.setattr(csolver, "solve_compiled", compiled)
    monkeypatch.setattr(eq, "_direct_solve", direct)
    return log


def solve_both(scene, spy, **kwargs):
    """(python result, c result, python's direct solve accepted, c answered)."""
    spy["compiled"].clear(), spy["direct"].clear()
    rp = solve(scene, backend="python", **kwargs)
    assert spy["compiled"] == []
    direct = spy["direct"] == [True]
    spy["compiled"].clear(), spy["direct"].clear()
    rc = solve(scene, backend="c", **kwargs)
    assert len(spy["compiled"]) <= 1
    taken = spy["compiled"] == [True]
    if taken:
        assert spy["direct"] == []          # the Python solver did not run
    return rp, rc, direct, taken


# -- comparing results ----------------------------------------------------------------------------

def differences(scene, rp, rc) -> list[str]:
    """Every way the c result ``rc`` differs from the python result ``rp`` beyond rounding."""
    out = []
    for key in ("converged", "stable", "iterations", "warnings", "reason", "load_factor",
                "model"):
        if getattr(rp, key) != getattr(rc, key):
            out.append(f"{key}: python {getattr(rp, key)!r}, c {getattr(rc, key)!r}")
    # the critical load factors (bifurcations, snap-throughs): located by the same steps, to
    # rounding (the warnings above quote them to 10 digits, identically)
    cp, cc = rp.critical_load_factors, rc.critical_load_factors
    if len(cp) != len(cc) or not all(math.isclose(a, b, rel_tol=1e-9, abs_tol=0.0)
                                     for a, b in zip(cp, cc)):
        out.append(f"critical_load_factors: python {cp!r}, c {cc!r}")
    if rp.q.keys() != rc.q.keys():
        out.append(f"q flexures: python {sorted(rp.q)}, c {sorted(rc.q)}")
    else:
        for name in rp.q:
            a, b = np.asarray(rp.q[name]), np.asarray(rc.q[name])
            if a.shape != b.shape:
                out.append(f"q[{name}] shape {a.shape} vs {b.shape}")
                continue
            d = float(np.max(np.abs(a - b), initial=0.0))
            if not d <= 1e-9 * max(1.0, float(np.max(np.abs(a), initial=0.0))):
                out.append(f"q[{name}] differs by {d:.3g}")
    if rp.points.keys() != rc.points.keys():
        out.append(f"points: python {sorted(rp.points)}, c {sorted(rc.points)}")
        return out
    for ref in rp.points:
        pp, pc = rp.points[ref], rc.points[ref]
        L = bench.path_length(scene, ref)
        dpos = float(np.max(np.abs(np.subtract(pp.pose[:2], pc.pose[:2]))))
        dang = abs(pp.pose[2] - pc.pose[2])
        if not (dpos <= 1e-9 * L and dang <= 1e-9):
            out.append(f"pose of {ref}: position differs by {dpos:.3g} (L = {L:.3g}), "
                       f"angle by {dang:.3g}")
        Cp, Cc = np.asarray(pp.compliance3), np.asarray(pc.compliance3)
        if not np.array_equal(np.isfinite(Cp), np.isfinite(Cc)):
            out.append(f"compliance3 of {ref}: finite entries differ")
        elif np.all(np.isfinite(Cp)):
            rel = np.linalg.norm(Cp - Cc, 2) / np.linalg.norm(Cp, 2)
            if not rel <= 1e-7:
                out.append(f"compliance3 of {ref}: relative difference {rel:.3g}")
            if not np.allclose(pc.compliance, Cc[:2, :2], rtol=0, atol=0):
                out.append(f"compliance of {ref} is not the position block of compliance3")
    if rp.converged and not math.isclose(rp.energy, rc.energy, rel_tol=1e-8, abs_tol=1e-300):
        out.append(f"energy: python {rp.energy!r}, c {rc.energy!r}")
    if rc.converged and not rc.residual <= TOL:
        out.append(f"c residual {rc.residual!r} > tol")
    return out


def python_residual(scene, factory, result) -> float:
    """The relative residual the Python System gives at the result's equilibrium (full load)."""
    models = build_models(scene, None, factory)
    chain = Chain(scene, models)
    q = chain.pack(result.q)
    return eq.System(chain).state(q, 1.0).rel


# -- 1. agreement on the bench suite --------------------------------------------------------------

def _cases(label: str, scenes):
    if label == "fem64":        # slow in Python on trees: the examples and chains of <= 2 flexures
        return [(n, s) for n, s in scenes if len(s.flexures) <= 2]
    return scenes


@pytest.mark.parametrize("label", list(FACTORIES))
def test_c_backend_agrees_with_python(label, scenes, spy):
    factory = FACTORIES[label]
    cases = _cases(label, scenes)
    problems, taken_count = [], 0
    for name, scene in cases:
        rp, rc, direct, taken = solve_both(scene, spy, model_factory=factory)
        problems += [f"{name}: {p}" for p in differences(scene, rp, rc)]
        # the C solver answers every solve the Python solver converges on (bifurcations,
        # snap-throughs and kernel switches included, with the same warnings)
        if direct and not taken:
            problems.append(f"{name}: python direct solve accepted, c handed it back")
        if rp.converged and not taken:
            problems.append(f"{name}: c handed back a converged solve")
        if taken:
            taken_count += 1
            assert rc.converged and rc.stable
            rel = python_residual(scene, factory, rc)
            if not rel <= TOL:
                problems.append(f"{name}: python residual at the c equilibrium {rel:.3g}")
    assert not problems, "\n".join(problems)
    # not vacuous: most of the suite runs in C (the exceptions buckle, switch kernels, ...)
    assert taken_count >= len(cases) // 2, f"the C path answered {taken_count} of {len(cases)}"


def test_c_continuation_answers_where_the_direct_attempt_is_rejected(scenes, spy):
    """Some suite scenes need the load continuation (the direct attempt is rejected in Python);
    the C solver runs it too and gives Python's answer, iterations included."""
    continued = 0
    for name, scene in scenes:
        rp, rc, direct, taken = solve_both(scene, spy, model_factory=scm(3))
        if taken and not direct:
            continued += 1
            assert differences(scene, rp, rc) == [], name
            assert rc.iterations == rp.iterations
    assert continued >= 1


def test_suite_exercises_the_c_path_on_trees_with_tendons_and_moments(scenes, spy):
    """The scenes the C path answers include trees, tendons and moments (scm3 and fem16)."""
    for factory in (scm(3), fem(16)):
        seen = set()
        for _, scene in scenes:
            spy["compiled"].clear()
            solve(scene, model_factory=factory, backend="c")
            if spy["compiled"] == [True]:
                if is_tree(scene):
                    seen.add("tree")
                if scene.tendons:
                    seen.add("tendon")
                if any(ld.moment for ld in scene.loads):
                    seen.add("moment")
                if len(scene.flexures) >= 2:
                    seen.add("chain")
        assert seen == {"tree", "tendon", "moment", "chain"}


@pytest.mark.parametrize("name, factory", [
    ("cantilever_tip_load", scm(3)),
    ("two_link_finger", scm(4)),
    ("richest", fem(16)),              # a 4-flexure tree with a tendon and moments
    ("chain_with_tendon", prb()),
])
def test_c_compliance_matches_finite_differences(name, factory, scenes, spy):
    """compliance3 = d(pose)/d(fx, fy, m) at each output point: central differences of C solves
    under a small extra load at the point (an independent check of the C answer)."""
    scene = pick(scenes, name)
    f0 = scene.flexures[0]
    fscale, mscale = f0.EI / f0.length ** 2, f0.EI / f0.length
    spy["compiled"].clear()
    base = solve(scene, model_factory=factory, backend="c")
    assert spy["compiled"] == [True]
    for ref in base.points:
        C = np.asarray(base.points[ref].compliance3)
        fd = np.zeros((3, 3))
        for j, (unit, h) in enumerate((((1, 0, 0), 1e-5 * fscale), ((0, 1, 0), 1e-5 * fscale),
                                        ((0, 0, 1), 1e-5 * mscale))):
            poses = []
            for sign in (1.0, -1.0):
                extra = Load(ref, (sign * h * unit[0], sign * h * unit[1]), sign * h * unit[2])
                sc = replace(scene, loads=tuple(scene.loads) + (extra,))
                spy["compiled"].clear()
                r = solve(sc, model_factory=factory, backend="c")
                assert spy["compiled"] == [True]
                poses.append(np.asarray(r.points[ref].pose))
            fd[:, j] = (poses[0] - poses[1]) / (2 * h)
        rel = np.linalg.norm(C - fd, 2) / np.linalg.norm(C, 2)
        assert rel <= 1e-6, (ref, rel, C, fd)


# -- 2. the C path really runs without the Python solver -----------------------------------------

def test_cantilever_is_solved_without_the_python_solver(monkeypatch):
    scene = example("cantilever_tip_load")
    reference = solve(scene, model_factory=scm(3))

    def forbidden(*args, **kwargs):
        raise AssertionError("the Python solver ran")

    monkeypatch.setattr(eq, "_Solver", forbidden)
    monkeypatch.setattr(eq, "_direct_solve", forbidden)
    with pytest.raises(AssertionError, match="Python solver ran"):
        solve(scene, model_factory=scm(3))          # the patch does catch the Python path
    got = solve(scene, model_factory=scm(3), backend="c")
    assert got.converged and got.stable and got.iterations > 0
    assert differences(scene, reference, got) == []
    # and against Bisshopp & Drucker (alpha = 2): x/L = 0.83936, y/L = -0.49346, angle 0.78175
    x, y, th = got.points["beam.tip"].pose
    assert abs(x - 0.83936) < 2e-4 and abs(y + 0.49346) < 2e-4 and abs(th + 0.78175) < 2e-4


def _plan_for(scene, factory, tol=TOL, max_dq=0.5, max_iterations=50):
    models = build_models(scene, None, factory)
    chain = Chain(scene, models)
    system = eq.System(chain)
    outputs = eq._output_points(scene, chain)
    return chain, build_plan(chain, system.loads, system.tendons, outputs, tol=tol,
                             max_dq=max_dq, max_iterations=max_iterations)


# -- 2b. stability along the path, in C: bifurcations crossed, snap-throughs ----------------------

EULER = math.pi ** 2 / 4          # the first Euler load of a cantilever, EI = L = 1
ELASTICA = 3.4375929              # the load of examples/rectangular_elastica.toml
SNAP = dict(force=(-1.74574099, -4.67920763), moment=3.478735754260268)   # a fold near 0.5457
WHY = dict(zip(("only", "lower", "y", "ccw"), eq.BUCKLING_SIDES))
# the models whose kernels never switch on these paths ("auto" passes the polynomial range of
# 90 degrees in the post-buckled elastica: a kernel switch, handed back), and the n-element chain
STABILITY_FACTORIES = {"scm3 gauss": scm(3, "gauss"), "scm5 gauss": scm(5, "gauss"),
                       "fem16": fem(16)}


def column(P: float, angle: float):
    """A cantilever along ``angle`` under the axial compressive tip load P."""
    return cantilever(force=(-P * math.cos(angle), -P * math.sin(angle)), angle=angle)


def tendon_column(T: float, ry: float):
    """A tendon from base point (0, ry) to the tip of a flexure along x, and the dead tip load
    that cancels its transverse pull: the straight state stays an equilibrium, but the tendon
    turns with the tip and a dead load does not, so the bifurcation is not a symmetric one (the
    sides differ in potential energy)."""
    return scene_from_dict({
        "name": "tendon column", "flexure": [{"name": "a", "length": 1.0, "EI": 1.0}],
        "base": {"points": {"r0": [0.0, ry]}},
        "tendon": [{"tension": T, "route": ["base.r0", "a.tip"]}],
        "load": [{"point": "a.tip", "force": [0.0, -T * ry / math.hypot(1.0, ry)],
                  "moment": 0.0}],
        "output": {"points": ["a.tip"]}})


def assert_answered_in_c(scene, spy, factory):
    """Both backends; the C solver answered (the Python solver never ran) with Python's answer:
    q, poses, compliances, iterations, identical warnings, critical load factors to 1e-9."""
    rp, rc, direct, taken = solve_both(scene, spy, model_factory=factory)
    assert rp.converged and rp.stable
    assert not direct and taken and rc.solver == "c"
    assert differences(scene, rp, rc) == []
    assert rc.iterations == rp.iterations and rc.warnings == rp.warnings
    return rp, rc


def buckling_sides(result) -> list[str]:
    """The why of each bifurcation warning, or "snap" for a snap-through."""
    out = []
    for w in result.warnings:
        if w.startswith("snap-through"):
            out.append("snap")
        elif w.startswith("buckling"):
            out.append(next(k for k, why in WHY.items() if w.endswith(f"({why})")))
    return out


@pytest.mark.parametrize("label", list(STABILITY_FACTORIES))
def test_rectangular_elastica_buckles_in_c(label, spy):
    scene = example("rectangular_elastica")
    rp, rc = assert_answered_in_c(scene, spy, STABILITY_FACTORIES[label])
    assert len(rc.critical_load_factors) == 1
    # Euler: P_cr = pi^2 EI / (4 L^2) of the applied load (these models: within 2e-3)
    assert abs(rc.critical_load_factors[0] / (EULER / ELASTICA) - 1.0) < 2e-3
    assert buckling_sides(rc) == ["y"]
    assert rc.warnings == [eq.buckling_warning(rp.critical_load_factors[0], WHY["y"])]
    x, y, th = rc.points["beam.tip"].pose          # the exact elastica: 0.456947, 0.762760, 90 deg
    assert abs(x - 0.456947) < 2e-3 and abs(y - 0.762760) < 2e-3 and abs(th - math.pi / 2) < 1e-2


@pytest.mark.parametrize("modes", [3, 5])
def test_rectangular_elastica_with_the_auto_kernel_switches_in_c(modes, spy):
    """The scene's own model (scm "auto") passes the polynomial kernel's range on the way: the C
    solver reports the switch per flexure and the Result carries the Python solver's warning;
    a C caller that takes no switch flags (answer.switched NULL) gets the same answer."""
    scene = example("rectangular_elastica")
    _, plan = _plan_for(scene, scm(modes))
    assert plan is not None and plan.run() == clib.SOLVED and plan.switched.tolist() == [1]
    q = plan.q.copy()
    plan.answer.switched = None
    assert plan.run() == clib.SOLVED and np.array_equal(plan.q, q)
    rp, rc, direct, taken = solve_both(scene, spy, model_factory=scm(modes))
    assert not direct and taken and rc.solver == "c"
    assert differences(scene, rp, rc) == []
    assert any("switched to the Gauss kernel" in w for w in rc.warnings)
    assert len(rc.critical_load_factors) == 1


@pytest.mark.parametrize("label", list(STABILITY_FACTORIES))
@pytest.mark.parametrize("angle, side", [
    (0.0, "y"), (0.3, "y"), (2.0, "y"), (math.pi, "y"),      # buckles to larger world y
    (math.pi / 2, "ccw"), (-math.pi / 2, "ccw"),             # y the same: counter-clockwise
])
def test_euler_column_breaks_symmetry_the_same_way(label, angle, side, spy):
    """A cantilever turned by ``angle`` under an axial load beyond its first Euler load: the
    straight state loses stability at a symmetric pitchfork; both solvers find the same critical
    load and take the same side, whichever sign the eigen-solvers give the lost mode."""
    scene = column(ELASTICA, angle)
    rp, rc = assert_answered_in_c(scene, spy, STABILITY_FACTORIES[label])
    assert buckling_sides(rc) == [side]
    assert abs(rc.critical_load_factors[0] / (EULER / ELASTICA) - 1.0) < 2e-3
    # the side taken: the tip moved up (larger world y) or turned counter-clockwise
    x, y, th = rc.points["beam.tip"].pose
    if side == "y":
        assert y > 0.5 * math.cos(angle) ** 2
    else:
        assert th > angle


@pytest.mark.parametrize("label", list(STABILITY_FACTORIES))
@pytest.mark.parametrize("P", [12.0, 25.0, 40.0])
def test_loads_far_beyond_the_euler_load(label, P, spy):
    """Up to 16 Euler loads: a bifurcation, for some models a second one on the post-buckled
    branch, all answered in C as in Python."""
    scene = column(P, 0.0)
    rp, rc = assert_answered_in_c(scene, spy, STABILITY_FACTORIES[label])
    assert buckling_sides(rc)[0] == "y"
    assert abs(rc.critical_load_factors[0] / (EULER / P) - 1.0) < 2e-3


@pytest.mark.parametrize("label", ["scm3 gauss", "scm5 gauss", "scm6 gauss"])
def test_snap_through_in_c(label, spy):
    """A tip force and moment whose proportional path has a fold near load factor 0.5457
    (tests/test_reference_models.py): the path ends, the solve descends to the equilibrium it
    snaps to, records the load factor and goes on, in C as in Python."""
    scene = cantilever(**SNAP)
    rp, rc = assert_answered_in_c(scene, spy, FACTORIES[label])
    assert buckling_sides(rc) == ["snap"]
    assert 0.54 < rc.critical_load_factors[0] < 0.55
    assert rc.warnings == [eq.snap_warning(rp.critical_load_factors[0])]


@pytest.mark.parametrize("label, T, ry, sides", [
    ("prb", 8.0, 1.5, ["lower"]), ("fem4", 8.0, 1.5, ["lower"]), ("fem16", 8.0, 1.5, None),
    ("prb", 20.0, -3.0, ["lower"]), ("fem4", 20.0, 0.5, ["only"]), ("fem16", 20.0, 0.5, None),
    ("scm5 gauss", 20.0, 1.5, None),
])
def test_asymmetric_bifurcation_under_a_tendon(label, T, ry, sides, spy):
    """A bifurcation whose sides differ in potential energy (the lower one is taken), or where
    one side's descent finds no stable state (the only stable side is taken)."""
    scene = tendon_column(T, ry)
    factory = FACTORIES[label] if label in FACTORIES else STABILITY_FACTORIES[label]
    rp, rc = assert_answered_in_c(scene, spy, factory)
    assert len(rc.critical_load_factors) >= 1
    if sides is not None:
        assert buckling_sides(rc) == sides


def _c_result(scene, factory, min_size: int):
    """The plan's own answer (no Python solver behind it) with LAPACK from ``min_size``
    coordinates on (10**9: the built-in factorizations and Jacobi eigen-solver throughout)."""
    models = build_models(scene, None, factory)
    chain, system, outputs, info = eq.prepare_system(scene, models)
    plan = build_plan(chain, system.loads, system.tendons, outputs)
    plan.problem.settings.lapack_min_size = min_size
    status = plan.run()
    if status != clib.SOLVED:
        return plan, status, None
    return plan, status, csolver.result_of(plan, scene.name, chain.slices, info)


@pytest.mark.parametrize("eigen", ["builtin", "lapack"])
@pytest.mark.parametrize("name, label", [
    ("rectangular_elastica", "scm3 gauss"), ("rectangular_elastica", "scm5 gauss"),
    ("rectangular_elastica", "fem16"), ("column vertical", "fem16"),
    ("column 25", "scm5 gauss"), ("column 25", "fem4"), ("snap", "scm5 gauss"),
    ("tendon lower", "fem4"), ("tendon only", "fem4"),
])
def test_builtin_and_lapack_eigen_solvers_give_python_answer(eigen, name, label):
    """The Jacobi method (min_size 10**9) and LAPACK's dsyev (min_size 1: every factorization
    and eigen-decomposition by LAPACK) both give the Python solver's answer."""
    scene = {"rectangular_elastica": lambda: example("rectangular_elastica"),
             "column vertical": lambda: column(ELASTICA, math.pi / 2),
             "column 25": lambda: column(25.0, 0.0),
             "snap": lambda: cantilever(**SNAP),
             "tendon lower": lambda: tendon_column(8.0, 1.5),
             "tendon only": lambda: tendon_column(20.0, 0.5)}[name]()
    factory = {**FACTORIES, **STABILITY_FACTORIES}[label]
    if eigen == "lapack" and not clib.lapack().syev:
        pytest.skip("SciPy's LAPACK routines are not available")
    plan, status, rc = _c_result(scene, factory, 10 ** 9 if eigen == "builtin" else 1)
    assert status == clib.SOLVED
    rp = solve(scene, model_factory=factory)
    assert rp.critical_load_factors
    assert differences(scene, rp, rc) == []
    assert rc.iterations == rp.iterations and rc.warnings == rp.warnings


def test_critical_events_beyond_the_capacity_are_counted_not_stored(spy):
    """The caller gives the capacity of the critical arrays: the solve goes on past it, counts
    every event (ncritical) and stores the first max_critical."""
    scene = column(25.0, 0.0)
    _, plan = _plan_for(scene, scm(3, "gauss"))
    assert plan.run() == clib.SOLVED and plan.answer.ncritical == 2     # two bifurcations
    side = eq.BUCKLING_SIDES.index(WHY["y"]) + 1
    assert plan.critical_kind[:2].tolist() == [side, side]
    first, q = plan.critical[:2].copy(), plan.q.copy()
    plan.critical[:] = -1.0
    plan.answer.max_critical = 1
    assert plan.run() == clib.SOLVED and plan.answer.ncritical == 2
    assert plan.critical[0] == first[0] and plan.critical[1] == -1.0
    assert np.array_equal(plan.q, q)
    plan.answer.max_critical = 0
    assert plan.run() == clib.SOLVED and plan.answer.ncritical == 2
    plan.answer.max_critical = 2
    assert plan.run() == clib.SOLVED and np.array_equal(plan.critical[:2], first)
    _, snap = _plan_for(cantilever(**SNAP), scm(5, "gauss"))
    assert snap.run() == clib.SOLVED and snap.answer.ncritical == 1
    assert snap.critical_kind[0] == clib.SNAP_THROUGH
    # a caller without critical arrays (NULL, capacity 0: as a zeroed fg_answer) gets the
    # same answers, the events counted
    plan.answer.critical = None
    assert plan.run() == clib.SOLVED and plan.answer.ncritical == 2
    assert np.array_equal(plan.q, q)
    _, calm = _plan_for(example("cantilever_tip_load"), scm(3))
    calm.answer.critical, calm.answer.max_critical = None, 0
    assert calm.run() == clib.SOLVED


# -- 3. fallbacks ---------------------------------------------------------------------------------

class CustomSCM(SCMModel):
    """A user's subclass: the same mathematics, but not a class the C solver knows."""


class Wrapped:
    """A FlexureModel by delegation (the protocol only)."""

    def __init__(self, inner):
        self.inner = inner
        self.kind, self.label, self.n_dof = "scm", "wrapped " + inner.label, inner.n_dof
        self.length, self.EI = inner.length, inner.EI

    def tip(self, q) -> TipKinematics:
        return self.inner.tip(q)

    def energy(self, q):
        return self.inner.energy(q)

    def energy_gradient(self, q):
        return self.inner.energy_gradient(q)

    def energy_hessian(self, q):
        return self.inner.energy_hessian(q)

    def shape(self, q, num=64):
        return self.inner.shape(q, num)


@pytest.mark.parametrize("make", [
    lambda f: CustomSCM(f.length, f.EI, 3, name=f.name),
    lambda f: Wrapped(SCMModel(f.length, f.EI, 3, kernel="gauss", name=f.name)),
], ids=["subclass", "wrapper"])
@pytest.mark.parametrize("name", ["cantilever_tip_load", "two_link_finger"])
def test_custom_model_has_no_plan_and_falls_back(make, name, spy):
    scene = example(name)
    _, plan = _plan_for(scene, make)
    assert plan is None
    rp, rc, direct, taken = solve_both(scene, spy, model_factory=make)
    assert direct and not taken and spy["direct"] == [True]          # the Python solver ran
    assert differences(scene, rp, rc) == []


def test_one_custom_flexure_among_known_ones_falls_back(spy):
    scene = example("two_link_finger")
    models = {"distal": Wrapped(SCMModel(0.015, scene.flexure("distal").EI, 3, kernel="gauss",
                                         name="distal"))}
    rp, rc, _, taken = solve_both(scene, spy, models=models)
    assert not taken and spy["direct"] == [True]
    assert differences(scene, rp, rc) == []
    # the wrapper is the gauss model itself: the same answer as the C solve of plain scm3 gauss
    mixed = {"distal": SCMModel(0.015, scene.flexure("distal").EI, 3, kernel="gauss",
                                name="distal")}
    spy["compiled"].clear()
    plain = solve(scene, models=mixed, backend="c")
    assert spy["compiled"] == [True]
    for p in plain.points:
        assert np.allclose(plain.points[p].pose, rc.points[p].pose, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name, warm_factory, factory", [
    ("cantilever_tip_load", scm(3), scm(5)),       # q0 padded with zeros
    ("two_link_finger", scm(4), scm(3)),           # q0 truncated
    ("richest", scm(3), scm(3, "gauss")),
    ("chain_with_tendon", fem(4), fem(4)),
])
def test_warm_start_matches_python(name, warm_factory, factory, scenes, spy):
    scene = pick(scenes, name)
    q0 = solve(scene, model_factory=warm_factory).q
    rp, rc, _, _ = solve_both(scene, spy, model_factory=factory, q0=q0)
    assert rc.converged
    assert differences(scene, rp, rc) == []
    cold = solve(scene, model_factory=factory, backend="c")
    for p in cold.points:
        assert np.allclose(cold.points[p].pose, rc.points[p].pose, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name, q0", [
    ("cantilever_tip_load", {"beam": [3.0, -1.0, 0.5]}),      # far off: Newton leaves max_dq
    ("two_link_finger", {}),                                 # all zeros: Newton at the full load
    ("rectangular_elastica", {}),                            # zeros: the unstable straight state
    ("rectangular_elastica", {"beam": [1.5]}),               # near the post-buckled branch
])
def test_poor_warm_starts_match_python(name, q0, spy):
    scene = example(name)
    rp, rc, _, _ = solve_both(scene, spy, model_factory=scm(3), q0=q0)
    assert differences(scene, rp, rc) == []


def test_poly_kernel_past_its_range_fails_the_same_way(spy):
    """A tip moment that would bend scm3 (poly only: |phi| <= 90 deg) to 150 degrees."""
    scene = cantilever(moment=math.radians(150.0))
    _, plan = _plan_for(scene, scm(3, "poly"))
    assert plan is not None and plan.run() == clib.NO_EQUILIBRIUM
    assert plan.answer.model_error == clib.ERR_KERNEL_RANGE
    assert plan.answer.model_error_flexure == 0
    rp, rc, direct, taken = solve_both(scene, spy, model_factory=scm(3, "poly"))
    assert not direct and not taken
    assert rc.converged is False and rp.converged is False
    assert rc.reason == rp.reason and "bent past the range of the polynomial kernel" in rc.reason
    assert differences(scene, rp, rc) == []
    # "auto" switches to the Gauss kernel there: the same answer in both, with its warning
    rp, rc, _, _ = solve_both(scene, spy, model_factory=scm(3, "auto"))
    assert rc.converged and differences(scene, rp, rc) == []
    assert any("switched to the Gauss kernel" in w for w in rc.warnings)
    assert abs(rc.points["beam.tip"].pose[2] - math.radians(150.0)) < 1e-9   # a pure moment


@pytest.mark.parametrize("degrees", [150.0, 200.0, 300.0])
def test_gauss_kernel_past_its_certified_range_matches_python(degrees, spy):
    """kernel="gauss" is certified for |phi| <= 180 degrees (SCMModel.in_range): the direct
    solve must reject a path beyond it as _direct_solve does; the continuation then runs, in C
    too (a Gauss-only flexure switches no kernel), with Python's iterations."""
    scene = cantilever(moment=math.radians(degrees))
    rp, rc, direct, taken = solve_both(scene, spy, model_factory=scm(3, "gauss"))
    assert direct == (degrees < 180.0)
    assert taken      # past 180 degrees by the continuation, in C as in Python
    assert differences(scene, rp, rc) == []
    _, plan = _plan_for(scene, scm(3, "gauss"))
    assert plan.run() == clib.SOLVED
    assert abs(rc.points["beam.tip"].pose[2] - math.radians(degrees)) < 1e-9


def test_missing_c_kernel_falls_back(monkeypatch, spy):
    def missing(name, folder=kernels.GENERATED):
        raise kernels.KernelNotFound(f"C kernel {name!r} not found in {folder}/c")

    monkeypatch.setattr(clib, "kernel_functions", missing)
    scene = example("cantilever_tip_load")
    rp, rc, _, taken = solve_both(scene, spy, model_factory=scm(3))
    assert not taken and rc.solver == "python"
    # the same answer, and a warning that the compiled solver was unavailable, naming why
    note = [w for w in rc.warnings if w not in rp.warnings]
    assert len(note) == 1 and "backend 'c' is unavailable" in note[0] and "scm3" in note[0]
    rc.warnings = rp.warnings
    assert differences(scene, rp, rc) == []


def test_solver_field_and_table_say_which_solver_answered():
    scene = example("cantilever_tip_load")
    rc = solve(scene, backend="c", model_factory=scm(3))
    rp = solve(scene, model_factory=scm(3))
    assert rc.solver == "c" and rp.solver == "python"
    assert "(compiled solver)" in rc.table() and "(compiled solver)" not in rp.table()
    assert "solver" not in rc.contract()          # not part of the JSON contract
    failed = solve(cantilever(moment=math.radians(150.0)), backend="c",
                   model_factory=scm(3, "poly"))
    assert failed.solver == "python" and not failed.converged     # handed back: no equilibrium
    switched = solve(example("rectangular_elastica"), backend="c", model_factory=scm(3))
    assert switched.solver == "c"                 # the "auto" kernel switched, in C
    buckled = solve(example("rectangular_elastica"), backend="c", model_factory=scm(3, "gauss"))
    assert buckled.solver == "c" and buckled.critical_load_factors      # crossed in C


def test_plan_cache_tells_models_and_settings_apart(spy):
    """solve(backend="c") keeps a plan per scene: every model parameter and solver setting that
    changes the answer must give its own (one scene object, solved in turns)."""
    scene = cantilever(moment=math.radians(150.0))
    variants = [
        dict(model_factory=scm(3, "gauss")),          # converges (C)
        dict(model_factory=scm(3, "poly")),           # fails: past the polynomial range
        dict(model_factory=scm(3, "auto")),           # switches kernels (Python)
        dict(model_factory=scm(4, "gauss")),
        dict(model_factory=prb()),
        dict(model_factory=lambda f: PRBModel(f.length, f.EI, gamma=0.7)),
        dict(model_factory=lambda f: PRBModel(f.length, f.EI, K_theta=2.0)),
        dict(model_factory=fem(8)),
        dict(models={"beam": SCMModel(1.0, 2.0, 3, kernel="gauss", name="beam")}),
        dict(model_factory=scm(3, "gauss"), tol=1e-6),
        dict(model_factory=scm(3, "gauss"), max_iterations=1),
        dict(model_factory=fem(8), max_dq=1e-3),
    ]
    for _ in range(2):
        for kwargs in variants:
            rp, rc, _, _ = solve_both(scene, spy, **kwargs)
            assert differences(scene, rp, rc) == [], kwargs


def test_lapack_and_builtin_factorizations_agree(scenes):
    """From LAPACK_MIN_SIZE coordinates on the plan calls SciPy's LAPACK; the built-in
    factorizations must give the same answer (fem16 on a 4-flexure tree: 64 coordinates)."""
    scene = richest(scenes)
    _, plan = _plan_for(scene, fem(16))
    if not plan.problem.lapack.potrf:
        pytest.skip("SciPy's LAPACK routines are not available")
    assert plan.q.size >= max(16, plan.problem.settings.lapack_min_size)
    assert plan.run() == clib.SOLVED
    lapack = (plan.q.copy(), plan.pose.copy(), plan.compliance.copy(), plan.answer.iterations)
    plan.problem.settings.lapack_min_size = 10 ** 9
    assert plan.run() == clib.SOLVED
    builtin = (plan.q.copy(), plan.pose.copy(), plan.compliance.copy(), plan.answer.iterations)
    assert lapack[3] == builtin[3]
    assert np.allclose(lapack[0], builtin[0], rtol=0, atol=1e-11)
    assert np.allclose(lapack[1], builtin[1], rtol=0, atol=1e-11)
    assert np.linalg.norm((lapack[2] - builtin[2]).ravel()) <= 1e-9 * np.linalg.norm(lapack[2])


def test_reused_model_gives_the_same_warnings(spy):
    results = {}
    for backend in ("python", "c"):
        model = SCMModel(1.0, 1.0, 3, name="beam")          # "auto": switches past 90 degrees
        solve(cantilever(moment=math.radians(150.0)), models={"beam": model}, backend=backend)
        assert model.switched is True
        results[backend] = solve(cantilever(moment=math.radians(30.0)), models={"beam": model},
                                 backend=backend)
    assert results["python"].warnings == results["c"].warnings


# -- 4. the backend argument ----------------------------------------------------------------------

@pytest.mark.parametrize("backend", ["fortran", "C", ""])
def test_unknown_backend_raises(backend):
    with pytest.raises(ValueError, match="backend"):
        solve(example("cantilever_tip_load"), model_factory=scm(3), backend=backend)


# -- 5. the C source ------------------------------------------------------------------------------

def _strip_comments(text: str) -> str:
    return re.sub(r"/\*.*?\*/|//[^\n]*", " ", text, flags=re.S)


@pytest.mark.parametrize("opt", ["-O0", "-O2"])
def test_c_source_compiles_strictly_without_writable_globals(opt, tmp_path):
    if shutil.which("gcc") is None:
        pytest.skip("gcc is not available")
    obj = tmp_path / "chain_solver.o"
    proc = subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", opt,
                           f"-I{SOURCE.parent}", "-c", str(SOURCE), "-o", str(obj)],
                          capture_output=True, text=True)
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


# -- 6. a plan is reusable ------------------------------------------------------------------------

@pytest.mark.parametrize("name, factory", [
    ("two_link_finger", scm(3)),
    ("richest", scm(3)),
    ("richest", fem(16)),
    ("arc_moment", prb()),
])
def test_plan_runs_twice_identically(name, factory, scenes):
    scene = pick(scenes, name)
    chain, plan = _plan_for(scene, factory)
    assert plan is not None
    assert plan.run() == clib.SOLVED

    def answer():
        a = plan.answer
        return (plan.q.copy(), plan.pose.copy(), plan.compliance.copy(),
                a.energy, a.residual, a.iterations, a.stable)

    first = answer()
    assert plan.run() == clib.SOLVED
    second = answer()
    # the workspace carries nothing from one run to the next: garbage in it changes nothing
    plan.work[:] = np.nan
    plan.iwork[:] = -7
    plan.q[:] = np.inf
    assert plan.run() == clib.SOLVED
    third = answer()
    # nor does another plan's solve in between (no global state)
    _, other = _plan_for(example("cantilever_tip_load"), scm(4))
    assert other.run() == clib.SOLVED
    assert plan.run() == clib.SOLVED
    fourth = answer()
    for got in (second, third, fourth):
        for x, y in zip(first[:3], got[:3]):
            assert np.array_equal(x, y)
        assert first[3:] == got[3:]
    # and it is the Python solver's answer
    ref = solve(scene, model_factory=factory)
    assert np.allclose(chain.pack(ref.q), first[0], rtol=0, atol=1e-9)
    assert first[5] == ref.iterations


def test_validity_check_reuses_the_compiled_stiffness():
    """flexgen.solve runs the validity check on every answer; from a compiled answer it reuses the
    C solver's final stiffness (Result._final), which must be the one the Python System gives at
    that equilibrium, and the API's answers (validity warnings included) match the Python ones."""
    from flexgen import validity
    from flexgen.api import solve as api_solve
    scene = example("two_link_finger")
    rc = solve(scene, backend="c")
    assert rc.solver == "c"
    models = build_models(scene, None, None)
    assert validity._reusable_state(scene, models, rc.q, rc._final) is not None
    chain = Chain(scene, models)
    K = eq.System(chain).state(chain.pack(rc.q), 1.0).K
    np.testing.assert_allclose(rc._final[2].K, K, rtol=1e-10, atol=1e-12 * np.abs(K).max())
    reused = validity.stiffness_margin(scene, models, rc.q, rc._final)
    fresh = validity.stiffness_margin(scene, models, rc.q, None)
    assert reused == pytest.approx(fresh, rel=1e-9) and 0 < reused < 1
    for name in ("two_link_finger", "cantilever_tip_load", "arc_moment"):
        a, b = api_solve(example(name)), api_solve(example(name), backend="c")
        assert b.solver == "c" and a.warnings == b.warnings
        assert a.error_class.keys() == b.error_class.keys()
        for k in a.error_class:
            assert b.error_class[k] == pytest.approx(a.error_class[k], rel=1e-9), k


def test_cache_dir_falls_back_to_the_temp_dir(monkeypatch, tmp_path):
    """$FLEXGEN_CACHE wins; without it ~/.cache/flexgen; with no usable home a temp folder."""
    monkeypatch.setenv("FLEXGEN_CACHE", str(tmp_path / "c"))
    assert clib.cache_dir() == tmp_path / "c"
    monkeypatch.delenv("FLEXGEN_CACHE")
    monkeypatch.setattr(Path, "home", staticmethod(lambda: tmp_path / "h"))
    assert clib.cache_dir() == tmp_path / "h" / ".cache" / "flexgen"
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setattr(Path, "home", staticmethod(lambda: blocker))
    got = clib.cache_dir()
    assert got.parent == Path(__import__("tempfile").gettempdir()) and "flexgen" in got.name


# -- 4. no equilibrium: the C answer carries the Python solver's reason ---------------------------

def c_reason(plan, models, tendons, max_dq) -> str:
    """equilibrium.solve's reason string, written from the C answer's failure, last error and
    model error fields alone (what the Python glue of the C-only solver will do)."""
    a = plan.answer
    route = [ref for _, r in tendons for ref in r]     # fg_problem.route's entries

    def model_message(code, flexure, entry):
        if code == clib.ERR_KERNEL_RANGE:
            m = models[plan.flexure_order[flexure]]
            with pytest.raises(ValueError) as exc:       # its message names no q
                m.kernel_at(np.full(m.n_dof, 1e6))
            return str(exc.value)
        if code == clib.ERR_TENDON:
            return f"tendon segment {route[entry]!r} -> {route[entry + 1]!r} has zero length"
        return None

    def last_error():
        e, lam, rel = a.last_error, a.last_error_load_factor, a.last_error_residual
        if e == clib.ERR_STAGNATION:
            return f"Newton stagnates at load factor {lam:.6g} (relative residual {rel:.2e})"
        if e == clib.ERR_NOT_CONVERGED:
            return (f"Newton did not converge in {a.last_error_iterations} iterations "
                    f"(relative residual {rel:.2e})")
        if e == clib.ERR_LINE_SEARCH:
            return f"line search failed at load factor {lam:.6g} (relative residual {rel:.2e})"
        if e == clib.ERR_JUMP:
            return f"the path jumped by more than {max_dq} in q at load factor {lam:.6g}"
        if e == clib.ERR_NONFINITE:
            return "a model returned a non-finite value"
        return str(model_message(e, a.last_error_flexure, a.last_error_route))

    lam = a.failure_load_factor
    reason = {
        clib.FAIL_UNLOADED: f"no equilibrium of the unloaded scene: {last_error()}",
        clib.FAIL_STEPS: (f"load continuation needed more than "
                          f"{plan.problem.settings.max_steps} steps (reached load factor "
                          f"{lam:.6g})"),
        clib.FAIL_BIFURCATION: (f"no stable equilibrium found past the bifurcation near load "
                                f"factor {lam:.6g}: {last_error()}"),
        clib.FAIL_LIMIT: f"no equilibrium found beyond load factor {lam:.6g}: {last_error()}",
    }[a.failure]
    model_error = model_message(a.model_error, a.model_error_flexure, a.model_error_route)
    if model_error and model_error not in reason:
        reason = f"{reason} (last model error: {model_error})"
    return reason


def finger(tension: float):
    """The two-link finger with its tendon at this tension (400 N: no equilibrium beyond a load
    factor of about 0.16)."""
    from dataclasses import replace
    scene = example("two_link_finger")
    return replace(scene, tendons=tuple(replace(t, tension=tension) for t in scene.tendons))


def zero_tendon():
    """A tendon whose two route points coincide in the unloaded state: no unloaded equilibrium."""
    return scene_from_dict({
        "name": "zero tendon", "flexure": [{"name": "a", "length": 1.0, "EI": 1.0}],
        "link": [{"name": "l", "parent": "a", "points": {"p": [0.0, 0.0]}}],
        "tendon": [{"tension": 1.0, "route": ["a.tip", "l.p"]}],
        "output": {"points": ["a.tip"]}})


@pytest.mark.parametrize("scene, factory, settings", [
    (cantilever(moment=math.radians(150.0)), scm(3, "poly"), {}),
    (cantilever(force=(0.0, -2.0)), scm(3), dict(max_iterations=0)),
    (cantilever(force=(0.0, -2.0)), scm(3), dict(max_steps=0)),
    (cantilever(force=(-3.4375929, 0.0)), scm(5), dict(max_iterations=1, max_steps=3)),
    (cantilever(force=(0.0, -2.0)), fem(8), dict(max_dq=1e-3, max_steps=20)),
    (cantilever(**SNAP), scm(5, "gauss"), dict(max_iterations=1)),
    (column(25.0, 0.0), scm(3, "gauss"), dict(max_iterations=1)),
], ids=["poly-range", "no-iterations", "no-steps", "few-steps", "jumps", "snap", "buckling"])
def test_no_equilibrium_reason_from_the_c_answer(scene, factory, settings):
    """Where the Python solver finds no equilibrium, so does the C solver (FG_NO_EQUILIBRIUM),
    and its answer's fields give the same reason, load factor and iterations."""
    rp = solve(scene, model_factory=factory, **settings)
    models = build_models(scene, None, factory)
    chain = Chain(scene, models)
    system = eq.System(chain)
    outputs = eq._output_points(scene, chain)
    plan = build_plan(chain, system.loads, system.tendons, outputs, **settings)
    status = plan.run()
    if rp.converged:
        assert status == clib.SOLVED
        pytest.skip("the Python solver finds an equilibrium here")
    assert status == clib.NO_EQUILIBRIUM
    max_dq = settings.get("max_dq", 0.5)
    assert c_reason(plan, models, system.tendons, max_dq) == rp.reason
    assert plan.answer.failure_load_factor == rp.load_factor
    assert plan.answer.iterations == rp.iterations
    assert plan.answer.ncritical == len(rp.critical_load_factors)


def test_limit_point_failure_from_the_c_answer():
    """The finger at 400 N: the path ends near lam = 0.16316 and the descent to the state it would
    snap to fails. Same failure and load factor; the last error comes from a descent that wanders
    for hundreds of iterations without converging, whose end (a failed line search after 671
    iterations in Python, 673 with LAPACK's dsyev in C, the iteration limit with the built-in
    Jacobi method) depends on the eigen-solver's rounding: not compared."""
    scene = finger(400.0)
    rp = solve(scene, model_factory=scm(3))
    models = build_models(scene, None, scm(3))
    chain = Chain(scene, models)
    system = eq.System(chain)
    plan = build_plan(chain, system.loads, system.tendons, eq._output_points(scene, chain))
    assert plan.run() == clib.NO_EQUILIBRIUM and plan.answer.failure == clib.FAIL_LIMIT
    assert plan.answer.failure_load_factor == rp.load_factor
    head = c_reason(plan, models, system.tendons, 0.5).split(": ")[0]
    assert rp.reason.split(": ")[0] == head
    assert plan.answer.last_error in (clib.ERR_LINE_SEARCH, clib.ERR_NOT_CONVERGED)


def test_no_unloaded_equilibrium_reason_from_the_c_answer():
    scene = zero_tendon()
    rp = solve(scene, model_factory=scm(3))
    assert not rp.converged and "zero length" in rp.reason
    models = build_models(scene, None, scm(3))
    chain = Chain(scene, models)
    system = eq.System(chain)
    plan = build_plan(chain, system.loads, system.tendons, eq._output_points(scene, chain))
    assert plan.run() == clib.NO_EQUILIBRIUM
    assert plan.answer.failure == clib.FAIL_UNLOADED
    assert plan.answer.last_error == plan.answer.model_error == clib.ERR_TENDON
    assert c_reason(plan, models, system.tendons, 0.5) == rp.reason
