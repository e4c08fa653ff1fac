"""Smoke test of benchmarks/solver_speed.py: its table functions on tiny cases, one round each.

No wall-clock limits are asserted: only that the fields exist, the three timings are positive,
the buckling elastica is solved (its bifurcation on the path), and LAPACK and the built-in
factorizations (``SolverSettings.lapack_min_size``) agree.
"""

from __future__ import annotations

import json

import pytest
from benchmark_modules import load_benchmark


@pytest.fixture(scope="module")
def sb():
    return load_benchmark("solver_speed")


@pytest.fixture(scope="module")
def scenes(sb):
    return sb.scenes()


@pytest.fixture(scope="module")
def speed(sb, scenes):
    cases = [
        sb.chain_case("cantilever scm3", scenes["cantilever"], sb.scm3),
        sb.chain_case("elastica scm3 (buckling)", scenes["elastica"], sb.scm3),
        sb.exact_case("cantilever exact", scenes["cantilever"], 1),
    ]
    return {c.name: sb.speed_row(c, repeats=1, budget_s=0.2, rounds=1) for c in cases}


@pytest.fixture(scope="module")
def lapack(sb, scenes):
    return {
        "cantilever fem16": sb.lapack_row(scenes["cantilever"], sb.fem(16), rounds=1, budget_s=0.2)
    }


def test_tables(sb, scenes):
    """The table functions run their cases (scaled to the fewest repeats)."""
    speed = sb.speed_table(
        [sb.chain_case("arc scm3", scenes["arc"], sb.scm3)], repeats_scale=0.0, budget_s=0.2
    )
    assert speed["arc scm3"]["us_core"] > 0
    lap = sb.lapack_table(
        [("arc", "fem16", scenes["arc"], sb.fem(16))], repeats_scale=0.0, budget_s=0.2
    )
    assert lap["arc fem16"]["agree"]
    names = [c.name for c in sb.cases(scenes)]
    assert "finger scm3" in names and "finger exact" in names and len(set(names)) == len(names)


def test_cases_have_their_model(sb, scenes):
    """Every flexure of a case's Scene has the case's model (what flexgen.solve then builds)."""
    case = sb.chain_case("finger fem16", scenes["finger"], sb.fem(16))
    assert all(f.model.kind == "fem" and f.model.elements == 16 for f in case.scene.flexures)
    import flexgen

    r = flexgen.solve(case.scene)
    assert r.model == {n: {"kind": "fem", "elements": 16} for n in ("proximal", "distal")}


def test_speed_row_fields(speed):
    r = speed["cantilever scm3"]
    assert r["us_api"] > 0 and r["us_prepared"] > 0 and r["us_core"] > 0
    assert r["converged"] and r["stable"] and r["critical"] == []
    assert r["iterations"] >= 1
    assert r["evaluations"] is None or r["evaluations"] >= r["iterations"]


def test_speed_row_buckling(speed):
    """The rectangular elastica buckles on the way: solved, with its critical load factor."""
    r = speed["elastica scm3 (buckling)"]
    assert r["converged"] and r["stable"] and len(r["critical"]) >= 1 and 0 < r["critical"][0] < 1
    assert r["us_core"] > 0 and r["us_prepared"] > 0 and r["us_api"] > 0


def test_exact_row(speed):
    r = speed["cantilever exact"]
    assert r["converged"] and r["us_api"] > 0
    assert r["us_prepared"] is None and r["us_core"] is None


def test_lapack_row(lapack):
    r = lapack["cantilever fem16"]
    # 16 coordinates: below the 32 from which the default settings factorize with LAPACK
    # (docs/accuracy-vs-speed.md), so the default solve is the built-in one
    assert r["ndof"] == 16 and r["lapack_used"] is False
    assert r["us_lapack"] > 0 and r["us_builtin"] > 0 and r["ratio"] > 0
    assert r["agree"] and r["q_rel_diff"] <= 1e-12


def test_lapack_solvers_settings(sb, scenes):
    """LAPACK off is a setting of its own solver: the default one keeps the default."""
    from flexgen import core
    from flexgen.settings import DEFAULT

    on, off = sb.lapack_solvers(scenes["cantilever"], sb.fem(64))
    assert on.settings.lapack_min_size == DEFAULT.lapack_min_size <= 64
    assert off.settings.lapack_min_size == sb.LAPACK_OFF
    r = sb.lapack_row(scenes["cantilever"], sb.fem(64), rounds=1, budget_s=0.1)
    assert r["agree"] and r["lapack_used"] == bool(core.lapack())


def test_page(sb, speed, lapack):
    page = sb.render_markdown(speed, lapack, elapsed=1.0)
    assert page.startswith("# Solver speed\n")
    assert "python benchmarks/solver_speed.py" in page and "OPENBLAS_NUM_THREADS" in page
    assert "| cantilever scm3 |" in page and "| elastica scm3 (buckling) |" in page
    assert "| cantilever exact |" in page
    assert "LAPACK against the built-in factorizations" in page
    assert "backend" not in page and "Python solver" not in page
    json.dumps({**speed, "lapack": lapack, "machine": sb.machine()})
