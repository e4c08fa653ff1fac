"""Flatten a scene and its flexure models into the C structs of ``chain_solver.h``.

The flexures are listed in the chain's body order (every parent before its children, as the C
kinematics and the reverse Hessian accumulation need), each with the offset of its coordinates in
the packed q of ``flexgen.chain.Chain``. The points are those the loads, tendons and outputs
name, each on the flexure frame that carries it (-1: the base). A model the C solver does not
know (anything but the built-in scm/cc, fem and prb classes) gives no plan.
"""
from __future__ import annotations

import ctypes
import dataclasses

import numpy as np

from ..chain import BASE, Chain
from ..settings import SolverSettings
from ..models.fem import FEMModel
from ..models.prb import PRBModel
from ..models.scm import SCMModel
from . import library as lib


def _flexure_struct(model, offset: int, parent: int, at) -> tuple[lib.Flexure, np.ndarray] | None:
    """The C struct and the diagonal energy Hessian of one model (None: not supported)."""
    f = lib.Flexure()
    f.ndof, f.offset, f.parent = int(model.n_dof), offset, parent
    f.at[0], f.at[1], f.at[2] = (float(v) for v in at)
    f.length, f.gamma = model.length, 0.0
    kind = type(model)
    if kind is SCMModel:
        f.kind = lib.MODEL_KERNEL
        if model.poly is not None:
            f.poly, f.in_range = lib.kernel_functions(f"scm{model.n_dof}")
        if model.gauss is not None:
            f.gauss, f.gauss_in_range = lib.kernel_functions(model.gauss_name)
        stiffness = model.EI / model.length * np.asarray(model.weights, dtype=float)
    elif kind is FEMModel:
        f.kind = lib.MODEL_FEM
        stiffness = np.full(model.n_dof, model.spring)
    elif kind is PRBModel:
        f.kind, f.gamma = lib.MODEL_PRB, model.gamma
        stiffness = np.array([model.stiffness])
    else:
        return None
    return f, stiffness


