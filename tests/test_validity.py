"""flexgen.validity: every solve result (``flexgen solve``, ``flexgen.solve``) carries the
validity warnings of its models; what it claims is its error estimate (flexgen.estimate), no
longer the CLAIMS table's error class."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

import flexgen
from flexgen import validity as V
from flexgen_tools import stability as S

ROOT = Path(__file__).resolve().parents[1]
FINGER = ROOT / "examples" / "two_link_finger.toml"
CONTRACT_KEYS = {
    "scene",
    "converged",
    "stable",
    "iterations",
    "model",
    "q",
    "points",
    "error_estimate",
    "flexures",
    "stiffness",
    "warnings",
    "notes",
}


def cantilever_toml(
    tmp_path: Path, fx: float, fy: float, kind: str = "scm", kernel: str = "auto"
) -> Path:
    p = tmp_path / f"cantilever_{kind}.toml"
    p.write_text(f"""name = "cantilever"
[model]
kind = "{kind}"
kernel = "{kernel}"
[[flexure]]
name = "beam"
length = 1.0
EI = 1.0
[[load]]
point = "beam.tip"
force = [{fx!r}, {fy!r}]
[output]
points = ["beam.tip"]
""")
    return p


def solve_json(path: Path, *extra: str) -> dict:
    out = subprocess.run(
        [sys.executable, "-m", "flexgen", "solve", str(path), "--json", *extra],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_prb_past_64_deg_warns_in_solve_json(tmp_path):
    """A prb cantilever under a tip force of 8 EI/L^2 turns its pin past 64 deg."""
    data = solve_json(cantilever_toml(tmp_path, 0.0, -8.0, kind="prb"))
    assert set(data) == CONTRACT_KEYS  # the JSON contract is unchanged
    assert data["converged"]
    assert abs(data["q"]["beam"][0]) > math.radians(64)
    hits = [w for w in data["warnings"] if "64 deg" in w]
    assert len(hits) == 1
    assert "'beam'" in hits[0] and "prb" in hits[0] and "pseudo-rigid-body" in hits[0]


def test_prb_within_its_validity_has_no_warning(tmp_path):
    r = flexgen.solve(cantilever_toml(tmp_path, 0.0, -2.0, kind="prb"))
    assert r.converged and abs(r.q["beam"][0]) < math.radians(64)
    assert r.warnings == []
    assert not hasattr(r, "error_class")
    assert r.error_estimate is not None and 0 < r.error_estimate < 1


def test_finger_inside_every_band_has_no_warning():
    r = flexgen.solve(FINGER)
    assert r.converged and r.stable
    assert r.warnings == []
    # the estimate, in the JSON too (the error class is gone)
    assert 0 < r.error_estimate < 1e-3
    data = solve_json(FINGER)
    assert data["warnings"] == [] and set(data) == CONTRACT_KEYS
    assert data["error_estimate"] == pytest.approx(r.error_estimate)
    assert "error_class" not in r.to_json()


def test_prb_outside_its_load_case_warns():
    r = flexgen.solve(FINGER, model="prb")
    assert r.converged
    hits = [w for w in r.warnings if "pseudo-rigid-body" in w]
    assert len(hits) == 1 and "'proximal'" in hits[0] and "'distal'" in hits[0]
    assert r.error_estimate is not None and r.error_estimate > 0.1  # prb is far off here


def test_poly_past_range_with_auto_warns_once(tmp_path):
    """kernel auto: the switch to the Gauss kernel, within its certified range, is a note, not a
    warning (the answer keeps its accuracy); validity adds no second message."""
    path = cantilever_toml(tmp_path, -8.0, -8.0)  # bends the tip far past 90 deg
    r = flexgen.solve(path)
    assert r.converged
    assert r.bend["beam"] > math.pi / 2
    assert not [w for w in r.warnings if "polynomial kernel" in w]
    poly = [n for n in r.notes if "polynomial kernel" in n]
    assert len(poly) == 1 and "switched to the Gauss kernel" in poly[0]
    assert not [w for w in r.warnings if "Gauss kernel" in w and "certified" in w]


def test_near_buckling_warns(tmp_path):
    """An axial load at 97 % of the Euler load: straight, stable, 3 % from singular."""
    P = math.pi**2 / 4
    for kind in ("scm", "fem"):
        r = flexgen.solve(cantilever_toml(tmp_path, -0.97 * P, 0.0, kind=kind))
        assert r.converged and r.stable
        hits = [w for w in r.warnings if "near a critical load" in w]
        assert len(hits) == 1 and "'beam.tip'" in hits[0] and "5%" in hits[0]
        e = r.points["beam.tip"].error_estimate
        assert e is not None and e["compliance"] > 10 * e["pose"]
    r = flexgen.solve(cantilever_toml(tmp_path, -0.5 * P, 0.0))
    assert not [w for w in r.warnings if "near a critical load" in w]


def test_margin_is_one_minus_load_over_critical(tmp_path):
    P = math.pi**2 / 4
    scene = flexgen.load_scene(cantilever_toml(tmp_path, -0.6 * P, 0.0))
    r = flexgen.solve(scene, modes=5)
    m = V.stiffness_margin(scene, V.models_of(scene, r), r.q)
    assert m == pytest.approx(0.4, abs=1e-6)


def test_load_level_above_the_old_calibration_is_not_a_warning(tmp_path):
    """The CLAIMS table's load-level band no longer says anything: the estimate is the claim
    (a load level of 40, mostly tension, is answered accurately)."""
    r = flexgen.solve(cantilever_toml(tmp_path, 40.0, 5.0))  # mostly tension: converges
    assert r.converged
    assert not any("load level" in w or "calibrated" in w for w in r.warnings)
    # scm3's 3x3 compliance is 3.1 % off the exact elastica's here (its rotational part: the
    # tension's boundary layer at the root; the 2x2 block 0.6 %), which the estimate covers
    assert r.error_estimate is not None and r.error_estimate < 0.1
    # nor in the stability sweep's assessment (the same assess, no table)
    scene = flexgen.load_scene(cantilever_toml(tmp_path, 40.0, 5.0))
    claim = V.assess(scene, r, V.models_of(scene, r))
    assert not any("load level" in w for w in claim.warnings)


def test_tolerance_result_keeps_its_estimate_as_the_claim():
    r = flexgen.solve(FINGER, tolerance=1e-4)
    assert r.converged and r.error_estimate is not None and r.error_estimate <= 1e-4
    assert r.warnings == []


def test_models_passed_to_solve_are_assessed(tmp_path):
    from flexgen.models.prb import PRBModel

    path = cantilever_toml(tmp_path, 0.0, -8.0)
    r = flexgen.solve(path, models={"beam": PRBModel(1.0, 1.0)})
    assert any("64 deg" in w for w in r.warnings)


def test_exact_and_unconverged_results_are_not_assessed(tmp_path):
    r = flexgen.solve(FINGER, model="exact")
    assert r.warnings == [] and r.error_estimate is None
    assert "error_estimate" not in r.to_json()
    # poly alone past its range: no equilibrium (converged false says so); no estimate either
    r = flexgen.solve(cantilever_toml(tmp_path, -8.0, -8.0, kernel="poly"))
    assert not r.converged and r.error_estimate == math.inf


def test_stability_uses_validity():
    """One implementation: the sweep assesses with flexgen.validity."""
    assert S.assess is V.assess
    scene = S.cantilever(15.0, 135.0)
    r, claim = S.solve_assessed(scene, S.model_def("prb"))
    assert r.converged and any("64 deg" in w for w in claim.warnings)


def _steel_finger(pad_force: float):
    from flexgen.scene import load_scene

    scene = load_scene(ROOT / "examples" / "steel_finger.toml")
    return scene.with_values({"load.0.force.1": -pad_force})


STRAINED = "outer-fibre bending strain"


def test_a_strain_past_any_linear_material_is_a_warning_on_every_path():
    # review: 5000 N on the steel finger bent its proximal strip to 7.7 % strain (no material
    # is linear there) and only the safety factors, absent without strengths, said anything
    import flexgen

    heavy = _steel_finger(5000.0)
    first = flexgen.solve(heavy)
    again = flexgen.solve(heavy)  # the cached solver's calm screen decides this one
    for r in (first, again):
        hits = [w for w in r.warnings if STRAINED in w]
        assert [w.split("'")[1] for w in hits] == ["proximal"], r.warnings
        strain = float(hits[0].split("strain ")[1].split(" ")[0])
        kappa = r.flexures["proximal"].max_curvature
        assert strain == pytest.approx(kappa * 0.5 * 0.0003, rel=1e-3)
    study = flexgen.sweep(heavy, {"load.0.force.1": [-10.0, -5000.0]}, workers=1, estimate=False)
    assert [STRAINED in w for w in study["warnings"]] == [False, True]
    assert not any(STRAINED in w for w in flexgen.solve(_steel_finger(10.0)).warnings)


def test_prb_in_its_fitted_case_by_value_claims_its_accuracy():
    """Review: a tendon without tension, or the tip force given at a link point on the tip,
    made prb's answer "outside its fitted case; no accuracy is claimed", though the answer was
    exactly Howell's case (the same pose and estimate as with the force at the tip)."""
    import flexgen

    scene = {
        "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
        "link": [{"name": "pad", "parent": "beam", "points": {"a": [0.0, 0.1], "p": [0.0, 0.0]}}],
        "base": {"points": {"r": [0.0, 0.1]}},
        "load": [{"point": "beam.tip", "force": [0.0, -1.0]}],
        "output": {"points": ["beam.tip"]},
    }
    plain = flexgen.solve(scene, model="prb")
    slack = flexgen.solve(
        {**scene, "tendon": [{"tension": 0.0, "route": ["base.r", "pad.a"]}]}, model="prb"
    )
    on_tip = flexgen.solve(
        {**scene, "load": [{"point": "pad.p", "force": [0.0, -1.0]}]}, model="prb"
    )
    for answer in (plain, slack, on_tip):
        assert answer.warnings == []
        assert answer.points["beam.tip"].pose == plain.points["beam.tip"].pose
    # a tendon under tension, a force off the tip: outside the case, said
    pulled = flexgen.solve(
        {**scene, "tendon": [{"tension": 0.5, "route": ["base.r", "pad.a"]}]}, model="prb"
    )
    off_tip = flexgen.solve(
        {**scene, "load": [{"point": "pad.a", "force": [0.0, -1.0]}]}, model="prb"
    )
    assert "this scene has a tendon; no accuracy is claimed" in pulled.warnings[0]
    assert "a load at 'pad.a', not at the tip" in off_tip.warnings[0]
