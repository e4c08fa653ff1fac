"""flexgen bench in quick mode: files, Pareto front, exact against itself, convergence in modes
and elements. No wall-clock assertions."""
from __future__ import annotations

import math

import pytest

from flexgen import bench


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    data = bench.run_bench(quick=True, out=out, progress=False)
    return data, out


def test_files_written(run):
    data, out = run
    png, md = out / "accuracy-vs-speed.png", out / "accuracy-vs-speed.md"
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = md.read_text()
    assert "## Targets" in text and "two-flexure finger" in text
    for m in data.models:
        assert f"| {m.label} |" in text or f"| **{m.label}** |" in text


def test_suite_has_examples_and_random(run):
    data, _ = run
    assert bench.SMOOTH_SCENE in data.scenes
    assert any(s.startswith("random") for s in data.scenes)


def test_exact_against_itself_is_zero(run):
    data, _ = run
    for s in data.scenes:
        assert data.pose_err["exact", s] == 0.0
        assert data.comp_err["exact", s] == 0.0


def test_pareto_front_is_non_dominated(run):
    data, _ = run
    labels, pts = bench.chart_points(data, "pose")
    front = bench.pareto_front(pts)
    assert front
    for i in front:
        ti, ei = pts[i]
        for j, (tj, ej) in enumerate(pts):
            if j != i:
                assert not (tj <= ti and ej <= ei and (tj < ti or ej < ei)), (labels[i], labels[j])
    # and every point off the front is dominated by one on it
    for j, (tj, ej) in enumerate(pts):
        if j not in front and math.isfinite(tj) and math.isfinite(ej):
            assert any(pts[i][0] <= tj and pts[i][1] <= ej for i in front), labels[j]


def test_pareto_front_synthetic():
    pts = [(1.0, 1.0), (2.0, 0.5), (3.0, 0.6), (0.5, 2.0), (2.0, 0.5), (4.0, 0.1)]
    front = bench.pareto_front(pts)
    assert [pts[i] for i in front] == [(0.5, 2.0), (1.0, 1.0), (2.0, 0.5), (2.0, 0.5), (4.0, 0.1)]


def test_error_decreases_with_elements_and_modes(run):
    data, _ = run
    s = bench.SMOOTH_SCENE
    for err in (data.pose_err, data.comp_err):
        fem = [err[f"fem{n}", s] for n in (4, 8, 16)]
        assert fem[0] > fem[1] > fem[2] > 0
        # O(h^2): halving h divides the error by about 4
        assert 3.0 < fem[0] / fem[1] < 5.0 and 3.0 < fem[1] / fem[2] < 5.0
        scm = [err[f"scm{n} gauss", s] for n in (2, 3, 4, 5)]
        assert all(a > b for a, b in zip(scm, scm[1:])), scm
    assert data.pose_err["scm5 gauss", s] < 1e-6


def test_targets_measured(run):
    data, _ = run
    tg = data.targets
    assert tg["finger_scm3_s"] > 0 and tg["finger_exact_s"] > 0
    assert tg["exact_ratio"] == pytest.approx(tg["finger_exact_s"] / tg["finger_scm3_s"])
    pe, ce = tg["finger_scm3_error"]
    assert pe < 1e-3 and ce < 1e-3
    for suffix in ("_c", "_cs"):
        assert tg[f"finger_scm3{suffix}_s"] > 0
        assert tg[f"exact_ratio{suffix}"] == pytest.approx(
            tg["finger_exact_s"] / tg[f"finger_scm3{suffix}_s"])
    for timing in bench.TIMINGS:
        assert f"equal_smooth_{timing}_ratio" in tg


def test_compiled_backend_measured_and_agrees(run):
    """Every chain model was also solved with backend="c" and agrees with the Python solver; the
    C solver solved the smooth cantilever itself (no hand-back), and its times are recorded."""
    data, out = run
    assert data.backend_diff and max(data.backend_diff.values()) <= 1e-9
    for md in data.models:
        if md.kind == "exact":
            continue
        assert data.c_solved[md.label, bench.SMOOTH_SCENE], md.label
        assert data.times_cs[md.label, bench.SMOOTH_SCENE] > 0
        assert data.times_c[md.label, bench.SMOOTH_SCENE] > 0
    text = (out / "accuracy-vs-speed.md").read_text()
    assert "compiled solve" in text and "backend c" in text


def test_time_at_error():
    pts = [(1.0, 1e-2), (2.0, 1e-3), (4.0, 1e-4)]
    t, how = bench.time_at_error(pts, 10 ** -3.5)
    assert how == "interpolated" and t == pytest.approx(2.0 * math.sqrt(2.0))
    t, how = bench.time_at_error(pts, 1e-5)
    assert how.startswith("extrapolated") and t == pytest.approx(8.0)
