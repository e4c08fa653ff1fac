"""The generated kernels against independent references, closed forms, the C twins, the goldens."""

import ctypes
import importlib.metadata
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import reference
import sympy as sp
from cbuild import compile_kernel

from flexgen import kernels
from flexgen.codegen.generate import CHECKED_IN, generate_files
from flexgen.codegen.render import write_files
from flexgen.codegen.spec import KernelSpec

ROOT = Path(__file__).resolve().parents[1]
NAMES = kernels.available()
POLY = [n for n in NAMES if "_" not in n]
# the kernels certified on a range of angles (|phi| <= PHI_MAX), and those certified at each q
RANGED = [n for n in NAMES if "_local" not in n]
LOCAL = [n for n in NAMES if "_local" in n]


def test_checked_in_set_is_complete():
    assert set(NAMES) >= {f"scm{n}" for n in range(1, 7)}
    assert any(n.startswith("scm3_gauss") for n in NAMES)
    assert any(n.startswith("scm5_gauss") for n in NAMES)
    assert {kernels.gauss_kernel_name(n, family="local") for n in range(1, 9)} <= set(LOCAL)
    for name in NAMES:
        if "_" in name:
            assert kernels.load_numpy(name).ERROR_BOUND <= 1e-10


@pytest.mark.parametrize("name", RANGED)
def test_pose_jacobian_hessian_within_bounds(name):
    m = kernels.load_numpy(name)
    rng = np.random.default_rng(1)
    q = reference.near_edge(m.N, m.PHI_MAX, 300, seed=2)
    inner = rng.normal(size=(300, m.N))
    inner *= m.PHI_MAX * rng.uniform(0, 0.9, (300, 1)) / reference.max_angle(inner)[:, None]
    q = np.concatenate([q, inner])
    pose, J, H = m.evaluate(q)
    rp, rJ, rH = reference.tip(q)
    assert np.abs(pose[:, :2] - rp).max() <= m.ERROR_BOUND
    assert np.array_equal(pose[:, 2], q[:, 0])
    assert np.abs(J[:, :2] - rJ).max() <= m.JACOBIAN_ERROR_BOUND
    assert np.abs(H[:, :2] - rH).max() <= m.HESSIAN_ERROR_BOUND
    assert np.array_equal(J[:, 2], np.broadcast_to(np.eye(m.N)[0], J[:, 2].shape))
    assert not H[:, 2].any()


@pytest.mark.parametrize("name", NAMES)
def test_derivatives_against_finite_differences(name):
    m = kernels.load_numpy(name)
    rng = np.random.default_rng(3)
    q = rng.normal(size=(5, m.N)) * 0.4
    h = 1e-5
    pose, J, H = m.evaluate(q)
    for i in range(m.N):
        dq = np.zeros(m.N)
        dq[i] = h
        (pp, Jp, _), (pm, Jm, _) = m.evaluate(q + dq), m.evaluate(q - dq)
        np.testing.assert_allclose(J[..., i], (pp - pm) / (2 * h), atol=1e-8)
        np.testing.assert_allclose(H[..., i], (Jp - Jm) / (2 * h), atol=1e-8)


def test_pose_against_scipy_quad():
    from scipy.integrate import quad

    m = kernels.load_numpy("scm3")
    q = np.array([0.9, -0.7, 0.4])
    pose, _, _ = m.evaluate(q)

    def phi(s):
        return (q @ reference.angle_basis(3, np.array([s])).T)[0]

    x = quad(lambda s: np.cos(phi(s)), 0, 1, epsabs=1e-14, epsrel=1e-14)[0]
    y = quad(lambda s: np.sin(phi(s)), 0, 1, epsabs=1e-14, epsrel=1e-14)[0]
    assert abs(pose[0] - x) <= m.ERROR_BOUND and abs(pose[1] - y) <= m.ERROR_BOUND


