"""Smoke test of benchmarks/solver_speed.py: its table functions on tiny cases, one repeat each.

No wall-clock limits are asserted: only that the fields exist, the times are positive, the
buckling elastica is solved in C too and LAPACK and the built-in factorizations agree.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from benchmark_modules import load_benchmark

ROOT = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")


@pytest.fixture(scope="module")
def sb():
    return load_benchmark("solver_speed")


@pytest.fixture(scope="module")
def scenes(sb):
    return sb.scenes()


@pytest.fixture(scope="module")
def speed(sb, scenes):
    cases = [sb.chain_case("cantilever scm3", scenes["cantilever"], sb.scm3, 1),
             sb.chain_case("elastica scm3 (buckling)", scenes["elastica"], sb.scm3, 1)]
    return {c.name: sb.speed_row(c, repeats=1, budget_s=0.5, rounds=1) for c in cases}


@pytest.fixture(scope="module")
def lapack(sb, scenes):
    return {"cantilever fem16": sb.lapack_row(scenes["cantilever"], sb.fem(16), rounds=1,
                                              budget_s=0.5)}


def test_tables(sb, scenes):
    """The table functions run their cases (scaled to the fewest repeats)."""
    speed = sb.speed_table([sb.chain_case("arc scm3", scenes["arc"], sb.scm3, 1)],
                           repeats_scale=0.0, budget_s=0.5)
    assert speed["arc scm3"]["us_compiled"] > 0
    lap = sb.lapack_table([("arc", "fem16", scenes["arc"], sb.fem(16))], repeats_scale=0.0,
                          budget_s=0.5)
    assert lap["arc fem16"]["agree"]


def test_speed_row_fields(speed):
    r = speed["cantilever scm3"]
    assert r["ms"] > 0 and r["ms_c"] > 0 and r["us_compiled"] > 0
    assert r["compiled"] == "solved"
    assert r["iterations"] >= 1 and r["states"] >= 1 and r["compiled_iterations"] >= 1
    assert r["backend_c_dq"] < 1e-9


def test_speed_row_buckling_in_c(speed):
    """The rectangular elastica buckles and switches kernels on the way: solved in C too."""
    r = speed["elastica scm3 (buckling)"]
    assert r["compiled"] == "solved" and r["us_compiled"] > 0
    assert r["ms"] > 0 and r["ms_c"] > 0 and r["backend_c_dq"] < 1e-9


def test_lapack_row(lapack):
    r = lapack["cantilever fem16"]
    assert r["ndof"] == 16 and r["lapack_used"] in (True, False)
    assert r["us_lapack"] > 0 and r["us_builtin"] > 0 and r["ratio"] > 0
    assert r["agree"] and r["q_rel_diff"] <= 1e-12


def test_lapack_min_size_restored(sb, scenes):
    from flexgen.compiled import library
    plan = sb.prepare(scenes["cantilever"], model_factory=sb.fem(16))
    before = plan.problem.settings.lapack_min_size
    r = sb.lapack_row(scenes["cantilever"], None, rounds=1, budget_s=0.1, plan=plan)
    assert r["agree"]
    assert plan.problem.settings.lapack_min_size == before == library.LAPACK_MIN_SIZE
    assert library.LAPACK_MIN_SIZE == 32


def test_page(sb, speed, lapack):
    page = sb.render_markdown(speed, lapack, elapsed=1.0)
    assert page.startswith("# Solver speed\n")
    assert "python benchmarks/solver_speed.py" in page and "OPENBLAS_NUM_THREADS" in page
    assert "| cantilever scm3 |" in page and "| elastica scm3 (buckling) |" in page
    assert "LAPACK against the built-in factorizations" in page
    json.dumps({**speed, "lapack": lapack, "machine": sb.machine()})
