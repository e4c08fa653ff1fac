"""The CasADi peer of issue 9: flexgen's controller against an expert's CasADi Newton solve.

    python benchmarks/casadi_peer.py --out docs/controller-speed.md      (make bench-controller)

Two scenes, each solved by C programs built in one private temporary folder:

- one flexure (3 modes, EI = L = 1) under the tip force (0, -3) EI/L^2;
- the two-link finger of examples/two_link_finger.toml (tendon at 10 N, 0.2 N on the pad).

The CasADi peer writes the scene's whole potential in SX (3 Legendre curvature modes and 8
Gauss-Legendre nodes per flexure), generates ONE fused C function for the potential, its
gradient and Hessian, the output poses and their Jacobians, and solves with the hand-written
damped Newton and LDL^T Cholesky of benchmarks/casadi/casadi_newton.c. flexgen's side is the scene
controller of ``flexgen generate --scene`` when this checkout has it, and the solver core
(``fg_solve`` on an ``fg_problem`` filled from the scene) beside it.

Every contender's answer is checked against ``flexgen.solve`` first (poses to 1e-10 of the
flexure length, compliances to 1e-8 relative): a disagreement exits 1 with one line. Then one C
timing program per contender (benchmarks/casadi/harness.c, gcc -O2 -std=c99 for all) is run in
interleaved rounds; the median of the per-round means is reported, with the ratios of one run.
casadi is a benchmark-only dependency (``pip install -e .[bench]``).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
C_DIR = Path(__file__).resolve().parent / "casadi"
sys.path.insert(0, str(ROOT))  # this checkout's flexgen, installed or not (as every benchmark)
FINGER = ROOT / "examples" / "two_link_finger.toml"
CC = "gcc"
CFLAGS = ["-O2", "-std=c99"]  # every contender: no -ffast-math, no -march, no LTO
MODES, NODES = 3, 8  # the CasADi model: Legendre curvature modes, Gauss nodes per flexure
REFERENCE_NODES = 40  # the 3-mode model itself: quadrature converged to rounding
WARM_SCALE = 1.01  # warm solves: every load and tension changed by 1 %
POSE_TOL, COMPLIANCE_TOL = 1e-10, 1e-8  # agreement with flexgen.solve
# compliance rows compared per scene (and reported by its CasADi peer): the flexure's 2x2 tip
# position compliance (issue 9's peer), the finger's 3x3 d(x, y, angle)/d(fx, fy, moment)
ROWS = {"flexure": 2, "finger": 3}
FLEXURE_TOML = """\
# one flexure, 3 modes, EI = L = 1, tip force (0, -3) EI/L^2 (written by benchmarks/casadi_peer.py)
name = "one flexure, tip force (0, -3)"

[model]
kind = "scm"
modes = 3

[[flexure]]
name = "beam"
length = 1.0
EI = 1.0

[[load]]
point = "beam.tip"
force = [0.0, -3.0]

[output]
points = ["beam.tip"]
"""


class Disagreement(Exception):
    """A contender's answer differs from flexgen.solve's."""


# ---- the scene, read independently of flexgen ------------------------------------------------


@dataclass(frozen=True)
class Flexure:
    name: str
    parent: str
    at: tuple[float, float, float]
    length: float
    EI: float


@dataclass(frozen=True)
class SceneSpec:
    """What the CasADi peer reads from a scene file: bodies, points, loads, tendons, outputs."""

    flexures: tuple[Flexure, ...]
    link_parent: dict[str, str]  # link -> the flexure whose tip frame it is
    points: dict[str, tuple[float, float]]  # "body.point" -> coordinates in the body's frame
    loads: tuple[tuple[str, tuple[float, float, float]], ...]  # point, (fx, fy, moment)
    tendons: tuple[tuple[float, tuple[str, ...]], ...]  # tension, route
    outputs: tuple[str, ...]


def xy(v: Sequence[float]) -> tuple[float, float]:
    return (float(v[0]), float(v[1]))


def read_scene(path: Path) -> SceneSpec:
    """A scene of scm flexures (3 modes), links, point loads and tendons, with the default
    parents of docs/scene.md (file order across [[flexure]] and [[link]])."""
    text = path.read_text()
    data = tomllib.loads(text)
    model = data.get("model", {})
    if model.get("kind", "scm") != "scm" or model.get("modes", MODES) != MODES:
        raise ValueError(f"{path}: the CasADi peer models scm flexures with {MODES} modes")
    kinds = re.findall(r"^\s*\[\[(flexure|link)\]\]", text, flags=re.MULTILINE)
    tables = {"flexure": iter(data.get("flexure", [])), "link": iter(data.get("link", []))}
    flexures: list[Flexure] = []
    link_parent: dict[str, str] = {}
    points = {f"base.{k}": xy(v) for k, v in data.get("base", {}).get("points", {}).items()}
    last_body, last_flexure = "base", None
    for kind in kinds:
        t = next(tables[kind])
        if kind == "flexure":
            if any(key in t for key in ("model", "kind", "modes", "kernel")):
                raise ValueError(f"{path}: flexure {t['name']!r} has its own model")
            EI = t.get("EI") or t["E"] * t["width"] * t["thickness"] ** 3 / 12.0
            ax, ay, ath = (float(v) for v in t.get("at", (0.0, 0.0, 0.0)))
            parent = t.get("parent", last_body)
            at = (ax, ay, ath)
            flexures.append(Flexure(t["name"], parent, at, float(t["length"]), float(EI)))
            points[f"{t['name']}.tip"] = (0.0, 0.0)
            last_flexure = t["name"]
        else:
            parent = t.get("parent", last_flexure)
            if parent is None:
                raise ValueError(f"{path}: link {t['name']!r} has no flexure before it")
            link_parent[t["name"]] = parent
            for k, v in t.get("points", {}).items():
                points[f"{t['name']}.{k}"] = xy(v)
        last_body = t["name"]
    loads = tuple(
        (ld["point"], (*xy(ld.get("force", (0.0, 0.0))), float(ld.get("moment", 0.0))))
        for ld in data.get("load", [])
    )
    tendons = tuple((float(t["tension"]), tuple(t["route"])) for t in data.get("tendon", []))
    outputs = tuple(data.get("output", {}).get("points", ()))
    return SceneSpec(tuple(flexures), link_parent, points, loads, tendons, outputs)


def scene_inputs(spec: SceneSpec) -> np.ndarray:
    """The scene's inputs as the kernels take them: fx, fy, moment per load, then tensions."""
    return np.array([v for _, f in spec.loads for v in f] + [t for t, _ in spec.tendons])