@pytest.mark.parametrize("name", NAMES)
def test_closed_forms(name):
    m = kernels.load_numpy(name)
    pose, _, _ = m.evaluate(np.zeros(m.N))
    np.testing.assert_allclose(pose, [1, 0, 0], atol=m.ERROR_BOUND)
    for theta in (-1.5, -0.3, 0.01, 0.8, 1.5):
        q = np.zeros(m.N)
        q[0] = theta
        pose, _, _ = m.evaluate(q)
        arc = [np.sin(theta) / theta, (1 - np.cos(theta)) / theta, theta]
        np.testing.assert_allclose(pose, arc, rtol=0, atol=m.ERROR_BOUND)


# The polynomial kernels' bound is the interpolation error itself (worst/bound 1.4-12x measured).
# The Gauss kernels' composition bound is looser where phi(0) = 0 keeps phi from the extremal
# Chebyshev shapes: worst/bound measured 3-150x (two modes the loosest), so it gets 200x.
HONESTY = {"poly": 100, "gauss": 200}


@pytest.mark.parametrize("name", RANGED)
def test_bound_is_honest(name):
    """Worst sampled error near the range edge: below the bound, and not far below it."""
    m = kernels.load_numpy(name)
    q = reference.near_edge(m.N, m.PHI_MAX, 20000, seed=4)
    error = np.abs(m.evaluate(q)[0][:, :2] - reference.tip(q)[0]).max()
    assert error <= m.ERROR_BOUND
    factor = HONESTY[m.FAMILY]
    assert error >= m.ERROR_BOUND / factor, f"bound {m.ERROR_BOUND:.3g} is loose: worst {error:.3g}"


@pytest.mark.parametrize("name", RANGED)
def test_in_range_is_sound_and_not_too_conservative(name):
    m = kernels.load_numpy(name)
    rng = np.random.default_rng(5)
    q = rng.normal(size=(4000, m.N)) * rng.choice([0.3, 1, 3, 10], size=(4000, 1))
    angle = reference.max_angle(q, samples=20001)
    ok = m.in_range(q)
    assert not np.any(ok & (angle > m.PHI_MAX))
    inside = angle <= 0.98 * m.PHI_MAX
    assert ok[inside].mean() > 0.95
    assert not m.in_range(np.r_[1.01 * m.PHI_MAX, np.zeros(m.N - 1)])
    assert m.in_range(np.r_[0.999 * m.PHI_MAX, np.zeros(m.N - 1)])


@pytest.mark.parametrize("name", NAMES)
def test_a_q_that_is_not_finite_is_out_of_range_silently_and_a_complex_one_refused(name):
    # review: in_range(inf) printed NumPy's "invalid value" warning (the local kernels were
    # silent), and a complex q was cast to real with only a ComplexWarning
    m = kernels.load_numpy(name)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert not m.in_range(np.r_[np.inf, np.zeros(m.N - 1)])
        assert not m.in_range(np.full(m.N, np.nan))
        assert not np.any(m.in_range(np.full((3, m.N), np.inf)))
        assert not m.in_range(np.r_[1e308, np.zeros(m.N - 1)])  # finite, its products not
    for call in (m.evaluate, m.in_range):
        with pytest.raises(ValueError, match="complex"):
            call(np.full(m.N, 0.1 + 0.2j))


def _errors(m, q):
    """max |pose|, |J|, |H| error per row of q against the 200-node reference."""
    pose, J, H = m.evaluate(q)
    rp, rJ, rH = reference.tip(q)
    return (
        np.abs(pose[:, :2] - rp).max(axis=1),
        np.abs(J[:, :2] - rJ).reshape(len(q), -1).max(axis=1),
        np.abs(H[:, :2] - rH).reshape(len(q), -1).max(axis=1),
    )


