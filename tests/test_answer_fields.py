"""What the core computes with every answer besides the equilibrium, against independent
Python: the stability margin (generalized eigenvalue of the stiffness against the elastic
Hessian), each flexure's bend (max |phi| along it, from NumPy's Legendre integrals), the kernel
at equilibrium, the compliance ellipses (NumPy's eigen-decomposition) and the n-element chain's
and pseudo-rigid body's tip kinematics (written out here from their definitions)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.polynomial import legendre

import flexgen
from flexgen.api import override
from flexgen.models.fem import FEMModel
from flexgen.models.prb import PRBModel
from flexgen.models.registry import build_models
from flexgen.scene import scene_from_dict

EXAMPLES = sorted(Path(__file__).resolve().parents[1].glob("examples/*.toml"))


def legendre_bend(q: np.ndarray, samples: int = 65) -> float:
    """max |phi(sigma)|, phi = sum q_n int_0^sigma P_n(2t - 1) dt, by NumPy's legint: the
    largest of the samples, then SciPy's bounded minimizer of -|phi| between its neighbours."""
    from scipy.optimize import minimize_scalar

    def phi(sigma):
        out = np.zeros_like(np.asarray(sigma, dtype=float))
        for n, qn in enumerate(q):
            c = np.zeros(n + 1)
            c[n] = 1.0
            out = out + qn * legendre.legval(2 * sigma - 1, legendre.legint(c, lbnd=-1) / 2)
        return out

    sigma = np.linspace(0.0, 1.0, samples)
    values = np.abs(phi(sigma))
    i = int(np.argmax(values))
    lo, hi = sigma[max(i - 1, 0)], sigma[min(i + 1, samples - 1)]
    best = minimize_scalar(
        lambda s: -abs(float(phi(s))), bounds=(lo, hi), method="bounded", options={"xatol": 1e-12}
    )
    return max(float(values[i]), -float(best.fun))


def reference_bend(kind: str, q: np.ndarray) -> float:
    if kind == "fem":
        return float(np.max(np.abs(np.cumsum(q)), initial=0.0))
    if kind == "prb":
        return abs(float(q[0]))
    return legendre_bend(q)


@pytest.mark.parametrize("model", ["scm", "fem", "prb"])
@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_margin_bend_and_ellipses_against_numpy(path, model):
    scene = override(flexgen.load_scene(path), model)
    if any(f.model.kind == "exact" for f in scene.flexures):
        pytest.skip("exact scene")
    r = flexgen.solve(scene)
    if not r.converged:
        pytest.skip(r.reason)
    models = build_models(scene)
    # margin: smallest eigenvalue of L^-1 K L^-T, hess U = L L^T
    KU = np.zeros_like(r.stiffness)
    start = 0
    for f in scene.flexures:
        k = models[f.name].n_dof
        KU[start : start + k, start : start + k] = models[f.name].energy_hessian(
            np.asarray(r.q[f.name])
        )
        start += k
    Li = np.linalg.inv(np.linalg.cholesky(KU))
    margin = np.linalg.eigvalsh(Li @ r.stiffness @ Li.T)[0]
    assert r.stability_margin == pytest.approx(margin, rel=1e-9, abs=1e-12)
    assert (r.stability_margin > 0) == r.stable
    for f in scene.flexures:
        kind = "scm" if model == "scm" else model
        assert r.bend[f.name] == pytest.approx(
            reference_bend(kind, np.asarray(r.q[f.name])), rel=1e-12, abs=1e-15
        )
    for p in r.points.values():
        C = np.asarray(p.compliance)
        w, V = np.linalg.eigh(0.5 * (C + C.T))
        assert p.ellipse["major"] == pytest.approx(w[1], rel=1e-9, abs=1e-300)
        assert p.ellipse["minor"] == pytest.approx(w[0], rel=1e-6, abs=1e-12 * abs(w[1]))
        if w[1] - w[0] > 1e-9 * abs(w[1]):
            axis = math.atan2(V[1, 1], V[0, 1])
            d = (p.ellipse["angle"] - axis) % math.pi
            assert min(d, math.pi - d) < 1e-7
            assert -math.pi / 2 < p.ellipse["angle"] <= math.pi / 2


