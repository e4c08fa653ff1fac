"""No C pointer is taken to a temporary array: the core reads it with the GIL released (cffi), so
a temporary's memory may be freed and reused by another thread during the call. A Solver built
while other threads allocated got a wrong kernel-at-zero table this way (np.zeros(k) passed
straight to fg_flexure_tip) and answered wrongly with converged True and no warning.

The rule, checked on the source: the array under ``double_ptr(...)`` or ``ffi.cast(..., X)`` is a
name, an attribute or a slice of one (a view of an array something holds), never a call's
result."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "flexgen"


def _array_of(node: ast.expr) -> ast.expr:
    """The array expression a pointer is taken to: X in X.ctypes.data, X[...] -> X."""
    if isinstance(node, ast.Attribute) and node.attr == "data":
        node = node.value
        if isinstance(node, ast.Attribute) and node.attr == "ctypes":
            node = node.value
    while isinstance(node, ast.Subscript):
        node = node.value
    return node


def _data_pointer(ctype: ast.expr) -> bool:
    """A cast to ``double *`` or ``int *`` (not to a function pointer type, e.g. LAPACK's)."""
    return isinstance(ctype, ast.Constant) and ctype.value in ("double *", "int *")


def _pointer_arguments(tree: ast.AST) -> list[tuple[int, ast.expr]]:
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        name = (
            node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
        )
        if name == "double_ptr" and node.args:
            found.append((node.lineno, node.args[0]))
        elif name == "cast" and len(node.args) == 2 and _data_pointer(node.args[0]):
            found.append((node.lineno, node.args[1]))
    return found


def _temporaries(source: str) -> list[int]:
    return [
        line
        for line, arg in _pointer_arguments(ast.parse(source))
        if isinstance(_array_of(arg), ast.Call)
    ]


def test_the_rule_catches_the_temporary_it_is_named_after():
    assert _temporaries("double_ptr(np.zeros(k))\n") == [1]
    assert _temporaries('ffi.cast("double *", np.ascontiguousarray(K).ctypes.data)\n') == [1]
    assert _temporaries("q = np.zeros(k)\ndouble_ptr(q)\ndouble_ptr(out[3:])\n") == []
    assert _temporaries('ffi.cast("int *", self.iwork.ctypes.data)\n') == []


@pytest.mark.parametrize("path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: p.name)
def test_no_pointer_to_a_temporary_array(path):
    bad = _temporaries(path.read_text())
    assert not bad, f"{path.relative_to(PACKAGE.parent)}: a pointer to a temporary at lines {bad}"


def test_solvers_built_beside_allocating_threads_get_the_kernel_table_exactly():
    """The race behind the rule, run: Solvers built in three threads while a fourth allocates
    small arrays; every kernel-at-zero table equals one built alone (with np.zeros(k) passed as
    a temporary, 10 of 180 differed, by up to 0.095 m in an unloaded pose)."""
    import threading

    import numpy as np

    import flexgen

    scene = flexgen.load_scene(PACKAGE.parent / "examples" / "two_link_finger.toml")
    reference = [t.copy() for t in flexgen.Solver(scene).problem.tip0]
    stop, wrong = threading.Event(), []

    def allocate() -> None:
        while not stop.is_set():
            a, b = np.full(3, 0.7), np.full(4, 1.3)
            del a, b

    def build() -> None:
        for _ in range(40):
            tables = flexgen.Solver(scene).problem.tip0
            wrong.extend(1 for a, b in zip(tables, reference, strict=True) if not (a == b).all())

    noise = threading.Thread(target=allocate)
    noise.start()
    builders = [threading.Thread(target=build) for _ in range(3)]
    for t in builders:
        t.start()
    for t in builders:
        t.join()
    stop.set()
    noise.join()
    assert not wrong