class Plan:
    """A scene's C problem, its workspace and its answer buffers (reusable for repeated solves
    of the same scene and models; not thread-safe: one solve at a time)."""

    def __init__(self, chain: Chain, loads, tendons, outputs: list[str], settings: dict,
                 flexures, stiffness):
        self.outputs = outputs
        order = chain.flexure_order
        index = {name: i for i, name in enumerate(order)}
        refs = list(dict.fromkeys([ref for ref, _ in loads]
                                  + [ref for _, route in tendons for ref in route] + outputs))
        pindex = {ref: i for i, ref in enumerate(refs)}
        points = (lib.Point * max(len(refs), 1))()
        for i, ref in enumerate(refs):
            body, xy = chain.resolve_point(ref)
            frame = chain.frame_of(body)
            points[i].frame = -1 if frame == BASE else index[frame]
            points[i].x, points[i].y = xy
        n = chain.ndof
        self._keep = []                              # arrays the struct points into

        def ints(values):
            a = np.ascontiguousarray(values, dtype=np.intc)
            self._keep.append(a)
            return a.ctypes.data_as(ctypes.POINTER(ctypes.c_int))

        def doubles(values):
            a = np.ascontiguousarray(values, dtype=float)
            self._keep.append(a)
            return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))

        flex = (lib.Flexure * len(order))(*flexures)
        route = [pindex[ref] for _, r in tendons for ref in r]
        starts = np.cumsum([0] + [len(r) for _, r in tendons])[:-1]
        p = lib.Problem()
        p.ndof, p.nflex, p.npoints = n, len(order), len(refs)
        p.nloads, p.ntendons, p.noutputs = len(loads), len(tendons), len(outputs)
        p.flex, p.points = flex, points
        p.load_point = ints([pindex[ref] for ref, _ in loads] or [0])
        p.load = doubles(np.array([F for _, F in loads], dtype=float).ravel() if loads else [0.0])
        p.tension = doubles([T for T, _ in tendons] or [0.0])
        p.route_start = ints(starts if tendons else [0])
        p.route_len = ints([len(r) for _, r in tendons] or [0])
        p.route = ints(route or [0])
        p.outputs = ints([pindex[ref] for ref in outputs] or [0])
        p.stiffness = doubles(stiffness)
        chosen = SolverSettings(**settings)          # validated; copied field by field
        for f in dataclasses.fields(chosen):
            setattr(p.settings, f.name, getattr(chosen, f.name))
        p.lapack = lib.lapack()
        self._keep += [flex, points]
        self.problem = p
        solver = lib.solver_library()
        self._solve = solver.fg_solve
        self.work = np.empty(solver.fg_work_size(ctypes.byref(p)))
        self.iwork = np.empty(solver.fg_iwork_size(ctypes.byref(p)), dtype=np.intc)
        self.q = np.empty(n)
        self.pose = np.empty((max(len(outputs), 1), 3))
        self.compliance = np.empty((max(len(outputs), 1), 3, 3))
        self.K = np.empty((n, n))
        a = lib.Answer()
        a.q = self.q.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        a.pose = self.pose.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        a.compliance = self.compliance.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        a.stiffness = self.K.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self.critical = np.empty(MAX_CRITICAL)
        self.critical_kind = np.empty(MAX_CRITICAL, dtype=np.intc)
        a.critical = self.critical.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        a.critical_kind = self.critical_kind.ctypes.data_as(ctypes.POINTER(ctypes.c_int))
        a.max_critical = MAX_CRITICAL
        self.flexure_order = list(order)
        self.switched = np.zeros(len(order), dtype=np.intc)
        a.switched = self.switched.ctypes.data_as(ctypes.POINTER(ctypes.c_int))
        self.answer = a
        self._args = (ctypes.byref(p), self.work.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
                      self.iwork.ctypes.data_as(ctypes.POINTER(ctypes.c_int)), ctypes.byref(a))
        self.q0 = np.zeros(n)
        self._q0_pointer = self.q0.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._warm = False

    def run(self, q0: np.ndarray | None = None) -> int:
        """One solve (from the unloaded state, or Newton at the full load from the packed ``q0``);
        the status (library.SOLVED, NO_EQUILIBRIUM or MODEL_ERROR). When SOLVED, ``q``, ``pose``,
        ``compliance`` and ``answer`` (energy, residual, iterations, stable, ncritical) hold it,
        and the first ``answer.ncritical`` entries of ``critical`` / ``critical_kind`` the
        critical load factors met on the way (a bifurcation crossed, a snap-through);
        ``switched[i]`` is 1 if flexure ``flexure_order[i]`` ("auto" kernel) used its Gauss
        kernel on the way."""
        if q0 is not None:
            self.q0[:] = q0
            self.problem.q0 = self._q0_pointer
            self._warm = True
        elif self._warm:
            self.problem.q0 = None
            self._warm = False
        return self._solve(*self._args)


# the most critical events (bifurcations crossed, snap-throughs) a solve stores (more are
# counted in answer.ncritical; solver.py hands such a solve back to the Python solver)
MAX_CRITICAL = 64

# the solver settings (flexgen.settings.SolverSettings) with their defaults
DEFAULTS = {f.name: getattr(SolverSettings(), f.name)
            for f in dataclasses.fields(SolverSettings)}


def build_plan(chain: Chain, loads, tendons, outputs: list[str], **settings) -> Plan | None:
    """The Plan of a chain with these loads ((ref, (fx, fy, m)) pairs) and tendons
    ((tension, route) pairs), or None if a model has no C counterpart. ``settings``: any of
    ``DEFAULTS`` (``flexgen.equilibrium.solve``'s keyword arguments of the same names)."""
    unknown = set(settings) - set(DEFAULTS)
    if unknown:
        raise TypeError(f"build_plan: unknown setting {sorted(unknown)[0]!r}")
    order = chain.flexure_order
    index = {name: i for i, name in enumerate(order)}
    flexures, stiffness = [], np.zeros(chain.ndof)
    for name in order:
        fl = chain.flexures[name]
        frame = chain.frame_of(fl.parent)
        parent = -1 if frame == BASE else index[frame]
        got = _flexure_struct(chain.models[name], chain.slices[name].start, parent, fl.at)
        if got is None:
            return None
        flexures.append(got[0])
        stiffness[chain.slices[name]] = got[1]
    return Plan(chain, loads, tendons, outputs, settings, flexures, stiffness)