# ---- the CasADi model -------------------------------------------------------------------------


def mode_shapes(modes: int, nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """B_n(sigma_k) (modes x nodes) at the Gauss-Legendre nodes on [0, 1], and the weights:
    B_0 = sigma, B_n = (P_{n+1}(2 sigma - 1) - P_{n-1}(2 sigma - 1)) / (2 (2n + 1))."""
    from numpy.polynomial import legendre

    x, w = legendre.leggauss(nodes)
    B = np.empty((modes, nodes))
    B[0] = (x + 1.0) / 2.0
    for n in range(1, modes):
        B[n] = legendre.legval(x, np.eye(n + 2)[n + 1]) - legendre.legval(x, np.eye(n + 2)[n - 1])
        B[n] /= 2.0 * (2 * n + 1)
    return B, w / 2.0


def energy_weights(modes: int) -> np.ndarray:
    """U = EI/(2L) sum_n w_n q_n^2, w_n = 1/(2n + 1) (model-notes.md; flexgen's ENERGY_WEIGHTS)."""
    return 1.0 / (2.0 * np.arange(modes) + 1.0)


@dataclass
class PeerModel:
    """The fused CasADi kernel of a scene and what its Newton loop needs."""

    function: Any  # casadi.Function (q, u) -> (Pi, r, K, pose, GT)
    ndof: int
    noutputs: int
    stiffness: np.ndarray  # diagonal of the elastic energy's Hessian
    inputs: np.ndarray  # the scene's loads and tensions (scene_inputs)


def compose(frame: tuple[Any, Any, Any], v: Sequence[Any], phi: Any = 0.0) -> tuple[Any, Any, Any]:
    """The frame (x, y, angle) moved by v in its own axes and turned by phi."""
    import casadi as ca

    x, y, th = frame
    c, s = ca.cos(th), ca.sin(th)
    return (x + c * v[0] - s * v[1], y + s * v[0] + c * v[1], th + phi)


def peer_model(spec: SceneSpec, name: str, nodes: int = NODES) -> PeerModel:
    """The whole potential Pi(q; u) = U(q) - sum (f . r_p + m theta_p) + sum T l(q) in SX."""
    import casadi as ca

    B, w = mode_shapes(MODES, nodes)
    ndof = MODES * len(spec.flexures)
    q = ca.SX.sym("q", ndof)
    u = ca.SX.sym("u", 3 * len(spec.loads) + len(spec.tendons))
    frames: dict[str, tuple[Any, Any, Any]] = {"base": (0.0, 0.0, 0.0)}
    stiffness = np.empty(ndof)
    U: Any = 0
    for i, f in enumerate(spec.flexures):
        qi = q[MODES * i : MODES * (i + 1)]
        parent = frames[spec.link_parent.get(f.parent, f.parent)]
        root = compose(parent, f.at[:2], f.at[2])
        phi = [ca.dot(qi, ca.DM(B[:, k])) for k in range(nodes)]
        tip_x = f.length * sum(w[k] * ca.cos(phi[k]) for k in range(nodes))
        tip_y = f.length * sum(w[k] * ca.sin(phi[k]) for k in range(nodes))
        frames[f.name] = compose(root, (tip_x, tip_y), qi[0])
        k_i = f.EI / f.length * energy_weights(MODES)
        stiffness[MODES * i : MODES * (i + 1)] = k_i
        U += 0.5 * ca.dot(ca.DM(k_i), qi * qi)

    def point(ref: str) -> tuple[Any, Any, Any]:
        body = ref.split(".")[0]
        return compose(frames[spec.link_parent.get(body, body)], spec.points[ref])

    Pi = U
    for j, (ref, _) in enumerate(spec.loads):
        x, y, th = point(ref)
        Pi -= u[3 * j] * x + u[3 * j + 1] * y + u[3 * j + 2] * th
    for j, (_, route) in enumerate(spec.tendons):
        pts = [point(ref) for ref in route]
        length = sum(ca.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(pts, pts[1:]))
        Pi += u[3 * len(spec.loads) + j] * length
    pose = ca.vertcat(*[ca.vertcat(*point(ref)) for ref in spec.outputs])
    K, r = ca.hessian(Pi, q)
    GT = ca.jacobian(pose, q).T
    outs = [Pi, r, K, pose, GT]
    # cse: one node per distinct subexpression (SX differentiation writes cos and sin of each
    # node angle afresh in every derivative; merged, each is evaluated once)
    function = ca.Function(name, [q, u], [ca.densify(e) for e in outs], {"cse": True})
    return PeerModel(
        function,
        ndof,
        len(spec.outputs),
        stiffness,
        scene_inputs(spec),
    )


def c_array(values: Sequence[float] | np.ndarray) -> str:
    return "{" + ", ".join(repr(float(v)) for v in np.ravel(values)) + "}"


def write_casadi_sources(model: PeerModel, rows: int, folder: Path) -> list[Path]:
    """The generated kernel (its .c and .h) and peer_casadi.h, for casadi_newton.c."""
    import casadi as ca

    name = model.function.name()
    cg = ca.CodeGenerator(f"{name}.c", {"with_header": True})
    cg.add(model.function)
    cg.generate(str(folder) + os.sep)
    nin = model.inputs.size
    header = f"""/* generated by benchmarks/casadi_peer.py: the CasADi peer's sizes and inputs */
#include "{name}.h"
#define PEER_NDOF {model.ndof}
#define PEER_NOUT {model.noutputs}
#define PEER_ROWS {rows}
#define PEER_KERNEL {name}
#define PEER_SZ_IW {name}_SZ_IW
#define PEER_SZ_W {name}_SZ_W
static const double peer_stiffness[PEER_NDOF] = {c_array(model.stiffness)};
static const double peer_inputs[2][{max(nin, 1)}] = {{{c_array(model.inputs)},
    {c_array(model.inputs * WARM_SCALE)}}};
"""
    (folder / "peer_casadi.h").write_text(header)
    return [C_DIR / "harness.c", C_DIR / "casadi_newton.c", folder / f"{name}.c"]


# ---- flexgen's side -----------------------------------------------------------------------------


def kernel_names() -> dict[int, tuple[str, str]]:
    """The address of every compiled kernel function -> (kernel, C function name)."""
    from flexgen import core

    names = {}
    for kernel in core.compiled_kernels():
        evaluate, in_range = core.kernel_functions(kernel)
        names[int(core.ffi.cast("uintptr_t", evaluate))] = (kernel, f"{kernel}_evaluate")
        names[int(core.ffi.cast("uintptr_t", in_range))] = (kernel, f"{kernel}_in_range")
    return names


def c_flexures(problem: Any, used: set[str]) -> tuple[str, str]:
    """The tip0 tables and fg_flexure initializers of a flexgen Problem's fg_problem (kernel
    models); adds the kernels to used."""
    from flexgen import core

    names = kernel_names()

    def fn(ptr: Any) -> str:
        if ptr == core.ffi.NULL:
            return "NULL"
        kernel, name = names[int(core.ffi.cast("uintptr_t", ptr))]
        used.add(kernel)
        return name

    p = problem.struct
    rows, tables = [], []
    for i in range(p.nflex):
        f = p.flex[i]
        if f.kind != core.lib.FG_MODEL_KERNEL:
            raise ValueError(f"flexure {i} is not a smooth curvature (kernel) model")
        # the kernel at q = 0, a constant of the model (fg_flexure.tip0, as flexgen.Solver's)
        tip0 = problem.tip0[i]
        tables.append(f"static const double peer_tip0_{i}[] = {c_array(tip0.tolist())};")
        rows.append(
            f"{{.kind = FG_MODEL_KERNEL, .ndof = {f.ndof}, .offset = {f.offset}, "
            f".parent = {f.parent}, .at = {c_array(list(f.at))}, .length = {f.length!r}, "
            f".gamma = {f.gamma!r}, .poly = {fn(f.poly)}, .in_range = {fn(f.in_range)}, "
            f".gauss = {fn(f.gauss)}, .gauss_in_range = {fn(f.gauss_in_range)}, "
            f".local = {fn(f.local)}, .local_in_range = {fn(f.local_in_range)}, "
            f".tip0 = peer_tip0_{i}}}"
        )
    return "\n".join(tables), ",\n    ".join(rows)


def c_ints(ptr: Any, n: int) -> str:
    return "{" + ", ".join(str(ptr[i]) for i in range(n)) + "}" if n else "{0}"


def c_inputs(values: np.ndarray) -> str:
    """{values, values * WARM_SCALE}: the two inputs (a zero for an empty array)."""
    v = values.ravel() if values.size else np.zeros(1)
    return f"{{{c_array(v)}, {c_array(v * WARM_SCALE)}}}"


def write_core_sources(scene: Path, folder: Path) -> list[Path]:
    """peer_fgcore.h: the fg_problem flexgen.Solver fills for the scene, as C constants, for
    fg_core_peer.c; returns the sources to compile (the core and the kernels it calls)."""
    import flexgen

    solver = flexgen.Solver(scene)
    p, problem = solver.problem.struct, solver.problem
    used: set[str] = set()
    tip0_tables, flexures = c_flexures(problem, used)
    points = ", ".join(
        f"{{.frame = {pt.frame}, .x = {pt.x!r}, .y = {pt.y!r}}}"
        for pt in (p.points[i] for i in range(p.npoints))
    )
    settings = "\n".join(
        f"    s->{f.name} = {getattr(p.settings, f.name)!r};" for f in fields(solver.settings)
    )
    nroute = sum(p.route_len[i] for i in range(p.ntendons))
    includes = "\n".join(f'#include "{k}.h"' for k in sorted(used))
    header = f"""/* generated by benchmarks/casadi_peer.py from {scene.name}: flexgen.Solver's fg_problem */
#include "chain_solver.h"
{includes}
#define PEER_NDOF {p.ndof}
#define PEER_NFLEX {p.nflex}
#define PEER_NPOINTS {p.npoints}
#define PEER_NLOADS {p.nloads}
#define PEER_NTENDONS {p.ntendons}
#define PEER_NOUT {p.noutputs}
{tip0_tables}
static const fg_flexure peer_flex[PEER_NFLEX] = {{
    {flexures}}};
static const fg_point peer_points[PEER_NPOINTS] = {{{points}}};
static const int peer_load_point[] = {c_ints(p.load_point, p.nloads)};
static const int peer_route_start[] = {c_ints(p.route_start, p.ntendons)};
static const int peer_route_len[] = {c_ints(p.route_len, p.ntendons)};
static const int peer_route[] = {c_ints(p.route, nroute)};
static const int peer_outputs[] = {c_ints(p.outputs, p.noutputs)};
static const double peer_stiffness[PEER_NDOF] = {c_array(problem.stiffness)};
static const double peer_load[2][{max(problem.loads.size, 1)}] = {c_inputs(problem.loads)};
static const double peer_tension[2][{max(problem.tensions.size, 1)}] = {c_inputs(problem.tensions)};
static void peer_settings(fg_settings *s)
{{
{settings}
}}
"""
    (folder / "peer_fgcore.h").write_text(header)
    core_sources = [ROOT / "flexgen" / "compiled" / "chain_solver.c"]
    kernels = [ROOT / "generated" / "c" / f"{k}.c" for k in sorted(used)]
    return [C_DIR / "harness.c", C_DIR / "fg_core_peer.c", *core_sources, *kernels]


def has_scene_controller() -> bool:
    """Does this checkout's ``flexgen generate`` take --scene (issue 9's controller)?"""
    out = subprocess.run(
        [sys.executable, "-m", "flexgen", "generate", "--help"], capture_output=True, text=True
    )
    return "--scene" in out.stdout


def write_controller_sources(scene: Path, prefix: str, folder: Path) -> list[Path]:
    """``flexgen generate --scene`` into folder; the controller's sources with the harness."""
    cmd = [sys.executable, "-m", "flexgen", "generate", "--scene", str(scene)]
    done = subprocess.run(
        [*cmd, "--out", str(folder), "--prefix", prefix], capture_output=True, text=True
    )
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {done.stderr.strip()}")
    sources = sorted(p for p in folder.glob("*.c") if not p.name.endswith("_example.c"))
    return [C_DIR / "harness.c", C_DIR / "controller_peer.c", *sources]


# ---- flexgen's own answer -------------------------------------------------------------------------


Points = list[dict[str, np.ndarray]]  # per output: "pose" (3), "compliance" (3 x 3)


def flexgen_answers(scene: Path) -> tuple[dict[str, Points], dict[str, np.ndarray]]:
    """flexgen.solve's answer (cold: the scene's inputs) and a prepared Solver's at every
    input times 1.01 (warm), with their packed q."""
    import flexgen

    def points(result: Any) -> Points:
        if not result.converged:
            raise Disagreement(f"flexgen.solve found no equilibrium of {scene.name}")
        return [
            {"pose": np.array(pt.pose), "compliance": np.array(pt.compliance3)}
            for pt in result.points.values()
        ]

    solver = flexgen.Solver(scene)
    loads, tensions = solver.problem.loads.copy(), solver.problem.tensions.copy()
    results = {
        "cold": flexgen.solve(scene),
        "warm": solver.solve(loads=loads * WARM_SCALE, tensions=tensions * WARM_SCALE),
    }
    answers = {k: points(r) for k, r in results.items()}
    qs = {
        k: np.concatenate([np.asarray(v, dtype=float) for v in r.q.values()])
        for k, r in results.items()
    }
    return answers, qs


def model_answers(spec: SceneSpec, starts: dict[str, np.ndarray]) -> dict[str, Points]:
    """The 3-mode model's own answers (REFERENCE_NODES Gauss nodes, Newton from flexgen's q):
    what every contender's kernel approximates."""
    model = peer_model(spec, "reference", REFERENCE_NODES)
    answers = {}
    for key, q in starts.items():
        u = model.inputs * (WARM_SCALE if key == "warm" else 1.0)
        q = q.copy()
        for _ in range(20):
            _, r, K, _, _ = (np.array(x) for x in model.function(q, u))
            dq = np.linalg.solve(K, -r.ravel())
            q += dq
            if np.abs(dq).max() <= 1e-15 * max(1.0, np.abs(q).max()):
                break
        else:
            raise Disagreement(f"the reference Newton did not converge ({key})")
        _, _, K, pose, GT = (np.array(x) for x in model.function(q, u))
        G = GT.T.reshape(model.noutputs, 3, model.ndof)
        answers[key] = [
            {"pose": pose.ravel()[3 * o : 3 * o + 3], "compliance": g @ np.linalg.solve(K, g.T)}
            for o, g in enumerate(G)
        ]
    return answers


# ---- contenders: build, answer, time -----------------------------------------------------------


@dataclass
class Contender:
    name: str
    scene: str  # "flexure" or "finger"
    side: str  # "CasADi" or "flexgen"
    exe: Path
    answer: dict[str, Any] | None = None
    errors: tuple[float, float] = (0.0, 0.0)  # against flexgen.solve: pose, compliance
    model_errors: tuple[float, float] = (0.0, 0.0)  # against the 3-mode model (REFERENCE_NODES)


def compile_program(
    sources: Sequence[Path], includes: Sequence[Path], exe: Path, defines: Sequence[str] = ()
) -> Path:
    flags = [f"-I{d}" for d in includes] + [f"-D{d}" for d in defines]
    cmd = [CC, *CFLAGS, *flags, *map(str, sources), "-lm", "-o", str(exe)]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}\n{done.stderr}")
    return exe


