"""flexgen stability (flexgen_tools.stability): no answer is silently wrong (on a grid off the
calibration grid), the rule can fail, poly kernels past their range are flagged, buckling loads
of scm5, the calibration of the CLAIMS block."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from flexgen import validity as V
from flexgen_tools import stability as S
from flexgen_tools.bench import model_def

MODELS = ("cc", "prb", "scm3 poly", "scm3 gauss", "scm4 gauss", "fem8")
# none of these alphas or directions is on the calibration grid (stability.grid)
ALPHAS = (1.5, 4.0, 15.0)
DIRECTIONS = (45.0, 135.0, 200.0, 300.0)


@pytest.fixture(scope="module")
def points():
    return S.sweep(
        ("cantilever", "finger"), [model_def(m) for m in MODELS], ALPHAS, DIRECTIONS, progress=False
    )


def test_no_answer_is_silently_wrong(points):
    silent = [
        (p.model, p.scene, p.alpha, p.direction, p.pose_err, p.claim_pose, p.comp_err, p.claim_comp)
        for p in points
        if p.silent
    ]
    assert not silent
    assert sum(p.reference for p in points) >= 0.9 * len(points)


def test_the_rule_is_exercised(points):
    """Some answers exceed their claims or fail, and every one of them says so."""
    bad = [p for p in points if p.reference and (not p.converged or p.exceeds or p.warned)]
    assert any(p.model == "prb" and p.warned for p in bad)
    assert any(p.model == "scm3 poly" and (not p.converged or p.out_of_range) for p in bad)
    ok = [p for p in points if p.category == "within claim"]
    assert any(p.model == "scm4 gauss" for p in ok) and any(p.model == "fem8" for p in ok)


def test_rule_detects_a_silent_failure(points, monkeypatch):
    """With claims far too tight the same answers count as silent failures: the check can fail."""
    tight = {m: tuple(((1e-14, 1e-14),) * len(S.BANDS) for _ in S.LOAD_BANDS) for m in MODELS}
    monkeypatch.setattr(V, "CLAIMS", tight)
    pts = S.sweep(("cantilever",), [model_def("scm3 gauss")], (1.5,), (45.0,), progress=False)
    assert pts[0].silent and pts[0].category == "SILENT"


def test_poly_kernel_past_range_is_flagged():
    """alpha = 15 at 135 deg bends the cantilever far past 90 deg."""
    scene = S.cantilever(15.0, 135.0)
    r, claim = S.solve_assessed(scene, model_def("scm3 poly"))
    assert (not r.converged) or (claim.out_of_range and claim.warnings)
    r, claim = S.solve_assessed(scene, model_def("scm3 gauss"))
    assert r.converged and claim.beta > math.pi / 2 and not claim.out_of_range


def test_buckling_loads_scm5():
    P = S.buckling_loads(5)
    rel = [abs(P[k] - S.euler(k + 1)) / S.euler(k + 1) for k in range(3)]
    # model-notes.md: the ideal 5-mode model's first load is 8.6e-9 relative
    assert rel[0] == pytest.approx(8.6e-9, rel=0.05)
    assert rel[1] < 1e-3 and rel[2] < 5e-2
    assert rel[0] < rel[1] < rel[2]
    assert all(P[k] > S.euler(k + 1) for k in range(3))  # Rayleigh-Ritz: from above


def test_buckling_solve_agrees():
    (row,) = S.buckling_table((5,))
    assert row["solve_first"] == pytest.approx(S.euler(1), rel=1e-7)
    assert abs(row["solve_first"] - row["loads"][0]) < 1e-8 * row["loads"][0]


def test_calibration_rewrites_the_claims_block(points, tmp_path):
    """The calibration (python -m flexgen_tools.stability --calibrate) turns a sweep into
    classes and writes them between the CLAIMS markers of a copy of flexgen/validity.py."""
    claims = S.calibrate(points)
    assert set(claims) == set(MODELS)
    for table in claims.values():
        assert len(table) == len(S.LOAD_BANDS) and all(len(r) == len(S.BANDS) for r in table)
    copy = tmp_path / "validity.py"
    copy.write_text(Path(V.__file__).read_text())
    S.write_claims(claims, copy)
    text = copy.read_text()
    assert text.count("# CLAIMS-BEGIN") == text.count("# CLAIMS-END") == 1
    ns: dict = {}
    exec(text[text.index("# CLAIMS-BEGIN") : text.index("# CLAIMS-END")], ns)
    assert ns["CLAIMS"] == claims
    assert S.main([]) == 2  # without --calibrate: the help, nothing rewritten