@pytest.mark.parametrize("name", LOCAL)
def test_local_kernel_is_within_its_bounds_wherever_it_certifies_them(name):
    """A local kernel's in_range(q) certifies its error at q. On wiggly profiles (the
    quadrature's worst) and smooth ones (what equilibria look like: the tip angle q_0, q_1 up to
    0.6 q_0, then decaying as 0.15^n) up to three times the arc bend PHI_MAX its nodes were
    chosen for: every certified q is within the pose, J and H bounds against the 200-node
    reference; the arc of PHI_MAX and nearly every smooth profile bent up to half of it are
    certified; and some uncertified q do err beyond the bounds, so the check is what keeps the
    kernel honest."""
    m = kernels.load_numpy(name)
    rng = np.random.default_rng(11)
    wiggly = reference.near_edge(m.N, m.PHI_MAX, 1500, seed=12)
    wiggly *= rng.uniform(0.02, 3.0, (len(wiggly), 1))
    shape = rng.normal(size=(3000, m.N)) * 0.15 ** np.arange(m.N)
    shape[:, 0] = rng.choice([-1.0, 1.0], 3000)
    if m.N > 1:
        shape[:, 1] = rng.uniform(-0.6, 0.6, 3000)
    bend = m.PHI_MAX * rng.uniform(0.0, 3.0, (3000, 1))
    smooth = shape * bend
    q = np.concatenate([wiggly, smooth])
    ok = m.in_range(q)
    errors = _errors(m, q)
    bounds = (m.ERROR_BOUND, m.JACOBIAN_ERROR_BOUND, m.HESSIAN_ERROR_BOUND)
    for error, bound in zip(errors, bounds):
        assert error[ok].max() <= bound
    assert m.in_range(np.r_[m.PHI_MAX, np.zeros(m.N - 1)])
    assert ok[len(wiggly) :][bend[:, 0] <= m.PHI_MAX / 2].mean() > 0.95
    beyond = np.any([e > b for e, b in zip(errors, bounds)], axis=0)
    assert beyond[~ok].any()
    assert not m.in_range(np.full(m.N, np.nan)) and not m.in_range(np.r_[np.inf, np.zeros(m.N - 1)])


def test_polynomial_kernel_is_the_expanded_polynomial():
    """The nodal form equals the fully expanded closed-form polynomial in q (N=2, degree 6)."""
    from flexgen.symbolic import trig
    from flexgen.symbolic.basis import angle_basis, sigma

    spec = KernelSpec(2, degree=6)
    files = generate_files(spec, ("numpy",))
    ns = {}
    exec(compile(files["numpy/scm2.py"], "scm2", "exec"), ns)
    q0, q1 = sp.symbols("q0 q1")
    phi = q0 * angle_basis(0).as_expr() + q1 * angle_basis(1).as_expr()
    interp = trig.chebyshev_interpolant(spec.range_rad, 6)
    C = sum(sp.Rational(str(c)) * phi**k for k, c in enumerate(interp.cos) if c != 0)
    x = sp.Poly(sp.expand(C), sigma).integrate()
    x = sp.expand(x.as_expr().subs(sigma, 1))
    f = sp.lambdify((q0, q1), x)
    for q in ([0.3, -0.2], [1.2, 2.0], [-0.9, 1.1]):
        assert abs(ns["evaluate"](np.array(q))[0][0] - float(f(*q))) < 1e-14


@pytest.fixture(scope="module")
def c_libraries(tmp_path_factory):
    build = tmp_path_factory.mktemp("c")
    return {name: compile_kernel(name, build) for name in NAMES}


def _call(lib, name, q, suffix="", ctype=ctypes.c_double, dtype=np.float64):
    n = q.size
    q = np.ascontiguousarray(q, dtype=dtype)
    out = [np.zeros(k, dtype=dtype) for k in (3, 3 * n, 3 * n * n)]
    ptr = ctypes.POINTER(ctype)
    getattr(lib, f"{name}_evaluate{suffix}")(*(a.ctypes.data_as(ptr) for a in (q, *out)))
    return out[0], out[1].reshape(3, n), out[2].reshape(3, n, n)


@pytest.mark.parametrize("name", NAMES)
def test_c_kernels_match_numpy(c_libraries, name):
    lib, m = c_libraries[name], kernels.load_numpy(name)
    rng = np.random.default_rng(6)
    for q in reference.near_edge(m.N, m.PHI_MAX, 40, seed=7)[::3]:
        expected = m.evaluate(q)
        for got, want in zip(_call(lib, name, q), expected):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-13)
        for got, want in zip(_call(lib, name, q, "_f", ctypes.c_float, np.float32), expected):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-5)
    # random q, and q near the range's edge, where the C test's quick bound must not accept
    # what the sampled test (NumPy's, for a batch) rejects
    q = np.vstack(
        [rng.normal(size=(200, m.N)) * 2, reference.near_edge(m.N, m.PHI_MAX, 200, seed=8)]
    )
    flags = [
        lib[f"{name}_in_range"](
            np.ascontiguousarray(x).ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        )
        for x in q
    ]
    assert flags == [int(v) for v in m.in_range(q)]


