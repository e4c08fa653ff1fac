"""Lowering: the unique output expressions of a kernel, common subexpressions, op counts."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from flexgen.symbolic.flexure import FlexureKernel


@dataclass(frozen=True)
class OpCount:
    adds: int
    muls: int
    calls: int  # cos/sin calls (gauss kernels)

    @property
    def total(self) -> int:
        return self.adds + self.muls + self.calls

    def __str__(self) -> str:
        return f"{self.total} ops ({self.adds} add, {self.muls} mul, {self.calls} cos/sin)"


@dataclass(frozen=True)
class Output:
    """One scalar output slot: its array and flat row-major index, and its expression."""

    array: str  # "pose", "J" or "H"
    index: int
    expr: sp.Expr


@dataclass(frozen=True)
class LoweredKernel:
    kernel: FlexureKernel
    temporaries: list[tuple[sp.Symbol, sp.Expr]]
    outputs: list[Output]
    ops: OpCount


def outputs_of(kernel: FlexureKernel) -> list[Output]:
    """Every slot of pose (3), J (3xN) and H (3xNxN), row-major."""
    N = kernel.modes
    e = kernel.expressions
    out = [Output("pose", r, e["pose"][r]) for r in range(3)]
    out += [Output("J", r * N + i, e["J"][r][i]) for r in range(3) for i in range(N)]
    out += [
        Output("H", (r * N + i) * N + j, e["H"][r][i][j])
        for r in range(3)
        for i in range(N)
        for j in range(N)
    ]
    return out


def lower(kernel: FlexureKernel) -> LoweredKernel:
    """CSE over the unique outputs (H's symmetric twins share one expression)."""
    outputs = outputs_of(kernel)
    unique: list[sp.Expr] = []
    seen: dict[int, int] = {}
    for o in outputs:
        if not o.expr.is_Number and id(o.expr) not in seen:
            seen[id(o.expr)] = len(unique)
            unique.append(o.expr)
    temps, reduced = sp.cse(unique, symbols=sp.numbered_symbols("t"), order="none")
    by_id = {key: reduced[i] for key, i in seen.items()}
    lowered = [
        Output(o.array, o.index, o.expr if o.expr.is_Number else by_id[id(o.expr)]) for o in outputs
    ]
    ops = count_ops([e for _, e in temps] + reduced)
    return LoweredKernel(kernel, temps, lowered, ops)


def count_ops(exprs) -> OpCount:
    """Adds, multiplies (integer powers as repeated products, as printed in C) and calls."""
    adds = muls = calls = 0
    for expr in exprs:
        for node in sp.preorder_traversal(expr):
            if node.is_Add:
                adds += len(node.args) - 1
            elif node.is_Mul:
                muls += len([a for a in node.args if a not in (sp.S.NegativeOne,)]) - 1
            elif node.is_Pow and node.exp.is_Integer and node.exp > 0:
                muls += int(node.exp) - 1
            elif isinstance(node, (sp.cos, sp.sin)):
                calls += 1
    return OpCount(adds, muls, calls)
