"""Reference models: exact elastica solver, rigid-segment chain (FEM), pseudo-rigid-body 1R.

Every expected value here comes from an independent source: the tables and closed forms of
../shared/model-notes.md, elliptic-integral closed forms, linear beam theory, or finite
differences; never from the code under test itself.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from reference import solve_cantilever
from scipy.special import ellipe, ellipk

import flexgen
from flexgen.models.exact import cantilever, euler_load, post_buckled, solve_exact, tip_compliance
from flexgen.models.fem import FEMModel
from flexgen.models.prb import PRBModel
from flexgen.scene import Flexure, Link, Load, ModelSpec, Scene, Tendon
from flexgen_tools.honesty import REFERENCE_NOISE

MS = ModelSpec(kind="exact")


def make_scene(flexures, links=(), loads=(), tendons=(), outputs=(), base=None):
    return Scene(
        name="test",
        model=MS,
        base_points=base or {},
        flexures=tuple(flexures),
        links=tuple(links),
        loads=tuple(loads),
        tendons=tuple(tendons),
        outputs=tuple(outputs),
    )


def rot(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


# ------------------------------------------------------------------------------------------
# exact solver: single cantilever
# ------------------------------------------------------------------------------------------


def test_rectangular_elastica_table():
    sol = cantilever(1.0, 1.0, force=(-3.4375929, 0.0))
    assert sol.converged and sol.stable and sol.branch == "post-buckled"
    assert abs(sol.pose[0] - 0.456947) < 5e-7
    assert abs(sol.pose[1] - 0.762760) < 5e-7
    assert abs(sol.pose[2] - math.pi / 2) < 1e-6


def test_rectangular_elastica_closed_form():
    m = 0.5  # k = 1/sqrt(2)
    K, E = float(ellipk(m)), float(ellipe(m))
    sol = cantilever(1.0, 1.0, force=(-K * K, 0.0))
    assert abs(sol.pose[0] - (2 * E / K - 1)) < 1e-9
    assert abs(sol.pose[1] - math.sqrt(2) / K) < 1e-9
    assert abs(sol.pose[2] - math.pi / 2) < 1e-9


@pytest.mark.parametrize("M", [0.3, math.pi / 2, 3.0, 6.0])
def test_pure_moment_arc(M):
    EI, L = 2.0, 3.0
    sol = cantilever(EI, L, moment=M * EI / L)
    th = M
    assert abs(sol.pose[2] - th) < 1e-10
    assert abs(sol.pose[0] - L * math.sin(th) / th) < 1e-9
    assert abs(sol.pose[1] - L * (1 - math.cos(th)) / th) < 1e-9
    # the whole shape is the circle of radius L/th about (0, L/th)
    r = np.hypot(sol.shape[:, 0], sol.shape[:, 1] - L / th)
    assert np.max(np.abs(r - L / th)) < 1e-9
    assert np.allclose(sol.moment, M * EI / L, atol=1e-9)


BISSHOPP_DRUCKER = [
    (0.25, 0.99588, 0.08275, 0.12429),
    (1.0, 0.94357, 0.30172, 0.46135),
    (2.0, 0.83936, 0.49346, 0.78175),
    (3.0, 0.74558, 0.60325, 0.98602),
    (5.0, 0.61237, 0.71379, 1.21537),
    (10.0, 0.44500, 0.81061, 1.43029),
]


@pytest.mark.parametrize("alpha,x,d,th", BISSHOPP_DRUCKER)
def test_bisshopp_drucker(alpha, x, d, th):
    EI, L = 1.0, 1.0
    sol = cantilever(EI, L, force=(0.0, -alpha))  # downward: deflection -y
    assert sol.converged and sol.stable
    tol = 5e-6 + 1e-12  # the table's 5 digits
    assert abs(sol.pose[0] - x) < tol
    assert abs(-sol.pose[1] - d) < tol
    assert abs(-sol.pose[2] - th) < tol


def test_bisshopp_drucker_dimensional_scaling():
    EI, L, alpha = 2.5, 0.4, 3.0
    sol = cantilever(EI, L, force=(0.0, alpha * EI / L**2))
    assert abs(sol.pose[0] / L - 0.74558) < 5e-6
    assert abs(sol.pose[1] / L - 0.60325) < 5e-6
    assert abs(sol.pose[2] - 0.98602) < 5e-6


POST_BUCKLED = [
    (30, 2.55406, 0.93243, 0.32390),
    (60, 2.84175, 0.74102, 0.59321),
    (120, 4.65056, 0.12316, 0.80317),
]


@pytest.mark.parametrize("deg,P,x,y", POST_BUCKLED)
def test_post_buckled_table(deg, P, x, y):
    a = math.radians(deg)
    # the table's load (5 digits) gives the table's pose; rounding of P moves the tip a little
    sol = cantilever(1.0, 1.0, force=(-P, 0.0))
    assert sol.converged and sol.stable and sol.branch == "post-buckled"
    assert sol.pose[1] > 0  # consistent direction: +y
    assert abs(sol.pose[2] - a) < 1e-4
    assert abs(sol.pose[0] - x) < 2e-5
    assert abs(sol.pose[1] - y) < 2e-5
    # closed form (elliptic integrals) against the table, then the solver against it to 1e-9
    Pc, xc, yc = post_buckled(1.0, 1.0, a)
    assert abs(Pc - P) < 5e-6 and abs(xc - x) < 5e-6 and abs(yc - y) < 5e-6
    sol = cantilever(1.0, 1.0, force=(-Pc, 0.0))
    assert abs(sol.pose[2] - a) < 1e-9
    assert abs(sol.pose[0] - xc) < 1e-9 and abs(sol.pose[1] - yc) < 1e-9


def test_first_buckling_load_detection():
    for EI, L in [(1.0, 1.0), (2.0, 3.0)]:
        P1 = math.pi**2 / 4 * EI / L**2
        assert abs(euler_load(EI, L) - P1) < 1e-15
        below = cantilever(EI, L, force=(-0.99 * P1, 0.0))
        assert below.critical_load is None and below.branch == "primary" and below.stable
        assert np.allclose(below.pose, [L, 0.0, 0.0], atol=1e-12)
        above = cantilever(EI, L, force=(-1.5 * P1, 0.0))
        assert above.critical_load is not None
        assert abs(above.critical_load - P1) < 1e-9 * P1
        assert above.branch == "post-buckled" and above.stable and above.pose[1] > 0
    assert abs(euler_load(1, 1, 2) - 22.20661) < 5e-6
    assert abs(euler_load(1, 1, 3) - 61.68503) < 5e-6


def test_imperfect_column_follows_its_imperfection():
    up = cantilever(1.0, 1.0, force=(-3.0, 0.01))
    down = cantilever(1.0, 1.0, force=(-3.0, -0.01))
    assert up.stable and down.stable and up.pose[1] > 0.5 and down.pose[1] < -0.5
    assert np.allclose(up.pose * [1, -1, -1], down.pose, atol=1e-10)


def test_small_load_compliance():
    EI, L = 2.0, 3.0
    C = tip_compliance(EI, L)
    lin = np.array([[L**3 / 3, L**2 / 2], [L**2 / 2, L]]) / EI
    assert np.allclose(C[1:, 1:], lin, rtol=1e-10, atol=0)
    assert np.allclose(C[0], 0, atol=1e-12) and np.allclose(C[:, 0], 0, atol=1e-12)
    # a small transverse load: the compliance moves off the linear one at O(load^2)
    C = tip_compliance(EI, L, force=(0.0, 1e-4 * EI / L**2))
    assert np.allclose(C[1:, 1:], lin, rtol=1e-7, atol=0)


def test_arc_compliance_eigenvalues():
    C = tip_compliance(1.0, 1.0, moment=math.pi / 2)
    assert np.allclose(C, C.T, atol=1e-12)
    ev = np.linalg.eigvalsh(C[:2, :2])
    assert abs(ev[1] - 0.2876591) < 1e-6
    assert abs(ev[0] - 0.0068858) < 1e-6


def test_tip_compliance_matches_finite_differences():
    EI, L = 1.3, 0.7
    F = np.array([0.8, 2.1]) * EI / L**2
    M = 0.6 * EI / L
    C = tip_compliance(EI, L, force=F, moment=M)
    h = 1e-4
    scales = [EI / L**2, EI / L**2, EI / L]
    Cfd = np.empty((3, 3))
    for j in range(3):
        w = np.array([F[0], F[1], M])
        dw = np.zeros(3)
        dw[j] = h * scales[j]
        p = cantilever(EI, L, force=(w + dw)[:2], moment=(w + dw)[2]).pose
        m = cantilever(EI, L, force=(w - dw)[:2], moment=(w - dw)[2]).pose
        Cfd[:, j] = (p - m) / (2 * dw[j])
    assert np.allclose(C, Cfd, rtol=1e-7, atol=1e-9 * np.max(np.abs(C)))
    assert np.allclose(C, C.T, atol=1e-11)


# ------------------------------------------------------------------------------------------
# exact solver: scenes
# ------------------------------------------------------------------------------------------

F0, M0 = (0.3, 1.7), 0.4


def test_scene_single_flexure_equals_cantilever():
    sc = make_scene(
        [Flexure("a", "base", (0.0, 0.0, 0.0), 1.0, 1.0, MS)], loads=[Load("a.tip", F0, M0)]
    )
    res = solve_exact(sc)
    ref = cantilever(1.0, 1.0, F0, M0)
    assert res.converged and res.stable and not res.warnings
    assert np.allclose(res.poses["a.tip"], ref.pose, atol=1e-10)
    assert np.allclose(res.compliance["a.tip"], tip_compliance(1.0, 1.0, F0, M0)[:2, :2], atol=1e-8)
    assert np.allclose(res.shapes["a"][-1], ref.pose[:2], atol=1e-10)


def test_scene_two_half_flexures_equal_one():
    L, EI = 1.0, 1.0
    sc = make_scene(
        [
            Flexure("a", "base", (0.0, 0.0, 0.0), L / 2, EI, MS),
            Flexure("b", "mid", (0.0, 0.0, 0.0), L / 2, EI, MS),
        ],
        links=[Link("mid", "a", {"p": (0.0, 0.0)})],
        loads=[Load("b.tip", F0, M0)],
        outputs=("b.tip", "mid.p"),
    )
    res = solve_exact(sc, num=51)
    ref = cantilever(EI, L, F0, M0, num=101)
    assert res.converged and res.stable
    assert np.allclose(res.poses["b.tip"], ref.pose, atol=1e-10)
    assert np.allclose(res.compliance["b.tip"], tip_compliance(EI, L, F0, M0)[:2, :2], atol=1e-8)
    assert np.allclose(res.poses["mid.p"][:2], ref.shape[50], atol=1e-10)
    assert abs(res.poses["mid.p"][2] - ref.phi[50]) < 1e-10
    assert np.allclose(res.shapes["a"], ref.shape[:51], atol=1e-9)
    assert np.allclose(res.shapes["b"], ref.shape[50:], atol=1e-9)
    assert np.allclose(res.root_loads["a"], [F0[0], F0[1], ref.root_moment], atol=1e-10)


def test_scene_rotated_root_and_link_offset():
    # a link offset along the flexure's tip axis with a moment-free load at its end is the same
    # as a longer arm; check frames instead: a rotated, translated root gives the rotated result
    a = 0.7
    at = (0.4, -0.2, a)
    Fw = rot(a) @ np.array(F0)
    sc = make_scene(
        [Flexure("a", "base", at, 1.0, 1.0, MS)],
        links=[Link("l", "a", {"p": (0.0, 0.0)})],
        loads=[Load("l.p", tuple(Fw), M0)],
    )
    res = solve_exact(sc)
    ref = cantilever(1.0, 1.0, F0, M0)
    exp = np.array(at[:2]) + rot(a) @ ref.pose[:2]
    assert np.allclose(res.poses["l.p"][:2], exp, atol=1e-10)
    assert abs(res.poses["l.p"][2] - (a + ref.pose[2])) < 1e-10
    Cref = tip_compliance(1.0, 1.0, F0, M0)[:2, :2]
    assert np.allclose(res.compliance["l.p"], rot(a) @ Cref @ rot(a).T, atol=1e-8)


def test_scene_symmetric_fork():
    # trunk along +x, a link carrying two branches at +-b, loaded mirror-symmetrically: the
    # trunk carries a pure axial tension and stays straight; each branch is a cantilever
    b, Lt, Lb = 0.5, 0.6, 0.8
    Fb = np.array([0.2, 1.1])  # in the upper branch's root frame
    Fu = rot(b) @ Fb
    Fl = Fu * [1, -1]
    sc = make_scene(
        [
            Flexure("trunk", "base", (0.0, 0.0, 0.0), Lt, 1.0, MS),
            Flexure("up", "hub", (0.1, 0.0, b), Lb, 1.0, MS),
            Flexure("lo", "hub", (0.1, 0.0, -b), Lb, 1.0, MS),
        ],
        links=[Link("hub", "trunk", {"c": (0.0, 0.0)})],
        loads=[Load("up.tip", tuple(Fu), 0.0), Load("lo.tip", tuple(Fl), 0.0)],
    )
    res = solve_exact(sc)
    assert res.converged and res.stable
    assert np.allclose(res.tip_frames["trunk"], [Lt, 0.0, 0.0], atol=1e-10)
    ref = cantilever(1.0, Lb, tuple(Fb))
    up = np.array([Lt + 0.1, 0.0]) + rot(b) @ ref.pose[:2]
    assert np.allclose(res.poses["up.tip"][:2], up, atol=1e-10)
    assert np.allclose(res.poses["lo.tip"][:2], up * [1, -1], atol=1e-10)
    assert abs(res.poses["lo.tip"][2] + res.poses["up.tip"][2]) < 1e-10


def test_scene_tendon_consistent_with_dead_load():
    # the tendon pulls the link point towards a base point; at equilibrium the same force held
    # dead (with the moment of its offset) must reproduce the pose
    T = 2.0
    sc = make_scene(
        [Flexure("a", "base", (0.0, 0.0, 0.0), 1.0, 1.0, MS)],
        links=[Link("l", "a", {"h": (0.0, 0.1)})],
        loads=[Load("a.tip", (0.0, -0.5), 0.0)],
        tendons=[Tendon(T, ("base.r0", "l.h"))],
        base={"r0": (0.2, 0.3)},
        outputs=("l.h", "a.tip"),
    )
    res = solve_exact(sc)
    assert res.converged and res.stable
    h, tip = res.poses["l.h"], res.poses["a.tip"]
    u = (np.array([0.2, 0.3]) - h[:2]) / np.linalg.norm(np.array([0.2, 0.3]) - h[:2])
    Ft = T * u
    arm = h[:2] - tip[:2]
    M = arm[0] * Ft[1] - arm[1] * Ft[0]
    ref = cantilever(1.0, 1.0, force=tuple(Ft + [0.0, -0.5]), moment=M)
    assert np.allclose(tip, ref.pose, atol=1e-9)
    # compliance against central differences of full re-solves with an extra load at l.h
    d = 1e-4
    cols = []
    for e in np.eye(2):
        poses = []
        for sgn in (1, -1):
            sc2 = make_scene(
                sc.flexures,
                sc.links,
                sc.loads + (Load("l.h", tuple(sgn * d * e)),),
                sc.tendons,
                ("l.h",),
                dict(sc.base_points),
            )
            poses.append(solve_exact(sc2).poses["l.h"][:2])
        cols.append((poses[0] - poses[1]) / (2 * d))
    Cfd = np.array(cols).T
    C = res.compliance["l.h"]
    assert np.allclose(C, Cfd, rtol=1e-6, atol=1e-8)
    assert np.allclose(C, C.T, atol=1e-8)  # constant-tension tendon is conservative


def test_scene_axial_buckling_follows_stable_branch():
    m = 0.5
    P = float(ellipk(m)) ** 2  # rectangular elastica
    sc = make_scene(
        [
            Flexure("a", "base", (0.0, 0.0, 0.0), 0.5, 1.0, MS),
            Flexure("b", "mid", (0.0, 0.0, 0.0), 0.5, 1.0, MS),
        ],
        links=[Link("mid", "a", {"p": (0.0, 0.0)})],
        loads=[Load("b.tip", (-P, 0.0), 0.0)],
    )
    res = solve_exact(sc)
    assert res.converged and res.stable
    K, E = float(ellipk(m)), float(ellipe(m))
    assert np.allclose(
        res.poses["b.tip"], [2 * E / K - 1, math.sqrt(2) / K, math.pi / 2], atol=1e-9
    )
    assert abs(res.critical_load_factor * P - math.pi**2 / 4) < 1e-7
    assert any("bifurcation" in w for w in res.warnings)


# ------------------------------------------------------------------------------------------
# FEM (rigid segments + torsion springs)
# ------------------------------------------------------------------------------------------


def test_fem_second_order_convergence():
    ref = cantilever(1.0, 1.0, force=(0.0, 1.0)).pose  # Bisshopp-Drucker alpha = 1
    errs = []
    for n in (8, 16, 32, 64):
        q, tk = solve_cantilever(FEMModel(1.0, 1.0, n), force=(0.0, 1.0), steps=5)
        errs.append(np.linalg.norm(tk.pose - ref))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 3.7) & (ratios < 4.3)), ratios
    assert errs[-1] < 3e-5


def test_fem16_arc_compliance_matches_paper():
    m = FEMModel(1.0, 1.0, 16)
    assert m.n_dof == 16
    q, tk = solve_cantilever(m, moment=math.pi / 2)
    assert abs(tk.pose[2] - math.pi / 2) < 1e-12  # tip angle is exact for a moment
    w = np.array([0.0, 0.0, math.pi / 2])
    K = m.energy_hessian(q) - np.einsum("k,kij->ij", w, tk.H)
    C = tk.J @ np.linalg.solve(K, tk.J.T)
    ev = np.linalg.eigvalsh(C[:2, :2])
    assert abs(ev[1] - 0.2873) < 5e-5 and abs(ev[0] - 0.0069) < 5e-5


def _fd_check(model, q, h=1e-6):
    tk = model.tip(q)
    n = model.n_dof
    J = np.empty((3, n))
    H = np.empty((3, n, n))
    for i in range(n):
        e = np.zeros(n)
        e[i] = h
        tp, tm = model.tip(q + e), model.tip(q - e)
        J[:, i] = (tp.pose - tm.pose) / (2 * h)
        H[:, :, i] = (tp.J - tm.J) / (2 * h)
    assert np.allclose(tk.J, J, atol=1e-8)
    assert np.allclose(tk.H, H, atol=1e-8)
    assert np.allclose(tk.H, np.transpose(tk.H, (0, 2, 1)), atol=0)
    # second derivative of the pose directly (independent of J)
    for i, j in [(0, 0), (0, n - 1), (n - 1, n // 2)]:
        ei, ej = np.zeros(n), np.zeros(n)
        ei[i], ej[j] = 1e-4, 1e-4
        d2 = (
            model.tip(q + ei + ej).pose
            - model.tip(q + ei - ej).pose
            - model.tip(q - ei + ej).pose
            + model.tip(q - ei - ej).pose
        ) / (4e-8)
        assert np.allclose(tk.H[:, i, j], d2, atol=1e-6)
    g = np.array([(model.energy(q + e) - model.energy(q - e)) / (2 * h) for e in np.eye(n) * h])
    assert np.allclose(model.energy_gradient(q), g, rtol=1e-6, atol=1e-9)
    Hh = np.array(
        [
            (model.energy_gradient(q + e) - model.energy_gradient(q - e)) / (2 * h)
            for e in np.eye(n) * h
        ]
    ).T
    assert np.allclose(model.energy_hessian(q), Hh, rtol=1e-6, atol=1e-9)


def test_fem_derivatives_finite_differences():
    rng = np.random.default_rng(1)
    m = FEMModel(0.8, 1.7, 7)
    _fd_check(m, rng.normal(scale=0.4, size=7))


def test_fem_geometry():
    m = FEMModel(2.0, 1.0, 5)
    assert abs(m.segments.sum() - 2.0) < 1e-15
    assert np.allclose(m.tip(np.zeros(5)).pose, [2.0, 0.0, 0.0])
    q = np.full(5, 0.3)
    pts = m.shape(q)
    assert np.allclose(pts[-1], m.tip(q).pose[:2])
    assert abs(m.energy(q) - 0.5 * (1.0 / 0.4) * 5 * 0.09) < 1e-14


# ------------------------------------------------------------------------------------------
# PRB 1R
# ------------------------------------------------------------------------------------------


def test_prb_derivatives_finite_differences():
    m = PRBModel(0.9, 1.4)
    assert m.n_dof == 1
    assert abs(m.stiffness - 0.85 * 2.65 * 1.4 / 0.9) < 1e-14
    for q in (-0.7, 0.0, 0.4, 1.2):
        _fd_check(m, np.array([q]))


def test_prb_geometry():
    m = PRBModel(1.0, 1.0)
    assert np.allclose(m.tip([0.0]).pose, [1.0, 0.0, 0.0])
    t = m.tip([math.pi / 2]).pose
    assert np.allclose(t, [0.15, 0.85, math.pi / 2])
    pts = m.shape([0.5])
    assert np.allclose(pts[-1], m.tip([0.5]).pose[:2]) and np.allclose(pts[0], 0)


def test_prb_small_moment_matches_arc():
    # Howell's end-moment parameters: gamma = 0.7346, K_theta = 2.0643 (c_theta = gamma K_theta
    # = 1.5164). The tip angle of the beam is c_theta times the pseudo-rigid angle; the tip
    # position is within about 3 % of the deflection for small moments, and the exact tip lies
    # within 0.5 % of the deflection of the PRB circle up to about 85 degrees.
    g, KT = 0.7346, 2.0643
    m = PRBModel(1.0, 1.0, gamma=g, K_theta=KT)
    for th in (0.05, 0.3, 1.0, 1.5):
        q, tk = solve_cantilever(m, moment=th)
        arc = np.array([math.sin(th) / th, (1 - math.cos(th)) / th])
        defl = np.hypot(1 - arc[0], arc[1])
        assert abs(g * KT * tk.pose[2] - th) < 1e-12
        assert np.linalg.norm(tk.pose[:2] - arc) < 0.035 * defl
        on_path = m.tip([math.atan2(arc[1], arc[0] - (1 - g))]).pose[:2]
        assert np.linalg.norm(on_path - arc) < 0.005 * defl


def test_prb_tip_path_force():
    # Howell's claim for a transverse end force: with gamma = 0.85 the exact tip lies within
    # 0.5 % of the deflection of the PRB tip path (pseudo-rigid angle up to about 64 degrees)
    m = PRBModel(1.0, 1.0)
    for _alpha, x, d, _th in BISSHOPP_DRUCKER[:5]:
        ex = np.array([x, d])
        defl = np.hypot(1 - x, d)
        on_path = m.tip([math.atan2(d, x - 0.15)]).pose[:2]
        assert np.linalg.norm(on_path - ex) < 0.005 * defl


def _cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def test_scene_chain_multipoint_tendon_against_cantilevers():
    # flexure b grows directly from flexure a's tip frame; a tendon runs base.r0 -> l.g -> l.h
    # -> base.r1 through two holes of the link on b (the g-h segment is internal). At the
    # equilibrium, each flexure must be the cantilever under the resultant beyond its tip.
    T = 2.0
    r0, r1 = np.array([0.2, 0.3]), np.array([1.3, -0.4])
    sc = make_scene(
        [
            Flexure("a", "base", (0.0, 0.0, 0.0), 0.6, 1.0, MS),
            Flexure("b", "a", (0.0, 0.0, 0.0), 0.4, 0.7, MS),
        ],
        links=[Link("l", "b", {"h": (0.05, 0.1), "g": (-0.05, 0.1)})],
        loads=[Load("a.tip", (0.0, -0.5), 0.1)],
        tendons=[Tendon(T, ("base.r0", "l.g", "l.h", "base.r1"))],
        base={"r0": tuple(r0), "r1": tuple(r1)},
        outputs=("l.h", "l.g", "a.tip", "b.tip"),
    )
    res = solve_exact(sc)
    assert res.converged and res.stable
    g, h = res.poses["l.g"][:2], res.poses["l.h"][:2]
    ta, tb = res.poses["a.tip"], res.poses["b.tip"]
    Fg = T * (r0 - g) / np.linalg.norm(r0 - g)
    Fh = T * (r1 - h) / np.linalg.norm(r1 - h)
    Fb = Fg + Fh
    Mb = _cross(g - tb[:2], Fg) + _cross(h - tb[:2], Fh)
    # b: cantilever in a's tip frame
    R = rot(ta[2])
    cb = cantilever(0.7, 0.4, force=tuple(R.T @ Fb), moment=Mb)
    assert np.allclose(tb[:2], ta[:2] + R @ cb.pose[:2], atol=1e-9)
    assert abs(tb[2] - (ta[2] + cb.pose[2])) < 1e-9
    # a: cantilever from the base under everything beyond its tip
    Fa = Fb + np.array([0.0, -0.5])
    Ma = 0.1 + _cross(g - ta[:2], Fg) + _cross(h - ta[:2], Fh)
    ca = cantilever(1.0, 0.6, force=tuple(Fa), moment=Ma)
    assert np.allclose(ta, ca.pose, atol=1e-9)


def test_limit_point_is_reported_not_hidden():
    # this proportional load path has a fold (snap-through) near load factor 0.5457: both the
    # cantilever solver and the scene solver must stop there, say so, and agree where
    F, M = (-1.74574099, -4.67920763), 3.478735754260268
    c = cantilever(1.0, 1.0, F, M)
    assert not c.converged and any("limit point" in w for w in c.warnings)
    sc = make_scene(
        [
            Flexure("a", "base", (0.0, 0.0, 0.0), 0.5, 1.0, MS),
            Flexure("b", "a", (0.0, 0.0, 0.0), 0.5, 1.0, MS),
        ],
        loads=[Load("b.tip", F, M)],
    )
    r = solve_exact(sc)
    assert not r.converged and any("limit point" in w for w in r.warnings)
    assert abs(r.load_factor - c.critical_load_factor) < 1e-5
    assert 0.5 < c.critical_load_factor < 0.6


@pytest.mark.parametrize("P", [70.0, 120.0])
def test_the_scene_solver_follows_a_large_transverse_tip_load(P):
    """Found by review: a plain cantilever under a transverse tip force of 61 to 1000 EI/L^2
    (below the exact solver's cap) stalled at load factor 0.97 (P = 70) and said "limit point:
    the load would snap through", which a transverse dead load has none of: Newton's absolute
    residual tolerance (1e-12) sat below the shooting's rounding at such loads (1e-12 to 1e-9).
    Its tolerance is relative to the load level now: the scene solver converges and agrees with
    the single cantilever's own shooting (a Newton on the root moment alone) and, at P = 70,
    with fem128 and fem256 extrapolated as O(h^2) (Richardson: 6e-9 off here)."""
    sc = make_scene(
        [Flexure("b", "base", (0.0, 0.0, 0.0), 1.0, 1.0, MS)], loads=[Load("b.tip", (0.0, -P), 0.0)]
    )
    r = solve_exact(sc)
    assert r.converged and not r.warnings, r.warnings
    pose = np.array(r.poses["b.tip"])
    c = cantilever(1.0, 1.0, force=(0.0, -P))
    assert c.converged and np.abs(pose - c.pose).max() < 1e-9
    if P == 70.0:
        fine = [
            solve_cantilever(FEMModel(1.0, 1.0, n), force=(0.0, -P), steps=40)[1].pose
            for n in (128, 256)
        ]
        richardson = (4.0 * fine[1] - fine[0]) / 3.0
        assert np.abs(pose - richardson).max() < 5e-8


@pytest.mark.parametrize("degrees", [0, 45, 90, 135, 180, 225, 270, 315])
def test_a_perfect_column_buckles_to_the_chain_models_side(degrees):
    """A perfect column (root turned by ``degrees``) at 1.3 times its Euler load has two mirror
    post-buckled branches of equal energy; the chain models take the one whose output points
    lie higher, else the counter-clockwise one (docs/solver-core.md, the side rules). Found by
    review: the exact solver bent counter-clockwise at the root always, so a column along -x
    went to -y against every chain model's +y, 2.8 rad off an scm4 answer estimated at 3e-4.
    Now the two agree at every orientation (scm6 within its own error, 2e-7 here)."""
    a = math.radians(degrees)
    P = 1.3 * euler_load(1.0, 1.0)
    sc = make_scene(
        [Flexure("beam", "base", (0.0, 0.0, a), 1.0, 1.0, MS)],
        loads=[Load("beam.tip", (-P * math.cos(a), -P * math.sin(a)), 0.0)],
    )
    exact = solve_exact(sc)
    assert exact.converged
    chain = flexgen.solve(sc, model="scm", modes=6).points["beam.tip"].pose
    assert np.abs(exact.poses["beam.tip"][:2] - np.array(chain[:2])).max() < 1e-5


def test_a_load_step_does_not_jump_to_a_branch_wound_once_more():
    """Found by review: one flexure under a tension of 80 EI/L^2 at 0.6 rad and a moment of
    8 EI/L (at a point just off the tip) ended, converged, stable and unwarned, on a branch
    wound once more (tip angle 7.89 rad), where scm8 and fem512 agree on 1.65 rad and the
    exact solver itself, in shorter steps, does too. A step may turn a tip by at most
    MAX_TURN_STEP now."""
    a = 0.6
    sc = make_scene(
        [Flexure("b", "base", (0.0, 0.0, 0.0), 1.0, 1.0, MS)],
        links=[Link("l", "b", {"p": (0.043, -0.0996)})],
        loads=[Load("l.p", (80.0 * math.cos(a), 80.0 * math.sin(a)), 8.0)],
    )
    default, short = solve_exact(sc), solve_exact(sc, max_step=0.02)
    assert default.converged and short.converged
    assert abs(short.poses["l.p"][2] - 1.6508) < 1e-3
    assert np.abs(default.poses["l.p"] - short.poses["l.p"]).max() < 1e-9


def test_exact_solver_refuses_a_load_past_its_cap_and_says_so():
    """docs/scene.md: the exact solver gives up beyond a nondimensional load of 1000
    (MAX_LOAD); the reason names that cap, not a limit point it never met."""
    import flexgen
    from flexgen.models.exact import MAX_LOAD

    # F L^2/EI = 0.2 * 0.02^2 / (200 * 0.01 * 0.0003^3 / 12) = 1.78e7: E = 200 meant as GPa
    scene = {
        "flexure": [
            {"name": "strip", "length": 0.02, "E": 200.0, "width": 0.01, "thickness": 3e-4}
        ],
        "load": [{"point": "strip.tip", "force": [0.0, -0.2]}],
    }
    r = flexgen.solve(scene, model="exact")
    assert not r.converged
    assert f"beyond the exact solver's cap of {MAX_LOAD:g}" in r.reason
    assert "1.78e+07" in r.reason and "limit point" not in r.reason
    # in GPa, the same strip under 2 N is solved (F L^2/EI = 0.178)
    scene["flexure"][0]["E"] = 200e9
    scene["load"][0]["force"] = [0.0, -2.0]
    assert flexgen.solve(scene, model="exact").converged


def test_a_failed_exact_solve_offers_no_partial_result():
    """Beyond the cap the exact solve fails with nothing solved: its Result has no q and no
    points, so no warning may say "result is at the last converged load factor" (it did)."""
    import flexgen
    from flexgen.models.exact import PARTIAL_LOAD

    f = Flexure("f", "base", (0.0, 0.0, 0.0), 1.0, 1.0, MS)
    scene = make_scene([f], loads=[Load("f.tip", (0.0, 5000.0), 0.0)], outputs=["f.tip"])
    sol = solve_exact(scene)
    assert not sol.converged and PARTIAL_LOAD in sol.warnings  # the SceneSolution keeps it
    r = flexgen.solve(scene)
    assert not r.converged and r.q == {} and r.points == {}
    assert r.load_factor == 0.0 and "beyond the exact solver's cap" in r.reason
    assert all("load not fully applied" not in w for w in r.warnings)
    assert "load not fully applied" not in r.reason


def test_exact_and_chain_models_report_the_same_default_points():
    """No [output], no load: the tips of the flexures that carry no other flexure, for every
    model (the exact solver gave every tip)."""
    import flexgen

    a = Flexure("a", "base", (0.0, 0.0, 0.0), 1.0, 1.0, MS)
    b = Flexure("b", "l", (0.5, 0.0, 0.0), 1.0, 1.0, MS)
    c = Flexure("c", "base", (0.0, 0.0, 1.0), 1.0, 1.0, MS)
    scene = make_scene([a, b, c], links=[Link("l", "a", {})])
    assert list(flexgen.solve(scene).points) == ["b.tip", "c.tip"]
    assert list(flexgen.solve(scene, model="scm").points) == ["b.tip", "c.tip"]


def _buckled_cantilever_tip(P: float, L: float) -> tuple[float, float]:
    """Tip (x, y) of a cantilever column (EI = 1) buckled under an axial tip force P, to +y:
    sqrt(P) L = K(k), x = L (2 E(k)/K(k) - 1), y = 2 k L / K(k) (the elastica, m = k^2)."""
    from scipy.optimize import brentq

    m = brentq(lambda m: ellipk(m) - math.sqrt(P) * L, 0.0, 1.0 - 1e-12)
    K, E = ellipk(m), ellipe(m)
    return L * (2 * E / K - 1), 2 * math.sqrt(m) * L / K


@pytest.mark.parametrize("second", [1.1, 1.5])
def test_two_columns_past_their_euler_loads_both_buckle(second):
    """Two cantilever columns side by side, each past its Euler load (2.47 and 2.04 for
    lengths 1 and 1.1) at P = 3: with lengths 1 and 1.1 both crossings fell in one default
    load step, the determinant's sign did not change, and the exact solver reported both
    straight and stable (review). Each column's notes name its own critical load factor."""
    P = 3.0
    scene = {
        "model": {"kind": "exact"},
        "flexure": [
            {"name": "a", "length": 1.0, "EI": 1.0},
            {"name": "b", "parent": "base", "at": [0.0, 1.0, 0.0], "length": second, "EI": 1.0},
        ],
        "load": [
            {"point": "a.tip", "force": [-P, 0.0]},
            {"point": "b.tip", "force": [-P, 0.0]},
        ],
    }
    r = flexgen.solve(scene)
    assert r.converged and r.stable
    for name, L, y0 in (("a", 1.0, 0.0), ("b", second, 1.0)):
        x, y = _buckled_cantilever_tip(P, L)
        assert r.points[f"{name}.tip"].pose[:2] == pytest.approx([x, y0 + y], abs=1e-6)
    crossings = sorted(
        float(n.split("load factor ")[1].split(":")[0]) for n in r.notes if "bifurcation" in n
    )
    euler = sorted(math.pi**2 / 4 / L**2 / P for L in (1.0, second))  # load factors
    assert crossings == pytest.approx(euler, rel=1e-6)


def test_equal_columns_buckling_together_are_not_called_stable():
    """Two equal columns cross their (equal) Euler loads together: the determinant's sign never
    changes, and the straight state was reported stable with a negative compliance eigenvalue
    (review). It is unstable, and the answer says so."""
    column = {"length": 1.0, "EI": 1.0}
    scene = {
        "model": {"kind": "exact"},
        "flexure": [
            {"name": "a", **column},
            {"name": "b", "parent": "base", "at": [0.0, 1.0, 0.0], **column},
        ],
        "load": [
            {"point": "a.tip", "force": [-3.0, 0.0]},
            {"point": "b.tip", "force": [-3.0, 0.0]},
        ],
    }
    r = flexgen.solve(scene)
    assert not r.stable
    assert any("negative eigenvalue" in w for w in r.warnings)
    assert not any("determinant changed sign" in w for w in r.warnings)


def test_a_tendon_pulled_to_zero_length_is_named_not_a_snap_through():
    """A tendon whose link point reaches its anchor stalls the exact solver; it said "limit
    point: the load would snap through" and printed a critical load factor, where the stiffness
    is far from singular (review). Exact names the tendon segment; so do the chain models."""
    scene = {
        "model": {"kind": "exact"},
        "base": {"points": {"a": [0.3, -0.1]}},
        "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
        "link": [{"name": "arm", "parent": "beam", "points": {"p": [0.0, -0.5]}}],
        "tendon": [{"tension": 10.0, "route": ["base.a", "arm.p"]}],
    }
    r = flexgen.solve(scene)
    assert not r.converged
    assert "tendon segment 'base.a' -> 'arm.p' has nearly zero length" in r.reason
    assert "snap through" not in r.reason and not r.critical_load_factors
    # the chain models too (review: they read it as "a limit point with no stable state to snap
    # to"): the core names the segment where the load path ended
    for models in ({"model": "scm"}, {"model": "fem"}, {"model": "scm", "modes": 6}):
        r = flexgen.solve(scene, **models)
        assert not r.converged, models
        assert "tendon segment 'base.a' -> 'arm.p' is pulled to nearly zero length" in r.reason
        assert "limit point" not in r.reason, r.reason


def test_a_tendon_short_from_the_start_is_not_blamed():
    """Review: a segment that was short before any load (here 1 um, a stub flexure's tip and a
    base point, listed first) was named as the segment pulled shut where the path ended: only a
    segment the load pulled shut is named, by both solvers."""
    scene = {
        "base": {"points": {"a": [0.3, -0.1], "s": [0.01, -0.05 + 1e-6]}},
        "flexure": [
            {"name": "beam", "length": 1.0, "EI": 1.0},
            {"name": "stub", "parent": "base", "length": 0.01, "EI": 2.5e-5, "at": [0, -0.05, 0]},
        ],
        "link": [{"name": "arm", "parent": "beam", "points": {"p": [0.0, -0.5]}}],
        "tendon": [
            {"tension": 1e-9, "route": ["base.s", "stub.tip"]},
            {"tension": 10.0, "route": ["base.a", "arm.p"]},
        ],
    }
    for model in ("scm", "exact"):
        r = flexgen.solve(scene, model=model)
        assert not r.converged, model
        assert "'base.a' -> 'arm.p'" in r.reason and "stub.tip" not in r.reason, r.reason


def test_one_short_tendon_rule_for_the_core_and_the_exact_solver():
    """A segment is pulled shut at the same fraction of the longest flexure in both solvers."""
    import re
    from pathlib import Path

    from flexgen.models.exact import SHORT_TENDON

    source = (Path(flexgen.__file__).parent / "compiled" / "chain_solver.c").read_text()
    got = re.search(r"#define FG_SHORT_TENDON ([0-9.e+-]+)", source)
    assert got is not None and float(got.group(1)) == SHORT_TENDON


def test_exact_lists_q_in_scene_order_as_the_chain_models_do():
    # review: a flexure declared before its parent chain came second in exact's q, first in
    # its model and flexures (docs/solve.md: flexures in scene order)
    scene = flexgen.scene_from_dict(
        {
            "flexure": [
                {"name": "c", "parent": "L", "length": 0.5, "EI": 1.0},
                {"name": "a", "parent": "base", "length": 1.0, "EI": 1.0},
            ],
            "link": [{"name": "L", "parent": "a", "points": {"p": [0.1, 0.0]}}],
            "load": [{"point": "c.tip", "force": [0.0, -0.5]}],
        }
    )
    for model in ("scm", "exact"):
        r = flexgen.solve(scene, model=model)
        assert list(r.q) == list(r.model) == list(r.flexures) == ["c", "a"], model


@pytest.mark.parametrize("ratio", [1.03, 1.1146, 1.3])
def test_a_tendon_anchored_at_the_root_buckles_as_the_pinned_elastica(ratio):
    """A tendon from the root to the tip of a clamped flexure: its force passes through the
    root, so the moment vanishes at both ends, the pinned-pinned elastica of critical load
    pi^2 EI/L^2: T L^2/EI = 4 K(k)^2, tip angle 2 theta0 (k = sin(theta0/2)), tip at
    (2E/K - 1) L along the chord at theta0. Review: the exact solver stayed straight and
    unstable from 1.03 to 1.3 x the critical tension (the pushes along the null vector just
    past the bifurcation fell back to the straight state)."""
    from scipy.optimize import brentq

    T = ratio * math.pi**2
    m = brentq(lambda m: 4 * ellipk(m) ** 2 - T, 1e-12, 0.999)
    theta0 = 2 * math.asin(math.sqrt(m))
    chord = 2 * ellipe(m) / ellipk(m) - 1
    want = [chord * math.cos(theta0), chord * math.sin(theta0), 2 * theta0]
    scene = flexgen.scene_from_dict(
        {
            "base": {"points": {"r0": [0.0, 0.0]}},
            "flexure": [{"name": "f", "length": 1.0, "EI": 1.0}],
            "tendon": [{"tension": T, "route": ["base.r0", "f.tip"]}],
        }
    )
    exact = flexgen.solve(scene, model="exact")
    assert exact.stable and not exact.warnings
    assert exact.points["f.tip"].pose == pytest.approx(want, abs=1e-9)
    scm = flexgen.solve(scene, modes=5)
    err = max(abs(a - b) for a, b in zip(scm.points["f.tip"].pose, want))
    assert scm.stable and err <= scm.points["f.tip"].error_estimate["pose"]


def test_the_exact_compliance_is_resolved_where_the_shooting_map_bends_sharply():
    """Review: on a three-flexure chain under large loads (a moment on a link) the exact
    solver's compliance, from the shooting Jacobian by central differences at 1e-6, was 12 %
    off (5x these loads; 0.12 % at 0.8x), with no warning: the step's truncation error. The
    complex-step Jacobian has none. Reference: scm8, a different discretisation, within its
    own stated compliance estimate; and the 2x2 compliance is symmetric, as a compliance is."""
    k = 0.8  # the review's loads times 0.8: the same failure, in half the time
    scene = {
        "flexure": [
            {"name": "f0", "length": 1.322, "EI": 1.228},
            {
                "name": "f1",
                "length": 0.762,
                "EI": 0.501,
                "parent": "l0",
                "at": [0.629, 0.104, -0.127],
            },
            {
                "name": "f2",
                "length": 1.27,
                "EI": 0.909,
                "parent": "l1",
                "at": [0.811, -0.034, 0.038],
            },
        ],
        "link": [
            {"name": "l0", "parent": "f0", "points": {"p": [0.577, -0.123]}},
            {"name": "l1", "parent": "f1", "points": {"p": [0.664, -0.094]}},
            {"name": "l2", "parent": "f2", "points": {"p": [0.58, 0.138]}},
        ],
        "load": [
            {"point": "l0.p", "force": [9.008 * k, 9.143 * k]},
            {"point": "l1.p", "force": [-9.085 * k, 4.048 * k], "moment": 9.027 * k},
            {"point": "l2.p", "force": [-8.974 * k, 4.662 * k]},
        ],
        "output": {"points": ["l2.p"]},
    }
    exact = flexgen.solve(scene, model="exact")
    rich = flexgen.solve(scene, modes=8).points["l2.p"]
    c_exact = np.array(exact.points["l2.p"].compliance)
    c_rich = np.array(rich.compliance)
    error = np.abs(c_exact - c_rich).max() / np.abs(c_rich).max()
    assert error <= rich.error_estimate["compliance"], error  # 1.2e-3 before, 6e-7 now
    assert abs(c_exact[0, 1] - c_exact[1, 0]) <= 1e-10 * np.abs(c_exact).max()


def arc_compliance(m: float, L: float, EI: float) -> np.ndarray:
    """The tip's 2x2 compliance of a cantilever bent into a circular arc by a tip moment
    M = m EI / L (m: the tip angle), by hand: with no force in it, a tip force dF adds the
    moment (r_tip - r(s)) x dF along it and nothing else to first order, so
    C = 1/EI int_0^L p(s) p(s)^T ds, p = (-(y_tip - y), x_tip - x); Gauss-Legendre on 200
    nodes (the integrand is a trigonometric polynomial of frequency 2 m)."""
    x, w = np.polynomial.legendre.leggauss(200)
    s = 0.5 * L * (x + 1.0)
    w = 0.5 * L * w
    r = L / m * np.stack([np.sin(m * s / L), 1.0 - np.cos(m * s / L)])
    tip = L / m * np.array([math.sin(m), 1.0 - math.cos(m)])
    p = np.stack([-(tip[1] - r[1]), tip[0] - r[0]])
    return (p * w) @ p.T / EI


@pytest.mark.parametrize("m", [1.0, math.pi, 2.0 * math.pi, 4.0 * math.pi])
def test_the_exact_compliance_of_an_arc_is_the_closed_form(m):
    """Review: under a tip moment of two roll-ups (4 pi EI/L) the exact solver's compliance was
    5.3e-8 off (central differences of the shooting map), with no note: the complex-step
    Jacobian and the polished root loads give it to the integration's rounding."""
    L, EI = 0.8, 1.7
    scene = {
        "flexure": [{"name": "beam", "length": L, "EI": EI}],
        "load": [{"point": "beam.tip", "force": [0.0, 0.0], "moment": m * EI / L}],
    }
    r = flexgen.solve(scene, model="exact")
    c = np.array(r.points["beam.tip"].compliance)
    ref = arc_compliance(m, L, EI)
    # the honesty suites' allowance for the reference's own error (REFERENCE_NOISE) rests on
    # this: measured 4.9e-15 (m = 1) to 3.2e-13 (m = 4 pi)
    assert np.abs(c - ref).max() <= REFERENCE_NOISE * np.abs(ref).max(), (c, ref)
    assert r.warnings == [] and r.notes == []


@pytest.mark.parametrize(
    "model",
    [FEMModel(0.7, 1.3, 1), FEMModel(0.7, 1.3, 9), PRBModel(0.7, 1.3)],
    ids=["fem1", "fem9", "prb"],
)
def test_tip_poses_repeat_the_cores_tip_pose(model):
    """fem's and prb's batched tip_poses (NumPy: the frame poses behind every answer's stress)
    are the pose the core's fg_flexure_tip gives, row for row: the two spellings of one formula
    stay in step."""
    Q = np.random.default_rng(3).uniform(-1.5, 1.5, (6, model.n_dof))
    batched = model.tip_poses(Q)
    for q, pose in zip(Q, batched):
        assert np.allclose(pose, model.tip(q).pose, rtol=0, atol=1e-14)


@pytest.mark.parametrize("tension", [1.0, 0.0])
def test_a_tendon_segment_of_zero_length_is_refused_by_exact_as_by_the_chain_models(tension):
    """A segment between two bodies that starts at zero length has no direction: the chain
    models refuse the scene (no equilibrium of the unloaded scene), and so does exact (review:
    it pulled along the rounding of the tip's position and answered, exit 0). Without tension
    the tendon is no tendon, and both solve."""
    scene = flexgen.scene_from_dict(
        {
            "base": {"points": {"p": [1.0, 0.0]}},
            "flexure": [{"name": "a", "length": 1.0, "EI": 1.0}],
            "tendon": [{"tension": tension, "route": ["base.p", "a.tip"]}],
        }
    )
    for model in ("scm", "exact"):
        r = flexgen.solve(scene, model=model)
        assert r.converged is (tension == 0.0), (model, r.reason)
        if tension:
            assert "'base.p' -> 'a.tip' has zero length" in r.reason, r.reason