def test_emitted_c_uses_no_heap_and_no_globals():
    for path in (kernels.GENERATED / "c").glob("*.c"):
        text = path.read_text()
        assert "malloc" not in text and "static" not in text
        top = [
            line
            for line in text.splitlines()
            if line and not line[0].isspace() and line[0] not in "/*#{}"
        ]
        assert all("(" in line for line in top), f"{path.name}: non-function top-level {top}"


def machine_specific(tmp_path) -> list[re.Pattern[str]]:
    """What must not reach a generated file: this machine's paths (the output folder, the
    checkout, the home folder), a date, the versions of flexgen and SymPy."""
    paths = [p for p in (str(tmp_path), str(ROOT), str(Path.home())) if p != "/"]
    versions = [importlib.metadata.version("flexgen"), sp.__version__]
    return [
        *(re.compile(re.escape(p)) for p in paths),
        re.compile(r"20\d\d-\d\d-\d\d"),
        *(re.compile(r"(?<![\d.])" + re.escape(v) + r"(?![\d.])") for v in versions),
    ]


def test_machine_specific_catches_each_leak(tmp_path):
    for leak in (
        str(tmp_path / "numpy"),
        str(ROOT / "templates"),
        str(Path.home() / "x"),
        "on 2024-06-01",
        f"flexgen {importlib.metadata.version('flexgen')}",
        f"sympy {sp.__version__}",
    ):
        assert any(p.search(leak) for p in machine_specific(tmp_path)), leak
    assert not any(p.search("0.12005194278465664*q[1]") for p in machine_specific(tmp_path))


def test_generated_is_byte_identical_to_a_fresh_regeneration(tmp_path):
    files = {}
    for spec in CHECKED_IN:
        files |= generate_files(spec)
    write_files(files, tmp_path)
    fresh = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    checked = sorted(
        p.relative_to(kernels.GENERATED)
        for p in kernels.GENERATED.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    )
    assert fresh == checked
    for rel in fresh:
        assert (tmp_path / rel).read_bytes() == (kernels.GENERATED / rel).read_bytes(), rel
        text = (tmp_path / rel).read_text()
        for leak in machine_specific(tmp_path):
            assert not leak.search(text), f"{rel}: {leak.pattern}"


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flexgen", *args], capture_output=True, text=True)


@pytest.mark.parametrize(
    "args",
    [
        ["--modes", "0"],
        ["--modes", "9"],
        ["--modes", "3", "--range", "-10"],
        ["--modes", "3", "--range", "180"],
        ["--modes", "3", "--lang", "rust"],
        ["--modes", "three"],
        ["--modes", "3", "--kernel", "spline"],
        ["--modes", "3", "--tol", "0"],
        ["--modes", "3", "--kernel", "gauss", "--degree", "4"],
        ["--modes", "3", "--tol", "1e-300"],
        ["--modes", "3", "--kernel", "gauss", "--tol", "1e-17"],
        ["--modes", "3", "--kernel", "local", "--tol", "1e-17"],
        ["--modes", "3", "--kernel", "local", "--nodes", "2"],
        ["--modes", "3", "--kernel", "local", "--range", "800"],
    ],
)
def test_generate_rejects_bad_arguments(args, tmp_path):
    result = _cli("generate", *args, "--out", str(tmp_path))
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1
    assert "Traceback" not in result.stderr
    assert not any(tmp_path.iterdir())


def test_generate_check_names_stale_files(tmp_path):
    assert _cli("generate", "--modes", "2", "--out", str(tmp_path)).returncode == 0
    assert _cli("generate", "--modes", "2", "--out", str(tmp_path), "--check").returncode == 0
    (tmp_path / "c" / "scm2.c").write_text("/* edited */\n")
    result = _cli("generate", "--modes", "2", "--out", str(tmp_path), "--check")
    assert result.returncode == 1 and "c/scm2.c" in result.stderr
    assert (tmp_path / "c" / "scm2.c").read_text() == "/* edited */\n"


