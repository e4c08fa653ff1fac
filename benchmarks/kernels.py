"""Kernel benchmark: C and NumPy kernels against sympy.lambdify and numerical quadrature.

    python benchmarks/kernels.py [--quick] [--out docs/benchmarks.md]

Everything in the page is measured in one run on this machine:

1. ns per call of every checked-in C kernel (generated/c/*.c), double and float, built with
   ``gcc -O2 -std=c99`` against benchmarks/c/harness.c (min over repeats, 256 seeded q's cycled);
   the op count from the header comment and the kernel's ERROR_BOUND.
2. The measured worst pose (and J, H) error of each C kernel over seeded in-range q's, including
   near-edge ones, against an independent 200-node Gauss-Legendre reference computed here in numpy.
3. Throughput of the generated NumPy modules at batch 1, 1e3 and 1e5.
4. The same scm3 expressions through ``sympy.lambdify`` and through ``scipy.integrate.quad``.
5. Which kernel the runtime should prefer, computed from the numbers above.

Progress goes to stderr. The functions are importable (tests/test_benchmarks.py uses them on one
kernel with tiny sizes).
"""

from __future__ import annotations

import os

if __name__ == "__main__":
    # Single-threaded BLAS, like the one-core C kernels (and robust on a shared 2-core machine);
    # must be set before numpy is imported, and only when run as the benchmark (importing this
    # module leaves the environment alone). An explicit setting in the environment wins.
    for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")

import argparse
import importlib.util
import math
import platform
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.polynomial import Legendre, Polynomial

ROOT = Path(__file__).resolve().parent.parent
C_DIR = ROOT / "generated" / "c"
NUMPY_DIR = ROOT / "generated" / "numpy"
HARNESS = Path(__file__).resolve().parent / "c" / "harness.c"
CFLAGS = ["-O2", "-std=c99"]
TARGET_ERROR = 1e-9
TIMING_SET = 256  # q's cycled in the C timing loop
TIMING_PHI = math.pi / 2  # timing q's keep |phi| <= 90 deg, so poly and gauss see the same q's
REFERENCE_NODES = 200
SEED = 20240601
NUMPY_REQUIRED = ("scm3", "scm5", "scm3_gauss25", "scm5_gauss41")


def log(msg: str) -> None:
    print(f"[kernels] {msg}", file=sys.stderr, flush=True)


# -- machine ---------------------------------------------------------------------------------
def machine_info() -> dict[str, str]:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        gcc = subprocess.run(
            ["gcc", "--version"], capture_output=True, text=True, check=True
        ).stdout.splitlines()[0]
    except (OSError, subprocess.CalledProcessError):
        gcc = "not found"
    import scipy
    import sympy

    return {
        "cpu": cpu,
        "cores": str(os.cpu_count()),
        "gcc": gcc,
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "sympy": sympy.__version__,
        "python": platform.python_version(),
    }


# -- the checked-in C kernels ----------------------------------------------------------------
@dataclass
class CKernel:
    name: str  # scm3, scm3_gauss25 ...
    header: Path
    source: Path
    modes: int
    family: str  # poly / gauss / local
    nodes: int
    phi_max: float
    error_bound: float
    jacobian_bound: float
    hessian_bound: float
    ops: str  # "1977 ops (912 add, 1065 mul, 0 cos/sin)"
    ops_total: int
    extra: dict = field(default_factory=dict)

    @property
    def macro(self) -> str:
        return self.name.upper()


def parse_header(header: Path) -> CKernel:
    """Read N, NODES, PHI_MAX, the error bounds and the op count from a generated header."""
    text = header.read_text()
    name = header.stem
    M = name.upper()

    def define(key: str) -> str:
        m = re.search(rf"#define {M}_{key}\s+(\S+)", text)
        if not m:
            raise ValueError(f"{header}: no {M}_{key}")
        return m.group(1)

    cost = re.search(r"Cost: ((\d+) ops \([^)]*\))", text)
    if not cost:
        raise ValueError(f"{header}: no 'Cost:' line in the header comment")
    return CKernel(
        name=name,
        header=header,
        source=header.with_suffix(".c"),
        modes=int(define("N")),
        family="gauss" if "_gauss" in name else "local" if "_local" in name else "poly",
        nodes=int(define("NODES")),
        phi_max=float(define("PHI_MAX")),
        error_bound=float(define("ERROR_BOUND")),
        jacobian_bound=float(define("JACOBIAN_ERROR_BOUND")),
        hessian_bound=float(define("HESSIAN_ERROR_BOUND")),
        ops=cost.group(1),
        ops_total=int(cost.group(2)),
    )


def c_kernels(folder: Path = C_DIR) -> list[CKernel]:
    """Every generated/c/*.c with its header, ordered by (modes, family)."""
    ks = [parse_header(c.with_suffix(".h")) for c in sorted(folder.glob("*.c"))]
    return sorted(ks, key=lambda k: (k.modes, k.family != "poly", k.name))


# Kernels generated for the comparison only (not checked in): the CasADi peer's workload (3 modes,
# Gauss, 8 nodes) and the fewest Gauss nodes certified to 1e-9 on the polynomial's 90 degrees.
PEER_SPECS = (
    ("the CasADi peer's node count", dict(modes=3, family="gauss", range_deg=90.0, nodes=8)),
    ("Gauss certified to 1e-9 on 90 deg", dict(modes=3, family="gauss", range_deg=90.0, tol=1e-9)),
)