def run_answer(c: Contender) -> dict[str, Any]:
    out = subprocess.run([str(c.exe), "answer"], capture_output=True, text=True, check=True)
    answer: dict[str, Any] = json.loads(out.stdout)
    return answer


def errors(
    got: dict[str, Any], ref: dict[str, Points], length: float, rows: int
) -> tuple[float, float]:
    """The worst pose error (x, y in units of the shortest flexure length, the angle in rad) and
    compliance error (max |dC| / max |C| per output, over its first rows rows and columns) of
    a contender's cold and warm answers."""
    pose_err = comp_err = 0.0
    for key in ("cold", "warm"):
        for mine, theirs in zip(got[key]["points"], ref[key], strict=True):
            dp = np.abs(np.array(mine["pose"]) - theirs["pose"]) / np.array([length, length, 1.0])
            C = np.array(mine["compliance"])[:rows, :rows]
            Cref = theirs["compliance"][:rows, :rows]
            pose_err = max(pose_err, float(dp.max()))
            comp_err = max(comp_err, float(np.abs(C - Cref).max() / np.abs(Cref).max()))
    return pose_err, comp_err


def compare(
    c: Contender, flexgen: dict[str, Points], model: dict[str, Points], length: float
) -> None:
    """Store the contender's errors against flexgen.solve and against the 3-mode model; raise
    Disagreement past the tolerances (against flexgen.solve) or on a failed solve."""
    assert c.answer is not None
    for key in ("cold", "warm"):
        got = c.answer[key]
        if got["status"] != 0 or not got["stable"]:
            raise Disagreement(
                f"{c.name} ({c.scene}, {key}): status {got['status']}, stable {got['stable']}"
            )
    c.errors = errors(c.answer, flexgen, length, ROWS[c.scene])
    c.model_errors = errors(c.answer, model, length, ROWS[c.scene])
    pose_err, comp_err = c.errors
    if not (pose_err <= POSE_TOL and comp_err <= COMPLIANCE_TOL):
        raise Disagreement(
            f"{c.name} disagrees with flexgen.solve on the {c.scene}: pose error {pose_err:.2e} "
            f"(tolerance {POSE_TOL:g}), compliance error {comp_err:.2e} (tolerance {COMPLIANCE_TOL:g})"
        )