def test_generate_gauss_on_request(tmp_path):
    result = _cli(
        "generate",
        "--modes",
        "2",
        "--kernel",
        "gauss",
        "--nodes",
        "12",
        "--lang",
        "numpy",
        "--out",
        str(tmp_path),
    )
    assert result.returncode == 0
    m = kernels.load_numpy("scm2_gauss12", tmp_path)
    q = np.array([2.5, 1.0])
    np.testing.assert_allclose(m.evaluate(q)[0][:2], reference.tip(q)[0], atol=m.ERROR_BOUND)


@pytest.mark.parametrize("name", NAMES)
def test_one_q_path_matches_the_block_path(name):
    """evaluate(q) for one q (stacked Horner, one product) equals the block path for a batch."""
    m = kernels.load_numpy(name)
    q = reference.near_edge(m.N, m.PHI_MAX, 20, seed=8)
    batch = m.evaluate(q)
    for k, row in enumerate(q):
        for got, want in zip(m.evaluate(row), batch):
            np.testing.assert_allclose(got, want[k], rtol=0, atol=1e-14)


@pytest.mark.parametrize("name", NAMES)
def test_in_range_is_0_for_a_q_that_is_not_finite(c_libraries, name):
    """A NaN (or infinite) q_n is out of range in C (the strict build and the compiled core)
    and in NumPy alike (review: C's sampled test skipped a NaN sample, and q[0] has no margin,
    so scmN_in_range({NAN, 0, ...}) was 1 and the solver took a NaN iterate as in range)."""
    from flexgen import _core

    m = kernels.load_numpy(name)
    ptr = ctypes.POINTER(ctypes.c_double)
    checks = (
        lambda q: lib_in_range(np.ascontiguousarray(q).ctypes.data_as(ptr)),
        lambda q: core_in_range(_core.ffi.cast("double *", _core.ffi.from_buffer(q))),
        lambda q: int(m.in_range(q)),
    )
    lib_in_range = c_libraries[name][f"{name}_in_range"]
    core_in_range = getattr(_core.lib, f"{name}_in_range")
    inside = np.r_[0.5 * m.PHI_MAX, np.zeros(m.N - 1)]
    assert [check(inside.copy()) for check in checks] == [1, 1, 1]
    for n in range(m.N):
        for bad in (np.nan, np.inf, -np.inf):
            q = inside.copy()
            q[n] = bad
            with np.errstate(invalid="ignore"):  # inf * 0 in NumPy's samples
                assert [check(q) for check in checks] == [0, 0, 0], (n, bad)


@pytest.mark.parametrize(
    "args, named",
    [
        # too few Gauss nodes: the Hessian's bound (and for fewer, the pose's) was inf, emitted
        # as `inf`, which neither the C header nor the Python module reads
        (["--modes", "3", "--kernel", "gauss", "--nodes", "3"], "--nodes"),
        (["--modes", "3", "--kernel", "gauss", "--nodes", "1"], "--nodes"),
        (["--modes", "8", "--kernel", "gauss", "--nodes", "8"], "--nodes"),
        # --tol was dropped silently where --nodes fixes the bound (poly: --degree with --tol)
        (["--modes", "3", "--kernel", "gauss", "--nodes", "10", "--tol", "1e-12"], "--tol"),
        # below double rounding: the pose bound came out above --tol, with exit 0
        (["--modes", "2", "--tol", "1e-15"], "--tol"),
        (["--modes", "3", "--tol", "1e-14"], "--tol"),
        (["--modes", "3", "--tol", "1e-30"], "--tol"),
    ],
)
def test_generate_refuses_what_it_cannot_certify(args, named, tmp_path):
    result = _cli("generate", *args, "--out", str(tmp_path))
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and result.stderr.startswith(f"flexgen: error: {named}")
    assert not any(tmp_path.iterdir())


