"""A scene and its flexure models as the solver core's problem: flat arrays, constant per scene.

``Problem`` is the model in Pinocchio's sense: topology, geometry, stiffness, kernels, loads and
tendons, and the solver settings, held in the C structs of ``chain_solver.h`` (filled by field
name through cffi) and the NumPy arrays they point into. ``Workspace`` is the data: the scratch
memory and answer buffers of one solve, owned by the caller. Neither holds solver state between
solves; the answer of a solve is read from the workspace right after it. What a ``Solver`` may
set after building it: the loads and tensions of the next solve, and once, the validity
screen's bend limits (``fg_problem.bend_limit``, ``near_margin``: ``validity.calm``).

Flexures are listed in body order (every parent before its children, as the core's kinematics
and its reverse Hessian accumulation need), each with the offset of its coordinates in the packed
q (the scene's flexure order, ``Chain.slices``). Points are those the loads, tendons and outputs
name, each on the flexure frame that carries it (-1: the base).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from functools import cached_property
from typing import Any

import numpy as np

from .chain import BASE, Chain
from .core import double_ptr, ffi, lapack, lib
from .models.registry import core_description
from .scene import Scene
from .settings import SolverSettings
from .statics import StaticsPlan

# the most critical events (bifurcations crossed, snap-throughs) a solve reports one by one
MAX_CRITICAL = 64


class Problem:
    """The constant part of a solve: ``problem.struct`` (an ``fg_problem *``) and what it points
    into. ``loads`` (nloads x 3: fx, fy, moment, world frame) and ``tensions`` are the arrays
    the core reads: write into them to solve the same mechanism under other loads."""

    def __init__(self, scene: Scene, models: Mapping[str, Any], settings: SolverSettings):
        chain = Chain(scene, models)
        self.scene, self.models, self.chain, self.settings = scene, dict(models), chain, settings
        # the [output] points; else every loaded point; else the tips of the flexures that
        # carry no other flexure (Scene.output_points, which the exact solver uses too)
        self.outputs = list(scene.output_points())
        order = chain.flexure_order
        self.flexure_order = order
        index = {name: i for i, name in enumerate(order)}
        refs = list(
            dict.fromkeys(
                [ld.point for ld in scene.loads]
                + [ref for t in scene.tendons for ref in t.route]
                + self.outputs
            )
        )
        self.points = refs  # the fg_point array's order: what each index names
        pindex = {ref: i for i, ref in enumerate(refs)}
        self._keep: list[Any] = []  # what the structs point into

        flex = ffi.new("fg_flexure[]", max(len(order), 1))
        # the elastic stiffness D: the diagonal of the elastic energy's Hessian (unloaded; the
        # loaded stiffness K of an answer is Result.stiffness)
        self.stiffness = np.zeros(chain.ndof)
        for i, name in enumerate(order):
            fl, f = chain.flexures[name], flex[i]
            frame = chain.frame_of(fl.parent)
            sl = chain.slices[name]
            f.ndof, f.offset = sl.stop - sl.start, sl.start
            f.parent = -1 if frame == BASE else index[frame]
            f.at = [float(v) for v in fl.at]
            self.stiffness[sl] = core_description(models[name], f)
        # each kernel flexure's kernel at q = 0 (fg_flexure.tip0, which points into these;
        # None for the others), read also by the controller emitter
        self.tip0 = [_set_kernel_at_zero(flex, i) for i in range(len(order))]
        points = ffi.new("fg_point[]", max(len(refs), 1))
        for i, ref in enumerate(refs):
            body, xy = chain.resolve_point(ref)
            frame = chain.frame_of(body)
            points[i].frame = -1 if frame == BASE else index[frame]
            points[i].x, points[i].y = float(xy[0]), float(xy[1])
        self._keep += [flex, points]

        self.loads = np.array(
            [[ld.force[0], ld.force[1], ld.moment] for ld in scene.loads], dtype=float
        ).reshape(-1, 3)
        self.tensions = np.array([t.tension for t in scene.tendons], dtype=float)
        routes = [[pindex[ref] for ref in t.route] for t in scene.tendons]
        p = ffi.new("fg_problem *")
        p.ndof, p.nflex, p.npoints = chain.ndof, len(order), len(refs)
        p.nloads, p.ntendons, p.noutputs = len(scene.loads), len(scene.tendons), len(self.outputs)
        p.flex, p.points = flex, points
        p.load_point = self._ints([pindex[ld.point] for ld in scene.loads])
        p.load = self._doubles(self.loads)
        p.tension = self._doubles(self.tensions)
        p.route_start = self._ints(np.cumsum([0] + [len(r) for r in routes])[:-1])
        p.route_len = self._ints([len(r) for r in routes])
        p.route = self._ints([i for r in routes for i in r])
        p.outputs = self._ints([pindex[ref] for ref in self.outputs])
        p.stiffness = self._doubles(self.stiffness)
        copy_settings(settings, p.settings)
        for routine, fn in lapack().items():
            setattr(p.lapack, routine, fn)
        self.struct = p

    @cached_property
    def statics(self) -> StaticsPlan:
        """Which points load which flexures (``flexgen.statics``), found on first use."""
        return StaticsPlan(self.scene)

    def _ints(self, values) -> Any:
        a = np.ascontiguousarray(np.asarray(values, dtype=np.intc).ravel())
        if a.size == 0:
            a = np.zeros(1, dtype=np.intc)
        self._keep.append(a)
        return ffi.cast("int *", a.ctypes.data)

    def _doubles(self, a: np.ndarray) -> Any:
        # the array itself (not a copy): loads, tensions and stiffness are read by the core
        if a.size == 0:
            a = np.zeros(1)
            self._keep.append(a)
        assert a.flags.c_contiguous and a.dtype == np.float64
        return ffi.cast("double *", a.ctypes.data)

    def split(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """The packed q per flexure (scene order)."""
        return {name: q[sl] for name, sl in self.chain.slices.items()}


def copy_settings(settings: SolverSettings, struct: Any) -> None:
    """Every field of ``settings`` into the ``fg_settings`` field of the same name (the C
    struct has no defaults of its own)."""
    for f in fields(settings):
        setattr(struct, f.name, getattr(settings, f.name))


class Workspace:
    """Scratch memory and answer buffers for solves of one ``Problem`` (one solve at a time)."""

    def __init__(self, problem: Problem):
        from .core import lib

        p = problem.struct
        n, m = int(p.ndof), max(int(p.noutputs), 1)
        self.work = np.empty(max(int(lib.fg_work_size(p)), 1))
        self.iwork = np.empty(max(int(lib.fg_iwork_size(p)), 1), dtype=np.intc)
        nf = max(int(p.nflex), 1)
        # the answer's arrays, views of one buffer: a Result keeps one copy of it
        # (answer_views of that copy)
        self.answer_data = np.zeros(sum(size for _, size, _ in _answer_layout(n, m, nf)))
        self.q, self.pose, self.compliance, self.ellipse, self.K, self.bend = answer_views(
            self.answer_data, n, m, nf
        )  # ellipse: major, minor, angle per output; bend: per flexure, core order
        self.shape = (n, m, nf)
        self.critical = np.empty(MAX_CRITICAL)
        self.critical_kind = np.empty(MAX_CRITICAL, dtype=np.intc)
        self.switched = np.zeros(max(int(p.nflex), 1), dtype=np.intc)
        self.kernel = np.zeros(max(int(p.nflex), 1), dtype=np.intc)  # FG_KERNEL_*
        self.q0 = np.zeros(max(n, 1))
        a = ffi.new("fg_answer *")
        a.q, a.pose, a.compliance, a.stiffness = (
            double_ptr(self.q),
            double_ptr(self.pose),
            double_ptr(self.compliance),
            double_ptr(self.K),
        )
        a.critical = double_ptr(self.critical)
        a.critical_kind = ffi.cast("int *", self.critical_kind.ctypes.data)
        a.max_critical = MAX_CRITICAL
        a.switched = ffi.cast("int *", self.switched.ctypes.data)
        a.bend = double_ptr(self.bend)
        a.ellipse = double_ptr(self.ellipse)
        a.kernel = ffi.cast("int *", self.kernel.ctypes.data)
        self.answer = a
        self.work_ptr = double_ptr(self.work)
        self.K_ptr = double_ptr(self.K)
        self.iwork_ptr = ffi.cast("int *", self.iwork.ctypes.data)
        self.q0_ptr = double_ptr(self.q0)


def _answer_layout(n: int, m: int, nf: int) -> list[tuple[str, int, tuple[int, ...]]]:
    """The answer buffer's arrays in order: name, size, shape (n coordinates, m output
    points, nf flexures)."""
    return [
        ("q", n, (n,)),
        ("pose", 3 * m, (m, 3)),
        ("compliance", 9 * m, (m, 3, 3)),
        ("ellipse", 3 * m, (m, 3)),
        ("K", n * n, (n, n)),
        ("bend", nf, (nf,)),
    ]


def answer_views(data: np.ndarray, n: int, m: int, nf: int) -> list[np.ndarray]:
    """q, pose, compliance, ellipse, K, bend: views of an answer buffer (``Workspace.answer_data``
    or a copy of it)."""
    views, start = [], 0
    for _, size, shape in _answer_layout(n, m, nf):
        views.append(data[start : start + size].reshape(shape))
        start += size
    return views


def _set_kernel_at_zero(flex: Any, i: int) -> np.ndarray | None:
    """Kernel flexure ``flex[i]``'s kernel at q = 0 (pose 3, J 3k, H 3kk, for length 1),
    computed once and set as ``flex[i].tip0`` (the unloaded state then evaluates no kernel);
    the array, which the caller keeps alive. None for the n-element chain and the pseudo-rigid
    body, whose closed forms cost nothing."""
    f = flex[i]
    if f.kind != lib.FG_MODEL_KERNEL:
        return None
    k = f.ndof
    out = np.zeros(3 + 3 * k + 3 * k * k)
    scratch = np.zeros(4 * (k + 1))
    # named, so that it lives through the call: a temporary's memory could be freed and reused
    # by another thread while the core reads it (cffi releases the GIL during the call)
    q = np.zeros(k)
    length, f.length = f.length, 1.0  # the kernel itself, unscaled (tip0 is not set yet)
    ok = lib.fg_flexure_tip(
        flex + i,
        double_ptr(q),
        double_ptr(out),
        double_ptr(out[3:]),
        double_ptr(out[3 + 3 * k :]),
        double_ptr(scratch),
    )
    f.length = length
    assert ok, "every kernel evaluates at q = 0"
    f.tip0 = double_ptr(out)
    return out
