"""Smoke test of benchmarks/kernels.py: its functions on one kernel with tiny sizes.

No wall-clock limits are asserted: only that the C timing is positive and that the measured error
is within the kernel's certified bounds.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from benchmark_modules import load_benchmark

ROOT = Path(__file__).resolve().parent.parent
KERNEL = "scm3"

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")


@pytest.fixture(scope="module")
def kb():
    return load_benchmark("kernels")


@pytest.fixture(scope="module")
def kernel(kb):
    return kb.parse_header(ROOT / "generated" / "c" / f"{KERNEL}.h")


def test_header_parsed(kernel):
    assert kernel.modes == 3 and kernel.family == "poly"
    assert kernel.ops_total > 0 and 0 < kernel.error_bound < 1e-9
    assert kernel.phi_max == pytest.approx(math.pi / 2)


def test_reference_is_the_circular_arc(kb):
    """q = (theta, 0, 0) is a circular arc: x = sin(theta)/theta, y = (1 - cos(theta))/theta."""
    ref = kb.Reference(3)
    theta = np.array([0.3, 1.5, -2.5])
    q = np.zeros((3, 3))
    q[:, 0] = theta
    pose, J, H = ref.evaluate(q)
    np.testing.assert_allclose(pose[:, 0], np.sin(theta) / theta, atol=1e-14)
    np.testing.assert_allclose(pose[:, 1], (1 - np.cos(theta)) / theta, atol=1e-14)
    np.testing.assert_allclose(pose[:, 2], theta)


def test_max_abs_phi_is_exact(kb):
    ref = kb.Reference(4, 8)
    q = np.random.default_rng(0).standard_normal((50, 4))
    s = np.linspace(0, 1, 20001)
    grid = np.abs(q @ np.stack([b(s) for b in ref.basis], axis=1).T).max(axis=1)
    exact = ref.max_abs_phi(q)
    assert np.all(exact >= grid - 1e-13) and np.all(exact <= grid + 1e-7)


def test_c_kernel_timing_and_error(kb, kernel, tmp_path):
    cfg = kb.Config(quick=True, c_rounds=1, c_repeats=1, c_target_ms=0.2, n_random=10, n_edge=10)
    rows = kb.run_c(cfg, tmp_path, [kernel])
    (row,) = rows
    assert row["time"]["double"] > 0 and row["time"]["float"] > 0
    err = row["error"]
    assert err["count"] == 22 and err["edge_count"] == 12
    assert err["double"]["pose"] < kernel.error_bound
    assert err["double"]["J"] < kernel.jacobian_bound
    assert err["double"]["H"] < kernel.hessian_bound
    assert err["float"]["pose"] < 1e-5
    page = kb.render_markdown(kb.machine_info(), cfg, rows, {}, {}, 0.0)
    assert f"`{KERNEL}`" in page and "Which kernel should the runtime prefer" in page


def test_numpy_module_and_quadrature(kb):
    mod = kb.load_module(ROOT / "generated" / "numpy" / f"{KERNEL}.py")
    rates = kb.time_numpy_module(mod, (1, 8), np.random.default_rng(0), budget_s=0.01, repeats=1)
    assert all(r > 0 for r in rates.values())
    q = kb.sample_q(3, kb.TIMING_PHI, 1, np.random.default_rng(1))[0]
    got = kb.quad_evaluate(q)
    want = kb.Reference(3).evaluate(q)
    errs = kb.max_errors(got, [w[0] for w in want])
    assert max(errs.values()) < 1e-10