def test_the_fewest_gauss_nodes_with_a_bound_and_a_tol_near_rounding(tmp_path):
    """N + 1 nodes is the fewest that bound the Hessian: a finite bound that the module states
    and keeps; a poly --tol just above the rounding floor is met by the pose bound, rounding
    included (5e-14: degree 14 gave 5.1e-14)."""
    for args in (["--kernel", "gauss", "--nodes", "4"], ["--tol", "5e-14"]):
        result = _cli("generate", "--modes", "3", *args, "--lang", "numpy", "--out", str(tmp_path))
        assert result.returncode == 0, result.stderr
    m = kernels.load_numpy("scm3_gauss4", tmp_path)
    bounds = (m.ERROR_BOUND, m.JACOBIAN_ERROR_BOUND, m.HESSIAN_ERROR_BOUND)
    assert all(np.isfinite(bounds))
    q = reference.near_edge(3, m.PHI_MAX, 200, seed=9)
    pose, J, H = m.evaluate(q)
    rp, rJ, rH = reference.tip(q)
    assert np.abs(pose[:, :2] - rp).max() <= m.ERROR_BOUND
    assert np.abs(J[:, :2] - rJ).max() <= m.JACOBIAN_ERROR_BOUND
    assert np.abs(H[:, :2] - rH).max() <= m.HESSIAN_ERROR_BOUND
    assert kernels.load_numpy("scm3", tmp_path).ERROR_BOUND <= 5e-14