def peer_kernels(folder: Path) -> list[CKernel]:
    """Generate PEER_SPECS into folder/c and describe them (marked extra["peer"])."""
    from flexgen.codegen.generate import generate_files
    from flexgen.codegen.render import write_files
    from flexgen.codegen.spec import KernelSpec

    out = []
    for why, spec in PEER_SPECS:
        files = generate_files(KernelSpec(**spec), ("c",))
        write_files(files, folder)
        header = folder / next(p for p in files if p.endswith(".h"))
        kernel = parse_header(header)
        kernel.extra.update(peer=why)
        out.append(kernel)
    return out


def build_harness(kernel: CKernel, workdir: Path, *, no_float: bool = False) -> Path:
    """Compile benchmarks/c/harness.c against one kernel; returns the executable."""
    exe = Path(workdir) / f"harness_{kernel.name}"
    cmd = [
        "gcc",
        *CFLAGS,
        "-I",
        str(kernel.header.parent),
        f"-DKERNEL={kernel.name}",
        f"-DKERNEL_UPPER={kernel.macro}",
        f'-DKERNEL_HEADER="{kernel.header.name}"',
    ]
    if no_float:
        cmd.append("-DHARNESS_NO_FLOAT")
    cmd += [str(HARNESS), str(kernel.source), "-lm", "-o", str(exe)]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return exe


def harness_command(kernel_name: str = "scm3") -> str:
    """The documented compile line (for the page)."""
    return (
        f"gcc {' '.join(CFLAGS)} -I generated/c -DKERNEL={kernel_name} "
        f"-DKERNEL_UPPER={kernel_name.upper()} '-DKERNEL_HEADER=\"{kernel_name}.h\"' "
        f"benchmarks/c/harness.c generated/c/{kernel_name}.c -lm"
    )


def _write_q(q: np.ndarray, workdir: Path, tag: str) -> Path:
    path = Path(workdir) / f"q_{tag}.bin"
    np.ascontiguousarray(q, dtype=np.float64).tofile(path)
    return path


