"""The fewest modes: flexgen.select, solve(tolerance=...), [model] tolerance, `flexgen select`.

The honesty test runs the seeded suite of benchmarks/selection.py (flexgen_tools.honesty: 65
scenes, 4 tolerances; about 10 s) against the exact elastica."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from flexgen import select, solve
from flexgen.cli import main
from flexgen.scene import SceneError, load_scene, scene_from_dict
from flexgen.solver import solve_models
from flexgen_tools import honesty as H

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
TOLS = (1e-2, 1e-4, 1e-6, 1e-8)


def cantilever(force=(0.0, -2.0), moment=0.0, **model):
    return scene_from_dict(
        {
            "name": "cantilever",
            "model": {"kind": "scm", **model},
            "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
            "load": [{"point": "beam.tip", "force": list(force), "moment": moment}],
        }
    )


# -- honesty (the requirement of issue 4, section 3) ----------------------------------------------


@pytest.fixture(scope="module")
def honesty():
    scenes = []
    for seed in range(5):
        scenes += [(f"s{seed} {label}", sc) for label, sc in H.honesty_suite(seed)]
    return scenes, H.honesty_cases(scenes, TOLS)


def test_suite_has_every_kind_of_scene(honesty):
    scenes, cases = honesty
    labels = " ".join(label for label, _ in scenes)
    for kind in ("(force)", "(moment)", "(both)", "chain", "tendon"):
        assert kind in labels
    # every scene was solved by the exact reference (none silently dropped)
    assert len(cases) == len(scenes) * len(TOLS)


def test_estimate_is_honest_for_every_tolerance(honesty):
    _, cases = honesty
    rates = H.honesty_rates(cases)
    for tol in TOLS:
        r = rates[tol]
        assert r["covered"] >= 0.95, (tol, r)  # true error <= estimate
        assert r["worst_ratio"] <= 10.0, (tol, r)  # never more than 10x the estimate
        assert r["true_within_tol"] >= 0.95, (tol, r)


def test_choice_is_the_cheapest(honesty):
    """At least 90 % of the choices are the cheapest that meets T in truth; 85 % at 1e-8,
    where the richest models' own estimate (scm8 against scm6, as every answer's) is close to
    T: measured 0.889 there, 0.938 at 1e-4, 1.0 at 1e-2, and T reached in 83 % of the cases at
    1e-8 (the price of stating scm8's error as scm6's, not extrapolated by the observed
    contraction: test_a_tolerance_past_the_modes_convergence_is_not_claimed)"""
    _, cases = honesty
    rates = H.honesty_rates(cases)
    for tol in TOLS:
        assert rates[tol]["cheapest"] >= (0.85 if tol <= 1e-8 else 0.90), (tol, rates[tol])
        # checked: T reached (at 1e-8: 54 of 65, the rest honestly out of reach)
        assert rates[tol]["checked"] >= (0.8 if tol <= 1e-8 else 0.9) * rates[tol]["cases"]


def test_fewer_modes_for_looser_tolerance(honesty):
    _, cases = honesty
    by_scene = {}
    for c in cases:
        by_scene.setdefault(c.label, {})[c.tol] = sum(c.modes)
    for label, modes in by_scene.items():
        totals = [modes[t] for t in TOLS]
        assert totals == sorted(totals), label


# -- the Result contract --------------------------------------------------------------------------


def test_plain_solve_has_no_selection_fields():
    """Without a tolerance: the answer's own error estimate (flexgen.estimate), but no
    per-flexure kernel or estimate (those are the selection's)."""
    res = solve(cantilever(modes=3))
    d = json.loads(res.to_json())
    assert res.tolerance is None and d["error_estimate"] == res.error_estimate > 0
    assert d["model"]["beam"] == {"kind": "scm", "modes": 3}


def test_tolerance_adds_modes_and_estimates_to_json():
    res = solve(cantilever(), tolerance=1e-6)
    d = json.loads(res.to_json())
    info = d["model"]["beam"]
    assert isinstance(info["modes"], int) and 1 <= info["modes"] <= 8
    assert info["kernel"] in ("local", "poly", "gauss")
    assert 0 <= info["error_estimate"] <= 1e-6
    assert 0 < d["error_estimate"] <= 1e-6
    assert res.tolerance == 1e-6
    # the modes are the fewest: exact errors 1.0e-5 (3 modes), 2.2e-6 (4), 7.5e-8 (5)
    assert info["modes"] == 5


def test_scene_tolerance_triggers_selection(tmp_path):
    text = (EXAMPLES / "two_link_finger.toml").read_text().replace("modes = 3", "tolerance = 1e-4")
    path = tmp_path / "finger.toml"
    path.write_text(text)
    scene = load_scene(path)
    assert select.scene_tolerance(scene) == 1e-4
    d = json.loads(solve(scene).to_json())
    assert d["error_estimate"] <= 1e-4
    assert set(d["model"]) == {"proximal", "distal"}
    assert all("error_estimate" in v for v in d["model"].values())
    import flexgen

    assert flexgen.solve(path).error_estimate == pytest.approx(d["error_estimate"])


def test_solve_with_tolerance_and_models_is_an_error():
    from flexgen.models.scm import SCMModel

    with pytest.raises(ValueError):
        solve(cantilever(), models={"beam": SCMModel(1.0, 1.0, 3)}, tolerance=1e-4)


@pytest.mark.parametrize("bad", [0.0, -1e-3, math.nan, math.inf])
def test_bad_tolerance(bad):
    with pytest.raises(SceneError):
        select.solve_to_tolerance(cantilever(), bad)


def test_tolerance_needs_scm_flexures():
    with pytest.raises(SceneError, match="kind 'scm'"):
        select.solve_to_tolerance(cantilever(kind="fem"), 1e-3)


def test_out_of_reach_says_so():
    # the rectangular elastica bends to 90 degrees at the tip: past the polynomial kernels' range,
    # so at most 8 Gauss modes, whose error (~8e-9) is above 1e-9
    sel = select.select_models(load_scene(EXAMPLES / "rectangular_elastica.toml"), 1e-9)
    assert not sel.reached
    assert sel.error_estimate > 1e-9
    assert sel.choices["beam"].modes == 8 and sel.choices["beam"].kernel == "gauss"
    assert any("out of reach" in w for w in sel.result.warnings)
    assert "out of reach" in sel.message


def test_positional_tolerance_does_not_clash_with_residual_tol():
    res = select.solve_to_tolerance(cantilever(), 1e-4, tol=1e-11)
    assert res.converged and res.error_estimate <= 1e-4


# -- warm start -----------------------------------------------------------------------------------


def test_warm_start_matches_cold_solve_with_fewer_iterations():
    from flexgen.models.scm import SCMModel

    sc = load_scene(EXAMPLES / "two_link_finger.toml")
    rich = solve_models(sc, {f.name: SCMModel(f.length, f.EI, 8, "poly") for f in sc.flexures})
    models = lambda: {f.name: SCMModel(f.length, f.EI, 4) for f in sc.flexures}  # noqa: E731
    cold = solve_models(sc, models())
    warm = solve_models(sc, models(), q0=rich.q)  # 8 coefficients truncated to 4
    assert warm.converged and warm.iterations < cold.iterations
    for name in cold.q:
        np.testing.assert_allclose(warm.q[name], cold.q[name], atol=1e-10)
    short = solve_models(
        sc, {f.name: SCMModel(f.length, f.EI, 8, "poly") for f in sc.flexures}, q0=cold.q
    )  # 4 coefficients padded to 8
    for name in rich.q:
        np.testing.assert_allclose(short.q[name], rich.q[name], atol=1e-10)


def test_bad_warm_start_falls_back_to_continuation():
    sc = cantilever(force=(0.0, -2.0), modes=3)
    cold = solve(sc)
    wild = solve(sc, q0={"beam": [40.0, -30.0, 25.0]})
    np.testing.assert_allclose(wild.q["beam"], cold.q["beam"], atol=1e-10)
    assert wild.stable


# -- the error measure ----------------------------------------------------------------------------


def test_error_components_are_relative_and_wrap_angles():
    sc = cantilever()
    C = np.array([[2.0, 0.0], [0.0, 1.0]])
    ref = {"beam.tip": (np.array([1.0, 0.0, math.pi - 1e-3]), C)}
    got = {"beam.tip": (np.array([1.0, 0.5, -math.pi + 1e-3]), C + np.array([[0.2, 0], [0, 0]]))}
    e = select.error_components(got, ref, select.length_scales(sc, ref))
    np.testing.assert_allclose(e, [0.5, 2e-3, 0.1], rtol=1e-9)
    assert select.error(got, ref, {"beam.tip": 1.0}) == pytest.approx(0.5)
    assert select.error(None, ref, {"beam.tip": 1.0}) == math.inf


def test_length_scale_is_the_flexures_on_the_path():
    sc = load_scene(EXAMPLES / "two_link_finger.toml")
    s = select.length_scales(sc, ["middle.pad", "fingertip.pad", "base.r0"])
    assert s == pytest.approx({"middle.pad": 0.020, "fingertip.pad": 0.035, "base.r0": 0.020})


# -- the command ----------------------------------------------------------------------------------


def test_cli_select_prints_choice_and_cost(capsys):
    rc = main(["select", str(EXAMPLES / "two_link_finger.toml"), "--tol", "1e-6", "--repeat", "1"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "proximal" in out and "distal" in out
    assert "us per solve" in out and "error estimate of the whole answer" in out
    assert "prepared solver" in out


def test_cli_select_json(capsys):
    rc = main(["select", str(EXAMPLES / "arc_moment.toml"), "--tol", "1e-4", "--json"])
    d = json.loads(capsys.readouterr().out)
    assert rc == 0 and d["error_estimate"] <= 1e-4 and d["model"]["beam"]["modes"] == 4


@pytest.mark.parametrize("tol", ["0", "-1e-3", "nan", "abc"])
def test_cli_select_bad_tolerance(tol, capsys):
    rc = main(["select", str(EXAMPLES / "arc_moment.toml"), "--tol", tol])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and "--tol" in err


def test_cli_select_unreachable_exits_1(capsys):
    rc = main(
        ["select", str(EXAMPLES / "rectangular_elastica.toml"), "--tol", "1e-9", "--repeat", "0"]
    )
    cap = capsys.readouterr()
    assert rc == 1
    assert "out of reach" in cap.err and "DOES NOT meet" in cap.out


def test_cli_select_missing_scene(capsys, tmp_path):
    rc = main(["select", str(tmp_path / "nope.toml"), "--tol", "1e-3"])
    assert rc == 2 and capsys.readouterr().err.count("\n") == 1


def test_modes_beside_a_scene_tolerance_are_refused(tmp_path):
    """[model] modes = 5 with tolerance = 1e-2 chose 2 modes and dropped the 5 silently: a
    given count is no minimum of the selection, so the scene is refused (one line, exit 2)."""
    text = (EXAMPLES / "two_link_finger.toml").read_text()
    path = tmp_path / "finger.toml"
    path.write_text(text.replace("modes = 3", "modes = 5\ntolerance = 1e-2"))
    with pytest.raises(SceneError, match=r"^model\.modes: a tolerance \(model\.tolerance\) .*5$"):
        load_scene(path)
    path.write_text(
        text.replace("modes = 3", "tolerance = 1e-2").replace(
            'name = "distal"', 'name = "distal"\nmodel = { modes = 4 }'
        )
    )
    with pytest.raises(SceneError, match=r"^flexure\[1\]\.model\.modes: .* not both, got 4$"):
        load_scene(path)


def test_a_tolerance_past_the_modes_convergence_is_not_claimed():
    """Found by review: one flexure under a mostly axial tension (68.5 EI/L^2 at 0.6 rad, a
    moment of -14.7 EI/L, at a point just off the tip): `--tol 1e-3` chose 8 modes and claimed
    3.8e-4 while the pose was off by 3.5e-4 against an estimate of 4.7e-6 (74x) and the
    compliance by 5.0e-3 (13x): the richest model's error was the observed contraction
    applied once more to a series that had not converged by 8 modes. Stated as scm6's (as
    every answer's estimate of scm8 is), the answer's errors against the exact elastica are
    within its estimates, and T is said to be out of reach."""
    import math as m

    scene = scene_from_dict(
        {
            "flexure": [{"name": "b", "length": 1.0, "EI": 1.0}],
            "link": [{"name": "l", "parent": "b", "points": {"p": [0.043, -0.0996]}}],
            "load": [
                {"point": "l.p", "force": [68.5 * m.cos(0.6), 68.5 * m.sin(0.6)], "moment": -14.7}
            ],
        }
    )
    exact = solve(scene, model="exact").points["l.p"]
    r = select.solve_to_tolerance(scene, 1e-3)
    point = r.points["l.p"]
    pose = max(
        m.hypot(point.pose[0] - exact.pose[0], point.pose[1] - exact.pose[1]),
        abs(m.remainder(point.pose[2] - exact.pose[2], 2 * m.pi)),
    )
    C, C_exact = np.array(point.compliance), np.array(exact.compliance)
    compliance = np.linalg.norm(C - C_exact, 2) / np.linalg.norm(C_exact, 2)
    assert pose <= point.error_estimate["pose"], (pose, point.error_estimate)
    assert compliance <= point.error_estimate["compliance"], (compliance, point.error_estimate)
    assert any("out of reach" in w for w in r.warnings), r.warnings


def test_a_selection_keeps_the_result_of_its_answer_only(monkeypatch):
    # review: every solved mode choice kept its Result, and each Result its solver's
    # workspace and a copy of the stiffness: a 50-flexure chain with a tolerance needed 4.4 GB
    problems = []

    class Recorded(select._Problem):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            problems.append(self)

    monkeypatch.setattr(select, "_Problem", Recorded)
    scene = load_scene(EXAMPLES / "two_link_finger.toml")
    sel = select.select_models(scene, 1e-6)
    (pb,) = problems
    # no Result kept in the cache: the selection owns the one of its answer (and another
    # tolerance from the same table makes its own: test_selections_from_one_table_...)
    assert len(pb.cache) >= 4 and not [s for s in pb.cache.values() if s.made is not None]
    (chosen,) = [s for s in pb.cache.values() if s.modes == tuple(sel.modes.values())]
    # the Result made again is the answer of that choice as it was solved
    again = solve_models(scene, pb.models(chosen.modes), q0=chosen.q0, settings=pb.settings)
    for name, point in again.points.items():
        assert sel.result.points[name].pose == point.pose
        assert sel.result.points[name].compliance == point.compliance
    assert chosen.q == again.q


def test_a_tolerance_given_to_solve_counts_eight_modes_a_flexure_against_the_limit(tmp_path):
    # review: `flexgen solve big.toml --tol 1e-3` (and solve(..., tolerance=)) skipped the
    # coordinate limit a [model] tolerance meets, and ran out of memory selecting
    flexures = [{"name": f"f{i}", "length": 0.1, "EI": 1.0} for i in range(257)]
    scene = scene_from_dict({"flexure": flexures})
    with pytest.raises(SceneError, match=r"^model: the scene's models have 2056 coordinates"):
        solve(scene, tolerance=1e-3)
    with pytest.raises(SceneError, match=r"^model: the scene's models have 2056 coordinates"):
        select.select_models(scene, 1e-3)  # flexgen select (review: it ran on, unbounded)


def test_a_selections_answer_carries_the_validity_warnings_of_solve():
    # review: 0.7 % below the Euler load, `flexgen solve --tol` warned that the compliance
    # amplifies model error 142x; `flexgen select` and solve_to_tolerance said nothing
    scene = cantilever(force=(-2.45, 0.0))
    near = [w for w in select.select_models(scene, 1e-4).result.warnings if "near a critical" in w]
    assert len(near) == 1
    assert select.solve_to_tolerance(scene, 1e-4).warnings.count(near[0]) == 1
    assert solve(scene, tolerance=1e-4).warnings.count(near[0]) == 1


@pytest.mark.parametrize(
    "force, moment", [([0.0, -2.0], 1.0), ([2.0, 1.0], -1.0), ([1.0, -3.0], 0.0)]
)
def test_a_tolerance_answer_states_the_error_of_its_3x3_compliance(force, moment):
    """Review: a tolerance's compliance estimate measured the 2x2 position block only, so the
    angle row and column of compliance3 could pass it (a cantilever under (0, -2) and a moment
    1 at tol 1e-4: 4.7e-6 against a stated 3.75e-6; a chain 38 times its estimate). Against the
    exact elastica's 3x3 tip compliance (variational equations), every answer's compliance
    error is within its estimate and the tolerance."""
    from flexgen.models.exact import tip_compliance

    exact = tip_compliance(1.0, 1.0, force, moment)
    scene = {
        "name": "cantilever",
        "flexure": [{"name": "b", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "b.tip", "force": force, "moment": moment}],
    }
    for tol in (1e-3, 1e-4, 1e-5):
        r = solve(scene_from_dict(scene), tolerance=tol)
        c3 = np.array(r.points["b.tip"].compliance3)
        err = np.linalg.norm(c3 - exact, 2) / np.linalg.norm(exact, 2)  # L_p = 1: D = I
        stated = r.points["b.tip"].error_estimate["compliance"]
        assert err <= stated <= tol, (tol, err, stated)


def test_near_a_critical_load_the_selection_states_its_compliance_error():
    """Review: a column at 0.9999 of its Euler load, under --tol 3e-7, claimed 1.07e-7 while its
    compliance was 7.6e-7 off the exact elastica's: Newton's last step, linearized in every
    model compared, left each compliance off by its residual over the margin (~1/2700), which
    the comparison of the models cannot see. The selection's solves evaluate every step."""
    scene = scene_from_dict(
        {
            "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
            "load": [{"point": "beam.tip", "force": [-2.4671535, -1e-5]}],
        }
    )
    answer = solve(scene, tolerance=3e-7)
    exact = solve(scene, model="exact")
    C = np.array(answer.points["beam.tip"].compliance)[:2, :2]
    C_exact = np.array(exact.points["beam.tip"].compliance)[:2, :2]
    true = np.linalg.norm(C - C_exact, 2) / np.linalg.norm(C_exact, 2)
    assert any("near a critical load" in w for w in answer.warnings)
    assert answer.error_estimate <= 3e-7  # met, as claimed ...
    assert true <= answer.error_estimate  # ... and true (was 7.6e-7 against 1.07e-7)


def test_a_tolerance_is_not_claimed_past_the_certified_bend(tmp_path, capsys):
    """Review: a tip moment of 22 EI/L (a 1261 deg roll-up) printed "meets 0.1" and exit 0,
    while the answer said no accuracy is claimed past 180 deg and its compliance was 28 % off
    the exact elastica's (estimate 6.9 %)."""
    path = tmp_path / "roll.toml"
    path.write_text(
        'name = "roll-up"\n[[flexure]]\nname = "beam"\nlength = 1.0\nEI = 1.0\n'
        '[[load]]\npoint = "beam.tip"\nforce = [0.0, 0.0]\nmoment = 22.0\n'
    )
    assert main(["select", str(path), "--tol", "0.1", "--repeat", "0"]) == 1
    out, err = capsys.readouterr()
    assert "(below 0.1, but not claimed)" in out and "meets" not in out
    assert err.strip() == (
        "flexgen: tolerance 0.1 is not claimed: flexure 'beam' is bent 1261 deg, past the 180 "
        "deg to which the error estimate is certified"
    )
    answer = solve(path, tolerance=0.1)  # flexgen solve --tol: the answer, with the warning
    assert answer.converged and err.strip().removeprefix("flexgen: ") in answer.warnings


def test_selections_from_one_table_do_not_share_their_result():
    """Review: the cached Result of a choice was written by every selection from one table
    (select_from_table): a second tolerance's warning and tolerance landed on the first's."""
    path = Path(__file__).resolve().parents[1] / "examples" / "rectangular_elastica.toml"
    table = select.estimate_table(load_scene(path))
    fine, coarse = select.select_from_table(table, 1e-13), select.select_from_table(table, 1e-2)
    assert fine.result is not coarse.result
    assert (fine.result.tolerance, coarse.result.tolerance) == (1e-13, 1e-2)
    assert sum("is out of reach" in w for w in fine.result.warnings) == 1
    assert not any("is out of reach" in w for w in coarse.result.warnings)
    again = select.select_from_table(table, 1e-13)
    assert again.result.warnings == fine.result.warnings  # nothing piled up