@pytest.mark.parametrize(
    "args",
    [["--degree", "1"], ["--degree", "2"], ["--tol", "0.2"], ["--tol", "0.5"], ["--range", "1e-9"]],
)
def test_low_degree_poly_kernels_are_generated(args, tmp_path):
    """A cos/sin interpolant of degree 1 or 2 has an all-zero derivative (s'' = 0, and for
    degree 1 c' = 0): it was `internal error: StopIteration`. Now the kernel is emitted, its C
    compiles strictly and its pose is within its bound against the reference on its range."""
    result = _cli("generate", "--modes", "3", *args, "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    from cbuild import STRICT

    subprocess.run(
        ["gcc", *STRICT, "-c", str(tmp_path / "c" / "scm3.c"), "-o", str(tmp_path / "scm3.o")],
        check=True,
    )
    m = kernels.load_numpy("scm3", tmp_path)
    q = reference.near_edge(3, m.PHI_MAX, 50, seed=10)
    for row in q:
        pose, J, H = m.evaluate(row)
        rp, rJ, rH = reference.tip(row[None])
        assert np.abs(pose[:2] - rp[0]).max() <= m.ERROR_BOUND
        assert np.abs(J[:2] - rJ[0]).max() <= m.JACOBIAN_ERROR_BOUND
        assert np.abs(H[:2] - rH[0]).max() <= m.HESSIAN_ERROR_BOUND


@pytest.mark.parametrize("args", [["--degree", "1"], ["--degree", "2"], ["--degree", "3"]])
def test_low_degree_poly_kernels_evaluate_batches(args, tmp_path):
    """A degree-2 or degree-3 interpolant's c'' is a constant (degree 1: c', c'', s'' too),
    which _trig returned as a scalar: the batch path failed in its matrix product (review
    finding 2). A (2, 3, N) batch is now within the bounds of the reference, row by row, and
    equals the one-q path."""
    result = _cli("generate", "--modes", "3", *args, "--lang", "numpy", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    m = kernels.load_numpy("scm3", tmp_path)
    q = reference.near_edge(3, m.PHI_MAX, 6, seed=13)[:6].reshape(2, 3, 3)
    pose, J, H = m.evaluate(q)
    assert pose.shape == (2, 3, 3) and J.shape == (2, 3, 3, 3) and H.shape == (2, 3, 3, 3, 3)
    rp, rJ, rH = reference.tip(q.reshape(-1, 3))
    assert np.abs(pose.reshape(-1, 3)[:, :2] - rp).max() <= m.ERROR_BOUND
    assert np.abs(J.reshape(-1, 3, 3)[:, :2] - rJ).max() <= m.JACOBIAN_ERROR_BOUND
    assert np.abs(H.reshape(-1, 3, 3, 3)[:, :2] - rH).max() <= m.HESSIAN_ERROR_BOUND
    for k, row in enumerate(q.reshape(-1, 3)):
        for got, want in zip(m.evaluate(row), (pose, J, H)):
            np.testing.assert_allclose(got, want.reshape(6, *want.shape[2:])[k], atol=1e-14)


def test_a_prefix_differing_only_in_case_is_refused_beside_the_other(tmp_path):
    """`--prefix Arm` beside arm_scm2.h: the same ARM_SCM2_* macros and header guard (and one
    file on a case-insensitive file system). One line, exit 2, nothing written; a prefix that
    differs in more than case is written beside it."""
    common = ["--modes", "2", "--lang", "c", "--out", str(tmp_path)]
    assert _cli("generate", *common, "--prefix", "arm").returncode == 0
    before = sorted(p.name for p in (tmp_path / "c").iterdir())
    result = _cli("generate", *common, "--range", "60", "--prefix", "Arm")
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert result.stderr.startswith("flexgen: error: --prefix") and "case" in result.stderr
    assert sorted(p.name for p in (tmp_path / "c").iterdir()) == before
    assert _cli("generate", *common, "--range", "60", "--prefix", "arm60").returncode == 0


def _counted_ops(source: str, name: str) -> tuple[int, int, int]:
    """Adds (binary + and -), multiplies and cos/sin calls in the text of <name>_evaluate, counted
    from the C tokens (a literal's exponent sign and a unary minus are not adds)."""
    body = re.search(rf"void {name}_evaluate\(const double[^{{]*\{{(.*?)\n\}}", source, re.S)
    assert body is not None
    text = re.sub(r"\d+\.?\d*[eE][-+]?\d+", "1.0", body[1])
    adds = muls = calls = 0
    previous = None
    for token in re.findall(r"[A-Za-z_]\w*(?:\[\d+\])?|\d+\.?\d*|[-+*/=(),;]", text):
        if token in "+-" and previous not in ("=", "(", ",", "+", "-", "*"):
            adds += 1
        muls += token == "*"
        calls += token in ("cos", "sin")
        assert token != "/"
        previous = token
    return adds, muls, calls


@pytest.mark.parametrize("name", NAMES)
def test_the_stated_cost_is_the_emitted_code(name):
    """The header's and the source's "Cost" count the operations of the emitted evaluate (review:
    H[i][j] and its twin H[j][i] were both printed in full, so scm8 ran 18747 ops at -O0 against
    the 12847 stated); the twin is now a copy."""
    source = (kernels.GENERATED / "c" / f"{name}.c").read_text()
    stated = re.search(r"Cost: (\d+) ops \((\d+) add, (\d+) mul, (\d+) cos/sin\)", source)
    assert stated is not None
    assert _counted_ops(source, name) == tuple(int(v) for v in stated.groups()[1:])
    header = (kernels.GENERATED / "c" / f"{name}.h").read_text()
    assert f"Cost: {stated[0][6:]}" in header


@pytest.mark.parametrize("name", NAMES)
def test_in_range_names_a_q_of_the_wrong_shape_as_evaluate_does(name):
    """in_range(np.zeros(N + 1)) raised numpy's matmul error; now evaluate's one line."""
    m = kernels.load_numpy(name)
    for function in (m.evaluate, m.in_range):
        with pytest.raises(ValueError, match=rf"^q must have shape \(\.\.\., {m.N}\), got"):
            function(np.zeros(m.N + 1))


def test_check_against_a_file_is_bad_input(tmp_path):
    """--check --out FILE said "stale in FILE", exit 1; without --check it is exit 2."""
    (tmp_path / "afile").write_text("x\n")
    result = _cli("generate", "--modes", "2", "--check", "--out", str(tmp_path / "afile"))
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "--out" in result.stderr and "not a folder" in result.stderr


def test_a_check_of_one_kernel_says_only_its_outcome(tmp_path):
    # review: `generate --modes 2 --check --out nonexist` printed a progress line, then the
    # stale message: two lines for one outcome
    result = _cli("generate", "--modes", "2", "--check", "--out", str(tmp_path / "none"))
    assert result.returncode == 1
    (line,) = result.stderr.strip().splitlines()
    assert line.startswith("flexgen: stale in ")