def test_kernel_at_equilibrium_names_the_switch():
    """scm3 "auto" tries the local kernel, then the polynomial one, then the Gauss kernel: the
    local kernel evaluates the finger at equilibrium; the polynomial kernel an S-shaped flexure
    (tip force 8 EI/L^2 across it, moment -4 EI/L: a curvature q1 of -3.4, wigglier than the
    local kernel's 9 nodes certify, a bend of 39 degrees), with no note; the Gauss kernel,
    named with a note and no warning, the rectangular elastica loaded to 117 degrees (past the
    polynomial kernel's 90 and a profile the local kernel does not certify)."""
    path = Path(__file__).resolve().parents[1] / "examples" / "rectangular_elastica.toml"
    scene = flexgen.load_scene(path)
    load = scene.loads[0]
    from dataclasses import replace

    harder = replace(scene, loads=(replace(load, force=(load.force[0] * 1.3, load.force[1])),))
    r = flexgen.solve(harder)
    assert r.converged and r.bend["beam"] > math.pi / 2
    assert r.kernel == {"beam": "gauss"} and not r.warnings
    assert any("switched to the Gauss kernel scm3_gauss25" in w for w in r.notes)
    finger = flexgen.solve(path.with_name("two_link_finger.toml"))
    assert set(finger.kernel.values()) == {"local"}
    s_shape = scene_from_dict(
        {
            "name": "S",
            "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
            "load": [{"point": "beam.tip", "force": [0.0, 8.0], "moment": -4.0}],
        }
    )
    r = flexgen.solve(s_shape)
    assert r.converged and r.kernel == {"beam": "poly"} and not r.warnings and not r.notes


def fem_tip_reference(L: float, q: np.ndarray):
    """The n-element chain from its definition: segments h/2, h, ..., h, h/2, joint i turning
    every segment after it by q_i; derivatives by the chain rule, written with loops."""
    n = len(q)
    h = L / n
    seg = np.full(n + 1, h)
    seg[0] = seg[-1] = h / 2
    phi = np.concatenate(([0.0], np.cumsum(q)))
    x, y = float(np.sum(seg * np.cos(phi))), float(np.sum(seg * np.sin(phi)))
    J = np.zeros((3, n))
    H = np.zeros((3, n, n))
    for i in range(n):
        for k in range(i + 1, n + 1):  # segments turned by joint i
            J[0, i] -= seg[k] * math.sin(phi[k])
            J[1, i] += seg[k] * math.cos(phi[k])
            for j in range(n):
                if j < k:
                    H[0, i, j] -= seg[k] * math.cos(phi[k])
                    H[1, i, j] -= seg[k] * math.sin(phi[k])
        J[2, i] = 1.0
    return np.array([x, y, phi[-1]]), J, H


def test_fem_and_prb_tips_from_the_core_match_their_definitions():
    rng = np.random.default_rng(3)
    for n in (1, 2, 5, 16):
        q = rng.normal(scale=0.3, size=n)
        tip = FEMModel(0.7, 2.0, n).tip(q)
        pose, J, H = fem_tip_reference(0.7, q)
        np.testing.assert_allclose(tip.pose, pose, rtol=0, atol=1e-15)
        np.testing.assert_allclose(tip.J, J, rtol=0, atol=1e-15)
        np.testing.assert_allclose(tip.H, H, rtol=0, atol=1e-15)
    m = PRBModel(0.5, 1.0, gamma=0.85)
    a = 0.7
    r = 0.85 * 0.5
    tip = m.tip(np.array([a]))
    np.testing.assert_allclose(
        tip.pose, [0.15 * 0.5 + r * math.cos(a), r * math.sin(a), a], rtol=0, atol=1e-15
    )
    np.testing.assert_allclose(tip.J[:, 0], [-r * math.sin(a), r * math.cos(a), 1.0], atol=1e-15)
    np.testing.assert_allclose(
        tip.H[:, 0, 0], [-r * math.cos(a), -r * math.sin(a), 0.0], atol=1e-15
    )


def test_run_leaves_the_answer_of_solve_in_the_workspace():
    """Solver.run (the loop path without a Result) finds what Solver.solve reports."""
    s = flexgen.Solver(EXAMPLES[0].with_name("two_link_finger.toml"))
    loads = s.problem.loads * 1.1
    r = s.solve(loads=loads)
    from flexgen import core

    assert s.run(loads=loads) == core.SOLVED
    ws = s.workspace
    for i, ref in enumerate(s.outputs):
        assert ws.pose[i].tolist() == r.points[ref].pose
        assert ws.compliance[i].tolist() == r.points[ref].compliance3
        assert ws.ellipse[i].tolist() == [
            r.points[ref].ellipse[k] for k in ("major", "minor", "angle")
        ]
    assert np.concatenate([r.q[n] for n in r.q]).tolist() == ws.q.tolist()
    assert bool(ws.answer.stable) == r.stable and ws.answer.iterations == r.iterations