def time_c_kernel(
    exe: Path, q: np.ndarray, *, repeats: int, target_ms: float, workdir: Path
) -> dict[str, float]:
    """Min ns per call (double, float) cycling the rows of q; a checksum defeats elimination."""
    qfile = _write_q(q, workdir, exe.name + "_time")
    out = subprocess.run(
        [str(exe), "bench", str(qfile), str(len(q)), str(repeats), str(target_ms)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    result = {}
    for line in out.splitlines():
        key, value = line.split()
        result[key] = float(value)
    return result


def eval_c_kernel(exe: Path, q: np.ndarray, modes: int, *, workdir: Path) -> dict:
    """Pose, J, H of the double and float entry points, and the in_range flags, for rows of q."""
    M, N = len(q), modes
    qfile = _write_q(q, workdir, exe.name + "_eval")
    ofile = Path(workdir) / f"{exe.name}_eval.out"
    subprocess.run(
        [str(exe), "eval", str(qfile), str(M), str(ofile)],
        check=True,
        capture_output=True,
        text=True,
    )
    data = np.fromfile(ofile, dtype=np.float64)
    n_out = 3 + 3 * N + 3 * N * N
    rows = data[: 2 * M * n_out].reshape(2, M, n_out)
    result = {"in_range": data[2 * M * n_out :].astype(bool)}
    for key, r in (("double", rows[0]), ("float", rows[1])):
        result[key] = (
            r[:, :3],
            r[:, 3 : 3 + 3 * N].reshape(M, 3, N),
            r[:, 3 + 3 * N :].reshape(M, 3, N, N),
        )
    return result


# -- an independent reference: 200-node Gauss-Legendre of cos/sin(phi(sigma)) in numpy ------
def angle_basis_poly(modes: int) -> list[Polynomial]:
    """B_n(sigma) = int_0^sigma P_n(2t - 1) dt as power series in sigma (numpy only)."""
    return [
        Legendre.basis(n, domain=[0, 1]).integ(lbnd=0).convert(kind=Polynomial)
        for n in range(modes)
    ]


class Reference:
    """pose, J, H of one flexure by high-order Gauss-Legendre quadrature, straight from the
    definitions x = int cos(phi), y = int sin(phi), dx/dq_i = -int sin(phi) B_i, ..."""

    def __init__(self, modes: int, nodes: int = REFERENCE_NODES):
        self.modes = N = modes
        x, w = np.polynomial.legendre.leggauss(nodes)
        self.sigma, self.w = (x + 1) / 2, w / 2
        self.basis = angle_basis_poly(N)
        self.B = np.stack([b(self.sigma) for b in self.basis], axis=1)  # (G, N)
        self.BB = np.einsum("gi,gj->gij", self.B, self.B).reshape(len(x), N * N)

    def evaluate(self, q: np.ndarray):
        q = np.atleast_2d(q)
        M, N = q.shape[0], self.modes
        phi = q @ self.B.T
        c, s = np.cos(phi) * self.w, np.sin(phi) * self.w
        pose = np.stack([c.sum(-1), s.sum(-1), q[:, 0]], axis=-1)
        J = np.zeros((M, 3, N))
        J[:, 0] = -s @ self.B
        J[:, 1] = c @ self.B
        J[:, 2, 0] = 1.0
        H = np.zeros((M, 3, N, N))
        H[:, 0] = (-c @ self.BB).reshape(M, N, N)
        H[:, 1] = (-s @ self.BB).reshape(M, N, N)
        return pose, J, H

    def max_abs_phi(self, q: np.ndarray) -> np.ndarray:
        """Exact max_sigma |phi(sigma)| on [0, 1] for each row of q: phi at the endpoints and at
        the real roots of kappa = phi' (companion-matrix eigenvalues, batched)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        M, N = q.shape
        width = N + 1
        P = np.zeros((N, width))  # P[n, k]: sigma^k coefficient of B_n
        for n, b in enumerate(self.basis):
            P[n, : len(b.coef)] = b.coef
        phi = q @ P  # (M, N+1) power coefficients of phi
        pts = [np.zeros((M, 1)), np.ones((M, 1))]
        if N >= 2:
            dphi = phi[:, 1:] * np.arange(1, width)  # kappa, degree N - 1
            for deg in range(N - 1, 0, -1):  # rows whose leading coefficient is this deg
                lead = dphi[:, deg]
                rows = (
                    (np.abs(lead) > 1e-300) & np.all(dphi[:, deg + 1 :] == 0, axis=1)
                    if deg < N - 1
                    else np.abs(lead) > 1e-300
                )
                if not rows.any():
                    continue
                c = dphi[rows, :deg] / lead[rows, None]  # monic: s^deg + c[deg-1] s^...
                comp = np.zeros((rows.sum(), deg, deg))
                comp[:, 0, :] = -c[:, ::-1]
                comp[:, np.arange(1, deg), np.arange(deg - 1)] = 1.0
                roots = np.linalg.eigvals(comp)
                r = np.where(
                    (np.abs(roots.imag) < 1e-9) & (roots.real >= 0) & (roots.real <= 1),
                    roots.real,
                    0.0,
                )
                full = np.zeros((M, N - 1))
                full[rows, :deg] = r
                pts.append(full)
                dphi = np.where(rows[:, None], 0.0, dphi)
        S = np.concatenate(pts, axis=1)  # (M, K) sample points
        vals = np.zeros_like(S)
        for k in range(width - 1, -1, -1):  # Horner, row-wise
            vals = vals * S + phi[:, k : k + 1]
        return np.max(np.abs(vals), axis=1)


def sample_q(
    modes: int,
    phi_max: float,
    count: int,
    rng: np.random.Generator,
    *,
    lo: float = 0.0,
    hi: float = 1.0,
    ref: Reference | None = None,
) -> np.ndarray:
    """count q's with random direction, scaled so that max|phi| = U(lo, hi) * phi_max."""
    ref = ref or Reference(modes, 8)
    d = rng.standard_normal((count, modes))
    d /= ref.max_abs_phi(d)[:, None]
    return d * (rng.uniform(lo, hi, count) * phi_max)[:, None]


def error_set(
    kernel: CKernel, rng: np.random.Generator, n_random: int, n_edge: int, ref: Reference
) -> tuple[np.ndarray, np.ndarray]:
    """In-range q's: n_random with max|phi|/PHI_MAX ~ U(0, 1), n_edge with U(0.9, 1), and
    (+-PHI_MAX, 0, ...). Returns (q, is_edge). A local kernel (certified at each q, PHI_MAX the
    arc bend its nodes certify) gets the same shapes at half its PHI_MAX, and its errors are
    taken where its in_range certifies them (``measure_c_error``)."""
    N, a = kernel.modes, kernel.phi_max
    if kernel.family == "local":
        a = a / 2
    axis = np.zeros((2, N))
    axis[:, 0] = (a, -a)
    q = np.concatenate(
        [
            sample_q(N, a, n_random, rng, ref=ref),
            sample_q(N, a, n_edge, rng, lo=0.9, hi=1.0, ref=ref),
            axis,
        ]
    )
    edge = np.zeros(len(q), bool)
    edge[n_random:] = True
    return q, edge


def max_errors(got, want) -> dict[str, float]:
    return {k: float(np.max(np.abs(g - w))) for k, g, w in zip(("pose", "J", "H"), got, want)}


def measure_c_error(
    kernel: CKernel, exe: Path, q: np.ndarray, edge: np.ndarray, ref: Reference, *, workdir: Path
) -> dict:
    out = eval_c_kernel(exe, q, kernel.modes, workdir=workdir)
    want = ref.evaluate(q)
    if kernel.family == "local":  # its bounds hold where in_range certifies them
        keep = out["in_range"].astype(bool)
        out = {**out, **{k: [a[keep] for a in out[k]] for k in ("double", "float")}}
        want = [a[keep] for a in want]
    res = {
        "double": max_errors(out["double"], want),
        "float": max_errors(out["float"], want),
        "count": len(q),
        "edge_count": int(edge.sum()),
        "in_range_edge": float(out["in_range"][edge].mean()),
        "in_range_all": float(out["in_range"].mean()),
    }
    return res


# -- NumPy modules, lambdify, quad -------------------------------------------------------------
def load_module(path: Path):
    spec = importlib.util.spec_from_file_location(f"bench_{path.stem}", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def numpy_modules(folder: Path = NUMPY_DIR) -> dict[str, object]:
    mods = {p.stem: load_module(p) for p in sorted(folder.glob("scm*.py"))}
    return dict(sorted(mods.items(), key=lambda kv: (kv[1].N, "gauss" in kv[0], kv[0])))


def throughput(fn, q: np.ndarray, *, budget_s: float, repeats: int) -> float:
    """Evaluations per second of fn on the batch q: best of `repeats` timed runs, each a loop
    long enough to take about budget_s / repeats."""
    batch = 1 if q.ndim == 1 else q.shape[0]
    fn(q)  # warm-up
    t0 = time.perf_counter()
    fn(q)
    one = max(time.perf_counter() - t0, 1e-7)
    loops = max(1, int(budget_s / repeats / one))
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(loops):
            fn(q)
        best = min(best, (time.perf_counter() - t0) / loops)
    return batch / best


def time_numpy_module(
    mod, batches, rng: np.random.Generator, *, budget_s: float, repeats: int
) -> dict[int, float]:
    out = {}
    for b in batches:
        q = sample_q(mod.N, TIMING_PHI, b, rng)
        out[b] = throughput(mod.evaluate, q[0] if b == 1 else q, budget_s=budget_s, repeats=repeats)
    return out


def lambdify_kernel(modes: int = 3, *, cse: bool = False):
    """sympy.lambdify of the pose/J/H expressions of FlexureKernel(KernelSpec(modes)).

    Returns (evaluate, seconds to derive, seconds to lambdify). evaluate(q (..., N)) returns the
    same (pose, J, H) arrays as a generated module."""
    import sympy as sp

    from flexgen.codegen.spec import KernelSpec
    from flexgen.symbolic.flexure import FlexureKernel

    t0 = time.perf_counter()
    kernel = FlexureKernel(KernelSpec(modes))
    e = kernel.expressions
    flat = (
        list(e["pose"])
        + [x for row in e["J"] for x in row]
        + [x for plane in e["H"] for row in plane for x in row]
    )
    t1 = time.perf_counter()
    f = sp.lambdify(kernel.q, flat, "numpy", cse=cse)
    t2 = time.perf_counter()
    N = modes

    def evaluate(q):
        q = np.asarray(q, dtype=float)
        vals = f(*np.moveaxis(q, -1, 0))
        out = np.empty(q.shape[:-1] + (len(vals),))
        for k, v in enumerate(vals):
            out[..., k] = v
        lead = q.shape[:-1]
        return (
            out[..., :3],
            out[..., 3 : 3 + 3 * N].reshape(lead + (3, N)),
            out[..., 3 + 3 * N :].reshape(lead + (3, N, N)),
        )

    return evaluate, t1 - t0, t2 - t1


def quad_evaluate(q: np.ndarray, *, epsabs: float = 1e-13, epsrel: float = 1e-13):
    """pose, J, H at one q, one scipy.integrate.quad per unique entry (H by symmetry)."""
    from scipy.integrate import quad

    N = len(q)
    coeffs = [list(b.coef[::-1]) for b in angle_basis_poly(N)]  # highest power first

    def horner(c, s):
        acc = 0.0
        for a in c:
            acc = acc * s + a
        return acc

    def phi(s):
        return sum(float(qn) * horner(c, s) for qn, c in zip(q, coeffs))

    def integral(f):
        return quad(f, 0.0, 1.0, epsabs=epsabs, epsrel=epsrel, limit=100)[0]

    pose = np.array(
        [integral(lambda s: math.cos(phi(s))), integral(lambda s: math.sin(phi(s))), q[0]]
    )
    J = np.zeros((3, N))
    H = np.zeros((3, N, N))
    J[2, 0] = 1.0
    for i in range(N):
        bi = coeffs[i]
        # the integrands are evaluated at once, inside integral(): the loop variables are current
        J[0, i] = -integral(lambda s: math.sin(phi(s)) * horner(bi, s))  # noqa: B023
        J[1, i] = integral(lambda s: math.cos(phi(s)) * horner(bi, s))  # noqa: B023
        for j in range(i, N):
            bj = coeffs[j]
            H[0, i, j] = H[0, j, i] = -integral(
                lambda s: math.cos(phi(s)) * horner(bi, s) * horner(bj, s)  # noqa: B023
            )
            H[1, i, j] = H[1, j, i] = -integral(
                lambda s: math.sin(phi(s)) * horner(bi, s) * horner(bj, s)  # noqa: B023
            )
    return pose, J, H


# -- the run -----------------------------------------------------------------------------------
@dataclass
class Config:
    quick: bool
    c_rounds: int
    c_repeats: int
    c_target_ms: float
    n_random: int
    n_edge: int
    numpy_batches: tuple = (1, 1000, 100000)
    numpy_budget_s: float = 1.0
    numpy_repeats: int = 5
    numpy_modules: tuple | None = None  # None: all
    lambdify_budget_s: float = 1.0
    quad_calls: int = 5

    @classmethod
    def full(cls) -> Config:
        return cls(
            quick=False,
            c_rounds=5,
            c_repeats=15,
            c_target_ms=5,
            n_random=3000,
            n_edge=3000,
            numpy_budget_s=0.6,
        )

    @classmethod
    def quick_mode(cls) -> Config:
        return cls(
            quick=True,
            c_rounds=2,
            c_repeats=5,
            c_target_ms=5,
            n_random=300,
            n_edge=300,
            numpy_budget_s=0.25,
            numpy_repeats=3,
            numpy_modules=NUMPY_REQUIRED,
            lambdify_budget_s=0.3,
            quad_calls=1,
        )


def run_c(cfg: Config, workdir: Path, kernels: list[CKernel] | None = None) -> list[dict]:
    """Compile every kernel, time them in `c_rounds` interleaved rounds (min over rounds and
    repeats, so a burst of load from other processes hits every kernel alike and the min
    survives it), then measure each kernel's error."""
    kernels = kernels or c_kernels()
    refs = {N: Reference(N) for N in sorted({k.modes for k in kernels})}
    timing_q = {
        N: sample_q(N, TIMING_PHI, TIMING_SET, np.random.default_rng([SEED, N]), ref=ref)
        for N, ref in refs.items()
    }
    exes = {}
    for k in kernels:
        log(f"C {k.name}: compiling")
        exes[k.name] = build_harness(k, workdir)
    best = {k.name: {"double": math.inf, "float": math.inf} for k in kernels}
    rounds: dict[tuple[str, str], list[float]] = {}
    for rnd in range(cfg.c_rounds):
        log(
            f"C timing round {rnd + 1}/{cfg.c_rounds} ({cfg.c_repeats} repeats x "
            f"~{cfg.c_target_ms:g} ms per kernel and type)"
        )
        for k in kernels:
            t = time_c_kernel(
                exes[k.name],
                timing_q[k.modes],
                repeats=cfg.c_repeats,
                target_ms=cfg.c_target_ms,
                workdir=workdir,
            )
            for key in ("double", "float"):
                best[k.name][key] = min(best[k.name][key], t[key])
                rounds.setdefault((k.name, key), []).append(t[key])
    rows = []
    for k in kernels:
        t = best[k.name]
        q, edge = error_set(
            k, np.random.default_rng([SEED, 1, k.modes]), cfg.n_random, cfg.n_edge, refs[k.modes]
        )
        err = measure_c_error(k, exes[k.name], q, edge, refs[k.modes], workdir=workdir)
        log(
            f"C {k.name}: double {t['double']:.1f} ns, float {t['float']:.1f} ns; pose error "
            f"{err['double']['pose']:.2e} (bound {k.error_bound:.2e})"
        )
        spread = max(
            max(rounds[k.name, key]) / min(rounds[k.name, key]) - 1 for key in ("double", "float")
        )
        rows.append({"kernel": k, "time": t, "error": err, "spread": spread})
    return rows


def run_numpy(cfg: Config) -> dict[str, dict[int, float]]:
    out = {}
    for name, mod in numpy_modules().items():
        if cfg.numpy_modules is not None and name not in cfg.numpy_modules:
            continue
        log(f"NumPy {name}: batches {', '.join(str(b) for b in cfg.numpy_batches)}")
        out[name] = time_numpy_module(
            mod,
            cfg.numpy_batches,
            np.random.default_rng([SEED, 2]),
            budget_s=cfg.numpy_budget_s,
            repeats=cfg.numpy_repeats,
        )
    return out


def run_baselines(cfg: Config) -> dict:
    """scm3 through sympy.lambdify (plain and cse=True) and through scipy quad."""
    mod = load_module(NUMPY_DIR / "scm3.py")
    rng = np.random.default_rng([SEED, 3])
    q1 = sample_q(3, TIMING_PHI, 1, rng)[0]
    qb = sample_q(3, TIMING_PHI, 100000, rng)
    res = {}
    for label, cse in (("lambdify", False), ("lambdify_cse", True)):
        log(f"{label}: deriving and lambdifying scm3")
        fn, t_derive, t_lambdify = lambdify_kernel(3, cse=cse)
        agree = max(
            float(np.max(np.abs(a - b))) for a, b in zip(fn(qb[:1000]), mod.evaluate(qb[:1000]))
        )
        log(f"{label}: timing batch 1 and 1e5")
        res[label] = {
            "derive_s": t_derive,
            "lambdify_s": t_lambdify,
            "agree": agree,
            1: throughput(fn, q1, budget_s=cfg.lambdify_budget_s, repeats=cfg.numpy_repeats),
            100000: throughput(
                fn, qb, budget_s=cfg.lambdify_budget_s, repeats=max(1, cfg.numpy_repeats // 2)
            ),
        }
    log("numpy scm3 at the same batches (for the ratio)")
    res["numpy"] = {
        1: throughput(mod.evaluate, q1, budget_s=cfg.lambdify_budget_s, repeats=cfg.numpy_repeats),
        100000: throughput(
            mod.evaluate, qb, budget_s=cfg.lambdify_budget_s, repeats=max(1, cfg.numpy_repeats // 2)
        ),
    }
    log(f"scipy quad: {cfg.quad_calls} full evaluations of scm3 pose/J/H at one q")
    ref = Reference(3)
    quad_evaluate(q1)  # warm-up: imports scipy.integrate
    best, err = math.inf, 0.0
    for _ in range(cfg.quad_calls):
        t0 = time.perf_counter()
        got = quad_evaluate(q1)
        best = min(best, time.perf_counter() - t0)
        err = max(max_errors(got, [x[0] for x in ref.evaluate(q1)]).values())
    res["quad"] = {
        "evals_per_s": 1 / best,
        "seconds": best,
        "error": err,
        "integrals": 2 + 2 * 3 + 3 * 4,
    }
    return res


# -- the page ----------------------------------------------------------------------------------
def _rate(x: float) -> str:
    if x >= 1e6:
        return f"{x / 1e6:.2f} M"
    if x >= 1e3:
        return f"{x / 1e3:.1f} k"
    return f"{x:.3g}"


TIE = 1.10  # gauss within 10 % of poly counts as a tie (timing noise on a shared machine)


def recommendation(c_rows: list[dict]) -> tuple[list[str], list[str], dict]:
    """Per N: the fastest C kernel (double) whose measured pose error meets TARGET_ERROR, and
    the gauss/poly time ratio where both exist; then the policy that follows from them."""
    lines, facts = [], {}
    by_n: dict[int, list[dict]] = {}
    for r in c_rows:
        # checked-in kernels certified on a range only (the local ones: a line of their own)
        if not r["kernel"].extra.get("peer") and r["kernel"].family != "local":
            by_n.setdefault(r["kernel"].modes, []).append(r)
    for N, rows in sorted(by_n.items()):
        ok = [r for r in rows if r["error"]["double"]["pose"] <= TARGET_ERROR]
        best = min(ok, key=lambda r: r["time"]["double"]) if ok else None
        poly = [r for r in ok if r["kernel"].family == "poly"]
        gauss = [r for r in ok if r["kernel"].family == "gauss"]
        facts[N] = {"best": best and best["kernel"].name}
        if not best:
            lines.append(f"- N = {N}: no kernel meets {TARGET_ERROR:g} measured.")
            continue
        text = (
            f"- N = {N}: fastest is `{best['kernel'].name}`, {best['time']['double']:.0f} ns "
            f"(measured pose error {best['error']['double']['pose']:.1e})"
        )
        if poly and gauss:
            p, g = poly[0], gauss[0]
            ratio = g["time"]["double"] / p["time"]["double"]
            ratio_f = g["time"]["float"] / p["time"]["float"]
            facts[N].update(
                ratio=ratio, ratio_f=ratio_f, poly=p["kernel"].name, gauss=g["kernel"].name
            )
            text += (
                f"; gauss/poly time `{g['kernel'].name}`/`{p['kernel'].name}` = "
                f"{ratio:.2f} in double, {ratio_f:.2f} in float"
            )
        lines.append(text + ".")
    policy = []
    pairs = {N: f for N, f in facts.items() if "ratio" in f}
    if pairs:
        poly_n = [N for N, f in pairs.items() if f["ratio"] > TIE]
        gauss_n = [N for N, f in pairs.items() if f["ratio"] <= TIE]
        if poly_n:
            lo = min(pairs[N]["ratio"] for N in poly_n)
            hi = max(pairs[N]["ratio"] for N in poly_n)
            span = f"{lo:.2f}x" if f"{lo:.2f}" == f"{hi:.2f}" else f"{lo:.2f}-{hi:.2f}x"
            policy.append(
                f"For N = {', '.join(map(str, poly_n))} the poly kernel is faster by more than "
                f"{100 * (TIE - 1):.0f} % (the "
                f"gauss kernel costs {span} as much per call in double): of the two, the runtime's "
                '`"auto"` calls the poly kernel while `in_range(q)` holds and the gauss kernel '
                "(certified to 180 deg, valid at any angle) when it does not; before either it "
                "tries the local kernel where that certifies q (faster still: section 1)."
            )
        if gauss_n:
            r = ", ".join(f"{pairs[N]['ratio']:.2f}" for N in gauss_n)
            policy.append(
                f"For N = {', '.join(map(str, gauss_n))} the gauss kernel is as fast or within "
                f"{100 * (TIE - 1):.0f} % (gauss/poly {r}), a tie at this noise level: the runtime "
                "should prefer the gauss kernel there; it is valid at any angle and needs no "
                "range check."
            )
        only = [N for N in facts if N not in pairs and facts[N]["best"]]
        if only:
            policy.append(
                f"N = {', '.join(map(str, only))} have only one kernel; use it (poly "
                "kernels only while `in_range(q)` holds)."
            )
        fl = [f["ratio_f"] for f in pairs.values()]
        policy.append(
            f"In float the gauss kernels close the gap (gauss/poly {min(fl):.2f}-"
            f"{max(fl):.2f}; `cosf`/`sinf` are much cheaper than `cos`/`sin`), but no "
            "float kernel meets 1e-9."
        )
    return lines, policy, facts


def _local_text(c_rows: list[dict]) -> str:
    """Each local kernel's time against the polynomial kernel of its mode count (same run)."""
    poly = {r["kernel"].modes: r for r in c_rows if r["kernel"].family == "poly"}
    parts = [
        f"`{r['kernel'].name}` {r['time']['double'] / poly[r['kernel'].modes]['time']['double']:.2f}"
        for r in c_rows
        if r["kernel"].family == "local" and r["kernel"].modes in poly
    ]
    if not parts:
        return ""
    return (
        "Time of each local kernel against the polynomial kernel of its mode count, double: "
        + ", ".join(parts)
        + "."
    )


def _span(lo: float, hi: float) -> str:
    return f"{lo:.2f}" if f"{lo:.2f}" == f"{hi:.2f}" else f"{lo:.2f}-{hi:.2f}"


def _spread_text(c_rows: list[dict]) -> str:
    spreads = sorted(r["spread"] for r in c_rows if "spread" in r and len(c_rows))
    if not spreads or not all(math.isfinite(x) for x in spreads):
        return ""
    return (
        f"; the per-round minima of one C kernel differ by {100 * spreads[len(spreads) // 2]:.0f} % "
        f"(median over kernels, max {100 * spreads[-1]:.0f} %), a measure of the run-to-run "
        "noise of this page"
    )


def git_state() -> str:
    """Commit of the checked-in kernels and whether generated/ differs from it."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--", "generated"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return f"generated/ as of commit {head}" + (
        " with uncommitted changes" if dirty else " (clean)"
    )


def render_markdown(
    info: dict, cfg: Config, c_rows: list[dict], np_res: dict, base: dict, elapsed: float
) -> str:
    L: list[str] = []
    mode = "--quick" if cfg.quick else "full"
    L += [
        "# Kernel benchmarks",
        "",
        f"Generated by `python benchmarks/kernels.py{' --quick' if cfg.quick else ''}` "
        f"({mode} mode, {elapsed:.0f} s); every number below comes from that one run. "
        "Do not edit by hand; rerun with `make bench-kernels`.",
        "",
        "## Machine",
        "",
        f"- CPU: {info['cpu']} ({info['cores']} logical cores)",
        f"- C compiler: {info['gcc']}; flags `{' '.join(CFLAGS)}` (no `-march`, no `-ffast-math`)",
        f"- Python {info['python']}, numpy {info['numpy']}, scipy {info['scipy']}, "
        f"sympy {info['sympy']}; BLAS threads: OPENBLAS_NUM_THREADS="
        f"{os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}",
        f"- Load average (1 min) at start / end: {info.get('load_start', '?')} / "
        f"{info.get('load_end', '?')}. The machine is shared; every timing is a minimum over "
        "repeats to suppress interference" + _spread_text(c_rows) + ".",
        f"- Kernels: {info.get('git', 'unknown')}",
        "",
    ]

    L += [
        "## 1. C kernels: time per call and measured error",
        "",
        "Each kernel is compiled with `benchmarks/c/harness.c` in a separate translation unit "
        f"(`{harness_command()}`), so the call cannot be inlined or dropped; every call's "
        "outputs feed a checksum. Timing: "
        f"{TIMING_SET} seeded q's with max|phi| ~ U(0, 90 deg) (the same q's for every kernel "
        f"of one N), cycled in a loop; `clock_gettime(CLOCK_MONOTONIC)`; min over "
        f"{cfg.c_rounds} interleaved rounds (all kernels per round) x {cfg.c_repeats} repeats "
        f"of ~{cfg.c_target_ms:g} ms each. One call fills pose, J and H.",
        "",
        f"Error: max |kernel - reference| over {c_rows[0]['error']['count'] if c_rows else 0} "
        f"seeded q's per kernel: {cfg.n_random} with max|phi|/PHI_MAX ~ U(0, 1), "
        f"{cfg.n_edge} near the edge (max|phi| scaled to U(0.9, 1.0) PHI_MAX, computed "
        "exactly from the roots of kappa), and q = (+-PHI_MAX, 0, ...). Reference: "
        f"{REFERENCE_NODES}-node Gauss-Legendre quadrature of cos/sin(phi(sigma)) (and of "
        "sin/cos times B_i, B_i B_j for J and H), computed in numpy from numpy's own Legendre "
        "polynomials, independent of flexgen. Units of L.",
        "",
        "| kernel | N | PHI_MAX | ops (header) | double ns/call | float ns/call | "
        "ns/op (double) | ERROR_BOUND | measured pose err (double) | <= 1e-9? | "
        "measured J err | measured H err | pose err (float) | in_range accepts, near-edge |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in c_rows:
        k, t, e = r["kernel"], r["time"], r["error"]
        d = e["double"]
        L.append(
            f"| `{k.name}`{' (not checked in)' if k.extra.get('peer') else ''} | {k.modes} | "
            f"{math.degrees(k.phi_max):.0f} deg | {k.ops} | "
            f"{t['double']:.1f} | {t['float']:.1f} | {t['double'] / k.ops_total:.3f} | "
            f"{k.error_bound:.2e} | {d['pose']:.2e} | "
            f"{'yes' if d['pose'] <= TARGET_ERROR else 'NO'} | {d['J']:.1e} "
            f"(bound {k.jacobian_bound:.1e}) | {d['H']:.1e} (bound {k.hessian_bound:.1e}) | "
            f"{e['float']['pose']:.1e} | {100 * e['in_range_edge']:.0f} % |"
        )
    peers = [r["kernel"] for r in c_rows if r["kernel"].extra.get("peer")]
    if peers:
        L += [
            "",
            "Rows marked (not checked in) are generated for this run only, for comparison: "
            + "; ".join(f"`{k.name}`: {k.extra['peer']}" for k in peers)
            + ". Section 4 "
            "considers the checked-in kernels certified on a range only.",
        ]
    within = all(r["error"]["double"]["pose"] <= r["kernel"].error_bound for r in c_rows)
    L += [
        "",
        (
            "Every kernel's measured double pose error is within its certified ERROR_BOUND."
            if within
            else "**At least one kernel's measured pose error exceeds its "
            "ERROR_BOUND** (see the table)."
        ),
        "The float twins are limited by float rounding (~1e-7 relative), not by the "
        "interpolation or quadrature; they do not meet 1e-9 and are meant for speed only. "
        "The last column is the share of the near-edge q's (all truly in range) that the "
        "conservative `in_range` check accepts.",
        "",
        "The local kernels (`scmN_localG`, certified at each q; PHI_MAX is the constant-"
        "curvature arc their nodes certify) are measured on the same shapes at half their "
        "PHI_MAX, and their errors over the q's their `in_range` certifies; the last column is "
        "then the share of the near-edge q's it certifies. " + _local_text(c_rows),
        "",
    ]

    L += [
        "## 2. Generated NumPy modules: throughput",
        "",
        "Evaluations per second of `evaluate(q)` (pose, J and H) on a batch of seeded q's "
        "(max|phi| ~ U(0, 90 deg)); best of several timed loops. Batch 1 is one q of shape (N,).",
        "",
        "| module | batch 1 | batch 1e3 | batch 1e5 |",
        "|---|---|---|---|",
    ]
    for name, r in np_res.items():
        L.append(
            f"| `{name}` | " + " | ".join(f"{_rate(r[b])}/s" for b in cfg.numpy_batches) + " |"
        )
    L.append("")

    if base:
        lam, lcse, npy, qd = base["lambdify"], base["lambdify_cse"], base["numpy"], base["quad"]
        L += [
            "## 3. The same scm3 expressions through sympy.lambdify and scipy quad",
            "",
            "`sympy.lambdify(q, [pose, J, H entries], 'numpy')` of "
            "`FlexureKernel(KernelSpec(3)).expressions` (the very expressions flexgen prints), "
            "wrapped to return the same arrays as the module; and, with `cse=True`. "
            f"Deriving the expressions took {lam['derive_s']:.2f} s; lambdify "
            f"{lam['lambdify_s']:.2f} s (plain) and {lcse['lambdify_s']:.2f} s (cse). "
            f"Max difference from the generated module: {lam['agree']:.1e} (plain), "
            f"{lcse['agree']:.1e} (cse).",
            "",
            "| implementation | batch 1 | batch 1e5 | generated module is faster by |",
            "|---|---|---|---|",
        ]
        for label, r in (
            ("generated `scm3.py`", npy),
            ("lambdify", lam),
            ("lambdify, cse=True", lcse),
        ):
            ratio = (
                "-"
                if r is npy
                else f"{npy[1] / r[1]:.1f}x (batch 1), {npy[100000] / r[100000]:.1f}x (batch 1e5)"
            )
            L.append(f"| {label} | {_rate(r[1])}/s | {_rate(r[100000])}/s | {ratio} |")
        L += [
            f"| scipy.integrate.quad, {qd['integrals']} integrals (one per unique entry, "
            f"epsabs = epsrel = 1e-13) | {qd['evals_per_s']:.3g}/s ({qd['seconds'] * 1e3:.0f} "
            f"ms per q; max error {qd['error']:.0e}) | - | "
            f"{npy[1] / qd['evals_per_s']:.0f}x (batch 1) |",
            "",
        ]
        c3 = next((r for r in c_rows if r["kernel"].name == "scm3"), None)
        if c3:
            L += [
                f"For scale: the C kernel `scm3` does one evaluation in "
                f"{c3['time']['double']:.0f} ns, i.e. {_rate(1e9 / c3['time']['double'])} "
                f"evaluations/s on one core; {1e9 / c3['time']['double'] / npy[100000]:.1f}x "
                "the NumPy module at batch 1e5 and "
                f"{1e9 / c3['time']['double'] / npy[1]:.0f}x it at batch 1.",
                "",
            ]

    lines, policy, facts = recommendation(c_rows)
    all_ok = all(r["error"]["double"]["pose"] <= TARGET_ERROR for r in c_rows)
    L += [
        "## 4. Which kernel should the runtime prefer",
        "",
        (
            f"Every kernel's measured double pose error meets {TARGET_ERROR:g}"
            if all_ok
            else f"Not every kernel meets {TARGET_ERROR:g} (see section 1)"
        )
        + "; among the kernels certified on a range (polynomial and Gauss; the local kernels, "
        "certified at each q, are compared in section 1), the fastest per N that does (C, double):",
        "",
    ]
    L += lines + [""] + [" ".join(policy)]
    if np_res:
        b0, b = cfg.numpy_batches[0], cfg.numpy_batches[-1]
        pairs = [
            (f["poly"], f["gauss"])
            for N, f in sorted(facts.items())
            if f.get("poly") in np_res and f.get("gauss") in np_res
        ]
        if pairs:
            L += [
                "",
                "NumPy modules, poly/gauss throughput ratio (> 1: poly faster):",
                "",
                f"| pair | batch {b0:g} | batch {b:g} |",
                "|---|---|---|",
            ]
            L += [
                f"| `{p}` / `{g}` | {np_res[p][b0] / np_res[g][b0]:.2f} | "
                f"{np_res[p][b] / np_res[g][b]:.2f} |"
                for p, g in pairs
            ]
            r1 = [np_res[p][b0] / np_res[g][b0] for p, g in pairs]
            rb = [np_res[p][b] / np_res[g][b] for p, g in pairs]
            L += [
                "",
                f"In NumPy the per-call overhead decides at batch {b0:g} (poly/gauss "
                f"{_span(min(r1), max(r1))}: the poly module's `_trig` is six Horner "
                "polynomials, dozens of small numpy calls, where the gauss module calls "
                f"`np.cos` and `np.sin` once each), the arithmetic at batch {b:g} (poly/gauss "
                f"{_span(min(rb), max(rb))}). A NumPy caller evaluating one q at a time "
                "should prefer the gauss module; a batched caller the poly module (when in "
                "range), as in C."
                if max(r1) < 1 < min(rb)
                else f"poly/gauss throughput in NumPy: {_span(min(r1), max(r1))} at batch {b0:g}, "
                f"{_span(min(rb), max(rb))} at batch {b:g}.",
            ]
    L.append("")
    return "\n".join(L)


def _loadavg() -> str:
    try:
        return Path("/proc/loadavg").read_text().split()[0]
    except OSError:
        return "?"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats and samples (< 60 s)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "benchmarks.md"))
    args = ap.parse_args(argv)
    cfg = Config.quick_mode() if args.quick else Config.full()
    t0 = time.perf_counter()
    info = machine_info()
    info["load_start"] = _loadavg()
    info["git"] = git_state()
    log(
        f"{info['cpu']}; {info['gcc']}; numpy {info['numpy']}; mode "
        f"{'quick' if cfg.quick else 'full'}"
    )
    with tempfile.TemporaryDirectory(prefix="flexgen-bench-") as tmp:
        c_rows = run_c(cfg, Path(tmp), c_kernels() + peer_kernels(Path(tmp) / "peers"))
    np_res = run_numpy(cfg)
    base = run_baselines(cfg)
    elapsed = time.perf_counter() - t0
    info["load_end"] = _loadavg()
    text = render_markdown(info, cfg, c_rows, np_res, base, elapsed)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    log(f"wrote {out} in {elapsed:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