def time_once(exe: Path, mode: str, n: int) -> float:
    out = subprocess.run(
        [str(exe), "time", mode, str(n)], capture_output=True, text=True, check=True
    )
    return float(out.stdout.split()[0])


def instructions_once(exe: Path, mode: str, n: int) -> int:
    """Machine instructions of `exe time MODE n` under callgrind (valgrind's instruction
    counter: the same count for the same binary and inputs, whatever the machine's load)."""
    out = subprocess.run(
        [
            "valgrind",
            "--tool=callgrind",
            "--callgrind-out-file=/dev/null",
            str(exe),
            "time",
            mode,
            str(n),
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    found = re.search(r"Collected : (\d+)", out.stderr)
    if found is None:
        raise RuntimeError(f"callgrind reported no instruction count for {exe.name}")
    return int(found.group(1))


def count_instructions(jobs: Sequence[tuple[Contender, str]]) -> dict[tuple[str, str, str], float]:
    """Instructions per solve of each (contender, mode): the difference of two runs (N and 2N
    timed solves, each after N/10 + 1 untimed ones: harness.c) over the solves it adds, so the
    program's start and the first cold solve cancel."""
    n = 1000
    out = {}
    for c, mode in jobs:
        low, high = instructions_once(c.exe, mode, n), instructions_once(c.exe, mode, 2 * n)
        extra = (2 * n + (2 * n) // 10) - (n + n // 10)
        out[(c.scene, c.name, mode)] = (high - low) / extra
    return out


def time_contenders(
    jobs: Sequence[tuple[Contender, str]], rounds: int, target_ms: float
) -> dict[tuple[str, str, str], float]:
    """ns per solve of each (contender, mode): one run of its program per round, the jobs in
    alternating order (forward, then backward), the median of the per-round means."""
    counts = []
    for c, mode in jobs:
        ns = time_once(c.exe, mode, 200)
        counts.append(max(100, int(target_ms * 1e6 / ns)))
    samples: list[list[float]] = [[] for _ in jobs]
    order = list(range(len(jobs)))
    for r in range(rounds):
        for j in order if r % 2 == 0 else order[::-1]:
            c, mode = jobs[j]
            samples[j].append(time_once(c.exe, mode, counts[j]))
    return {(c.scene, c.name, mode): statistics.median(s) for (c, mode), s in zip(jobs, samples)}


# ---- the page ---------------------------------------------------------------------------------------


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_note() -> str:
    import casadi

    gcc = subprocess.run([CC, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    return (
        f"{cpu_model()}, {os.cpu_count()} cores, Linux {platform.release()}; {gcc}; "
        f"CasADi {casadi.CasadiMeta.version()}; Python {platform.python_version()}"
    )


def write_page(
    out: Path,
    contenders: Sequence[Contender],
    times: dict[tuple[str, str, str], float],
    instructions: dict[str, int],
    per_solve: dict[tuple[str, str, str], float] | None,
    rounds: int,
    target_ms: float,
) -> list[str]:
    """docs/controller-speed.md; returns the table rows (also printed)."""
    casadi = {c.scene: c for c in contenders if c.side == "CasADi"}

    def us(c: Contender, mode: str) -> str:
        t = times.get((c.scene, c.name, mode))
        return "—" if t is None else f"{t / 1e3:.3f}"

    def ratio(c: Contender, mode: str) -> str:
        peer = casadi[c.scene]
        t, tp = times.get((c.scene, c.name, mode)), times.get((c.scene, peer.name, mode))
        return "—" if c.side == "CasADi" or t is None or tp is None else f"{t / tp:.2f}"

    def counts(c: Contender, key: str) -> str:
        assert c.answer is not None
        a = c.answer[key]
        calls = "?" if a["calls"] < 0 else str(a["calls"])
        return f"{a['iterations']} / {calls}"

    rows = [
        f"| {c.scene} | {c.name} | {us(c, 'cold')} | {us(c, 'warm')} | {counts(c, 'cold')} | "
        f"{counts(c, 'warm')} | {ratio(c, 'cold')} | {ratio(c, 'warm')} |"
        for c in contenders
    ]
    agreement = [
        f"| {c.scene} | {c.name} | {c.errors[0]:.1e} | {c.errors[1]:.1e} | "
        f"{c.model_errors[0]:.1e} | {c.model_errors[1]:.1e} |"
        for c in contenders
    ]
    verdicts = targets(contenders, times)
    if per_solve is None:
        counted = [
            "valgrind is not installed: no instruction counts (Debian: apt install valgrind)."
        ]
    else:

        def kilo(c: Contender, mode: str) -> str:
            return f"{per_solve[(c.scene, c.name, mode)] / 1e3:.1f}"

        def kratio(c: Contender, mode: str) -> str:
            if c.side == "CasADi":
                return "—"
            peer = casadi[c.scene]
            return (
                f"{per_solve[(c.scene, c.name, mode)] / per_solve[(c.scene, peer.name, mode)]:.2f}"
            )

        counted = [
            "| scene | contender | cold (k instructions) | warm (k instructions) | ratio cold | ratio warm |",
            "|---|---|---|---|---|---|",
        ] + [
            f"| {c.scene} | {c.name} | {kilo(c, 'cold')} | {kilo(c, 'warm')} | "
            f"{kratio(c, 'cold')} | {kratio(c, 'warm')} |"
            for c in contenders
        ]
    text = PAGE.format(
        machine=machine_note(),
        rounds=rounds,
        flexure_ops=instructions.get("flexure", 0),
        finger_ops=instructions.get("finger", 0),
        table="\n".join(rows),
        instruction_table="\n".join(counted),
        agreement="\n".join(agreement),
        targets="\n".join(f"- {v}" for v in verdicts),
        pose_tol=POSE_TOL,
        comp_tol=COMPLIANCE_TOL,
        reference_nodes=REFERENCE_NODES,
        target_ms=f"{target_ms:g}",
        cflags=" ".join(CFLAGS),
    )
    out.write_text(text)
    return rows + [""] + counted + [""] + agreement + [""] + verdicts


def targets(contenders: Sequence[Contender], times: dict[tuple[str, str, str], float]) -> list[str]:
    """Issue 9's speed targets, each met or not, for the generated controller (else for the
    solver core, said so)."""
    flexgen_side = [c for c in contenders if c.side == "flexgen"]
    lines = []
    for scene, modes in (("flexure", ("cold",)), ("finger", ("cold", "warm"))):
        peer = next(c for c in contenders if c.side == "CasADi" and c.scene == scene)
        ours = [c for c in flexgen_side if c.scene == scene]
        # the controllers (the default kernel, then kernel "local"), else the core
        mine = [c for c in ours if c.name.startswith("flexgen controller")] or ours[:1]
        for mode in modes:
            for c in mine:
                t, tp = times[(scene, c.name, mode)], times[(scene, peer.name, mode)]
                met = "met" if t <= tp else "NOT met"
                lines.append(
                    f"{scene}, {mode}: {c.name} {t / 1e3:.3f} us vs {peer.name} {tp / 1e3:.3f} "
                    f"us (ratio {t / tp:.2f}): target {met}"
                )
    return lines


PAGE = """\
# Controller speed: flexgen against an expert's CasADi solve

Written by `make bench-controller` (`benchmarks/casadi_peer.py --out docs/controller-speed.md`);
issue 9, item 5. Do not edit by hand.

## What is timed

One solve = equilibrium from the inputs, then the output points' poses and compliances, in C:

- **one flexure** (3 modes, EI = L = 1) under the tip force (0, -3) EI/L^2 (a temporary scene
  like `examples/cantilever_tip_load.toml`); the CasADi peer reports the 2x2 tip compliance, flexgen
  the 3x3;
- **the two-link finger** of `examples/two_link_finger.toml` (tendon 10 N through
  base.r0 -> middle.hole -> fingertip.anchor, 0.2 N on fingertip.pad along -y; outputs middle.pad
  and fingertip.pad, each pose (x, y, angle) and 3x3 compliance d(x, y, angle)/d(fx, fy, moment)).

Cold: from the unloaded state (q = 0) at the full inputs. Warm: from the previous answer, with
every load and tension changed by 1 % (alternating between the scene's inputs and 1.01 times them).

Contenders:

- **CasADi**: the scene's whole potential Pi(q; u) = U(q) - sum (f . r + m theta) + sum T l(q) in
  SX, 3 Legendre curvature modes and 8 Gauss-Legendre nodes per flexure; ONE fused generated C
  function for Pi, its gradient and Hessian, the output poses and their Jacobians ({flexure_ops}
  SX instructions for the flexure, {finger_ops} for the finger); a hand-written damped Newton
  (LDL^T Cholesky, backtracking on Pi or the residual, relative residual 1e-12 or a step below 1e-14),
  then G K^-1 G^T (`benchmarks/casadi/casadi_newton.c`).
- **flexgen controller**: the C of `flexgen generate --scene SCENE --out DIR --prefix NAME`,
  `NAME_solve` with `state.solved = 0` (cold, as docs/controller.md asks for one: the CasADi
  peer likewise clears only its q) or the state kept (warm) (`benchmarks/casadi/controller_peer.c`).
  Its warm start is accepted only where the direct solve's three path samples put it on the load
  path from the unloaded state, as the library's (docs/controller.md, "Warm and cold"): a warm
  answer is the cold one.
- **flexgen controller, warm follows history**: the same C compiled with
  `-DNAME_WARM_FOLLOWS_HISTORY`: the warm start accepted without the path samples (3 chain
  evaluations fewer), the answer on the previous answer's branch (where several stable
  equilibria hold the inputs, not always the cold one; the CasADi peer's warm Newton is of this
  kind). Cold solves are the same as the default's.
- **flexgen core (fg_solve)**: the solver core on the `fg_problem` that `flexgen.Solver` fills for
  the scene, written out as C constants, with the library's settings; warm through
  `fg_problem.q0` (`benchmarks/casadi/fg_core_peer.c`).

Every program: `gcc {cflags}` (no -ffast-math, no -march, no LTO), each source its own translation
unit, `benchmarks/casadi/harness.c` as `main`. The programs run interleaved, {rounds} rounds (forward
then backward order), each run a mean over about {target_ms} ms of solves; the table gives the median of
the per-round means.

Machine: {machine}. A shared, noisy machine: absolute times move between runs; the ratios are
measured within one run.

## Time per solve

Iterations / calls: Newton iterations and kernel calls of one solve (CasADi: calls of the fused
kernel; flexgen: chain evaluations, each evaluating every flexure's kernel; `?`: not reported).
Ratio: flexgen / the CasADi peer of the same scene.

| scene | contender | cold (us) | warm (us) | cold iterations / calls | warm iterations / calls | ratio cold | ratio warm |
|---|---|---|---|---|---|---|---|
{table}

## Instructions per solve

The same programs under valgrind's instruction counter (callgrind): machine instructions per
solve, the difference of a run of 2000 timed solves and one of 1000 over the solves it adds. A
count does not move with the machine's load, so it tells a small change from noise where the
times above cannot; it weighs every instruction alike (a division as an addition), so its ratios
are close to, not equal to, the times'.

{instruction_table}

## Issue 9's targets

flexgen's generated controller no slower than the CasADi peer, in the same run: the flexure cold,
the finger cold and warm (issue 9 measured the CasADi peers here at 0.80 us, 3.3 us and 2.0 us
on a quieter day; the targets are the ratios, not those numbers).

{targets}

## Agreement

Before timing, each program's cold answer and its warm answer (at 1.01 times the inputs, from
the cold answer) are compared with `flexgen.solve` (cold) and a prepared `flexgen.Solver`
(warm): pose error = max |dx|, |dy| in units of the shortest flexure length and |d angle| in rad
(tolerance {pose_tol:g}); compliance error = max |dC| / max |C| per output point (tolerance
{comp_tol:g}; the flexure: its 2x2 position block, the finger: the 3x3); the worse of cold and warm.
A disagreement stops the benchmark (exit 1) before anything is timed.

The last two columns measure the same errors against the 3-mode model itself: the SX potential
with {reference_nodes} Gauss nodes per flexure (quadrature converged to rounding), solved by Newton
in NumPy from flexgen's q. They are each kernel's error at the answer: flexgen's certified
kernel (the local kernel `scm3_local9` on these scenes) against the CasADi peer's 8-node Gauss
quadrature.

| scene | contender | pose vs flexgen.solve | compliance vs flexgen.solve | pose vs the model | compliance vs the model |
|---|---|---|---|---|---|
{agreement}
"""


# ---- main -------------------------------------------------------------------------------------------


def build_contenders(tmp: Path) -> tuple[list[Contender], dict[str, int]]:
    flexure_toml = tmp / "flexure_tip_force.toml"
    flexure_toml.write_text(FLEXURE_TOML)
    scenes = {"flexure": flexure_toml, "finger": FINGER}
    controller = has_scene_controller()
    contenders, instructions = [], {}
    for scene, path in scenes.items():
        spec = read_scene(path)
        model = peer_model(spec, f"{scene}_kernel")
        instructions[scene] = int(model.function.n_instructions())
        d = tmp / f"casadi_{scene}"
        d.mkdir()
        srcs = write_casadi_sources(model, ROWS[scene], d)
        exe = compile_program(srcs, [d, C_DIR], d / "peer")
        contenders.append(Contender("CasADi", scene, "CasADi", exe))
        if controller:
            d = tmp / f"controller_{scene}"
            d.mkdir()
            srcs = write_controller_sources(path, scene, d)
            defines = [
                f"PEER_PREFIX={scene}",
                f"PEER_UPPER={scene.upper()}",
                f'PEER_HEADER="{scene}.h"',
                "PEER_CALLS=evaluations",
            ]
            exe = compile_program(srcs, [d, C_DIR], d / "peer", defines)
            contenders.append(Contender("flexgen controller", scene, "flexgen", exe))
            history = [*defines, f"{scene.upper()}_WARM_FOLLOWS_HISTORY"]
            exe = compile_program(srcs, [d, C_DIR], d / "peer_history", history)
            contenders.append(
                Contender("flexgen controller, warm follows history", scene, "flexgen", exe)
            )
        d = tmp / f"core_{scene}"
        d.mkdir()
        srcs = write_core_sources(path, d)
        incs = [d, C_DIR, ROOT / "flexgen" / "compiled", ROOT / "generated" / "c"]
        exe = compile_program(srcs, incs, d / "peer")
        contenders.append(Contender("flexgen core (fg_solve)", scene, "flexgen", exe))
    return contenders, instructions


def check_agreement(contenders: Sequence[Contender], tmp: Path) -> None:
    paths = {"flexure": tmp / "flexure_tip_force.toml", "finger": FINGER}
    for scene, path in paths.items():
        spec = read_scene(path)
        length = min(f.length for f in spec.flexures)
        flexgen, qs = flexgen_answers(path)
        model = model_answers(spec, qs)
        for c in contenders:
            if c.scene == scene:
                c.answer = run_answer(c)
                compare(c, flexgen, model, length)


def missing_tools() -> str | None:
    """What this benchmark needs and does not find, in words (None: all there)."""
    if importlib.util.find_spec("casadi") is None:
        return "casadi is not installed (a benchmark-only dependency: pip install -e '.[bench]')"
    if shutil.which(CC) is None:
        return f"no C compiler {CC!r} on PATH"
    return None


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "controller-speed.md")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--target-ms", type=float, default=40.0, help="length of one timed run")
    args = ap.parse_args(argv)
    missing = missing_tools()
    if missing:
        print(f"casadi_peer: {missing}", file=sys.stderr)
        return 2
    tmp = Path(tempfile.mkdtemp(prefix="flexgen-casadi-peer-"))
    try:
        contenders, instructions = build_contenders(tmp)
        try:
            check_agreement(contenders, tmp)
        except Disagreement as e:
            print(f"casadi_peer: {e}", file=sys.stderr)
            return 1
        jobs = [(c, mode) for c in contenders for mode in ("cold", "warm")]
        times = time_contenders(jobs, args.rounds, args.target_ms)
        counts = count_instructions(jobs) if shutil.which("valgrind") else None
        for line in write_page(
            args.out, contenders, times, instructions, counts, args.rounds, args.target_ms
        ):
            print(line)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
