"""flexgen stability (flexgen_tools.stability): no answer is wrong beyond its error estimate
without a warning (on a grid off the map's grid), the rule can fail, poly kernels past their
range are flagged, buckling loads of scm5."""

from __future__ import annotations

import math

import pytest

from flexgen import estimate as E
from flexgen_tools import stability as S
from flexgen_tools.bench import model_def

MODELS = ("cc", "prb", "scm3 poly", "scm3 gauss", "scm4 gauss", "fem8")
# none of these alphas or directions is on the map's grid (stability.grid)
ALPHAS = (1.5, 4.0, 15.0)
DIRECTIONS = (45.0, 135.0, 200.0, 300.0)


@pytest.fixture(scope="module")
def points():
    return S.sweep(
        ("cantilever", "finger"), [model_def(m) for m in MODELS], ALPHAS, DIRECTIONS, progress=False
    )


def test_no_answer_is_silently_wrong(points):
    silent = [
        (p.model, p.scene, p.alpha, p.direction, p.pose_err, p.comp_err, p.estimate, p.ratio)
        for p in points
        if p.silent
    ]
    assert not silent
    assert sum(p.reference for p in points) >= 0.9 * len(points)


def test_the_rule_is_exercised(points):
    """Some answers exceed their estimates or fail, and every one of them says so; the true
    error of a quiet answer is near its estimate (the estimate is not vacuously large)."""
    bad = [p for p in points if p.reference and (not p.converged or p.exceeds or p.warned)]
    assert any(p.model == "prb" and p.warned for p in bad)
    assert any(p.model == "scm3 poly" and (not p.converged or p.out_of_range) for p in bad)
    ok = [p for p in points if p.category == "within estimate"]
    assert any(p.model == "scm4 gauss" for p in ok) and any(p.model == "fem8" for p in ok)
    assert max(p.ratio for p in ok if p.model in ("fem8", "scm3 gauss")) > 0.3


def test_rule_detects_a_silent_failure(monkeypatch):
    """With the estimate's margin turned into an under-statement the same answer counts as a
    silent failure: the check can fail."""
    monkeypatch.setattr(E, "SCM_FACTOR", 1e-6)
    pts = S.sweep(("cantilever",), [model_def("scm3 gauss")], (1.5,), (45.0,), progress=False)
    assert pts[0].ratio > 1 and pts[0].silent and pts[0].category == "SILENT"


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


def test_the_convergence_sentence_names_only_the_rows_shown():
    """A --quick page (N = 3 and 5) quoted "0.3 % from N = 6" from the full run's table
    (review): the sentence reads the rows it follows."""
    rows = [
        {"modes": 3, "rel": [1e-4, 0.2, 0.9]},
        {"modes": 5, "rel": [8.6e-9, 3.3e-4, 0.022]},
    ]
    text = S._convergence_sentence(rows)
    assert "3 % from N = 5" in text and "0.3 % at no N shown (N <= 5)" in text
    rows.append({"modes": 6, "rel": [1e-12, 1e-6, 0.002]})
    assert "0.3 % from N = 6" in S._convergence_sentence(rows)