def test_a_prepared_answer_is_a_plain_result_in_every_way_that_shows():
    """Solver.solve builds the bulky fields on first access (LazyResult); the values, equality,
    JSON, pickling and copies are those of a plain Result, and the next solve does not change an
    earlier answer."""
    import copy
    import pickle
    from dataclasses import asdict, fields

    from flexgen.result import Result

    s = flexgen.Solver(EXAMPLES[0].with_name("two_link_finger.toml"))
    first = s.solve()
    json_first = first.to_json()
    s.solve(loads=s.problem.loads * 2.0)  # overwrites the workspace
    assert first.to_json() == json_first  # built from the answer's own copy
    plain = Result(**{f.name: getattr(first, f.name) for f in fields(Result)})
    assert first == plain and plain == first
    again = pickle.loads(pickle.dumps(first))
    assert type(again) is Result and again == plain
    assert copy.deepcopy(first) == plain
    assert asdict(first)["q"] == first.q and set(first.bend) == {"proximal", "distal"}
    assert first.stiffness.shape == (6, 6)


@pytest.mark.parametrize("case", ["spread", "clustered", "repeated", "near_singular", "indefinite"])
def test_margin_of_any_stiffness_against_numpy(case):
    """fg_margin on stiffnesses built with known spectra: positive definite ones (where it
    iterates: well spread, clustered within 1e-3, a repeated smallest eigenvalue, one near 0)
    and indefinite ones (where it decomposes), against NumPy's eigvalsh."""
    from flexgen import core

    solver = flexgen.Solver(EXAMPLES[-1])  # any scene: its elastic stiffness D scales K
    n = solver.workspace.q.size
    d = np.sqrt(np.asarray(solver.problem.stiffness, dtype=float))
    spectra = {
        "spread": np.geomspace(0.05, 40.0, n),
        "clustered": 0.3 + 1e-3 * np.arange(n),
        "repeated": np.r_[0.2, 0.2, np.linspace(1.0, 3.0, n - 2)],
        "near_singular": np.r_[1e-9, np.linspace(0.5, 2.0, n - 1)],
        "indefinite": np.r_[-0.4, np.linspace(0.1, 2.0, n - 1)],
    }
    rng = np.random.default_rng(7)
    for _ in range(20):
        V, _ = np.linalg.qr(rng.normal(size=(n, n)))
        A = V @ np.diag(spectra[case]) @ V.T
        K = np.ascontiguousarray(np.outer(d, d) * (A + A.T) / 2)
        ws = solver.workspace
        got = core.lib.fg_margin(
            solver.problem.struct,
            core.ffi.cast("double *", K.ctypes.data),
            ws.work_ptr,
            ws.iwork_ptr,
        )
        want = np.linalg.eigvalsh(A)[0]
        assert got == pytest.approx(want, rel=1e-9, abs=1e-12), case


def test_margin_above_agrees_with_the_margin():
    """fg_margin_above (one Cholesky factorization of K - t D) says whether fg_margin exceeds
    t, on stiffnesses of known spectra around the threshold the validity check uses."""
    from flexgen import core
    from flexgen.validity import NEAR_SINGULAR

    solver = flexgen.Solver(EXAMPLES[-1])
    n = solver.workspace.q.size
    d = np.sqrt(np.asarray(solver.problem.stiffness, dtype=float))
    ws = solver.workspace
    rng = np.random.default_rng(11)
    ptr = core.double_ptr
    seen = set()
    for lowest in (-0.3, 0.0, 0.01, NEAR_SINGULAR * 0.99, NEAR_SINGULAR * 1.01, 0.2, 1.0):
        V, _ = np.linalg.qr(rng.normal(size=(n, n)))
        A = V @ np.diag(np.r_[lowest, np.linspace(1.0, 2.0, n - 1)]) @ V.T
        K = np.ascontiguousarray(np.outer(d, d) * (A + A.T) / 2)
        above = bool(
            core.lib.fg_margin_above(
                solver.problem.struct, ptr(K), NEAR_SINGULAR, ws.work_ptr, ws.iwork_ptr
            )
        )
        assert above == (lowest > NEAR_SINGULAR), lowest
        seen.add(above)
    assert seen == {True, False}
