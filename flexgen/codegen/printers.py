"""One printer per target language: SymPy expressions to C99 (double or float) and NumPy text.

Small classes in the SymPy style: a ``_print_<Node>`` method per node that needs a rule, and
lookup tables instead of branches. Integer powers print as products in C (``x*x*x``, not
``pow(x, 3)``); floating constants print as the shortest text that round-trips to the target type.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypedDict

import numpy as np
import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.pycode import PythonCodePrinter


class CTypeInfo(TypedDict):
    """One C scalar type: literal suffix, rounding to the type, libm names of cos and sin."""

    suffix: str
    to_float: Callable[[float], float]
    functions: dict[str, str]


# per C type: literal suffix and the names of the libm functions we call
C_TYPES: dict[str, CTypeInfo] = {
    "double": {"suffix": "", "to_float": float, "functions": {"cos": "cos", "sin": "sin"}},
    "float": {
        "suffix": "f",
        "to_float": lambda x: float(np.float32(x)),
        "functions": {"cos": "cosf", "sin": "sinf"},
    },
}


def float_literal(value, ctype: str = "double") -> str:
    """Shortest round-trip decimal of value rounded to ctype, with the C suffix."""
    info = C_TYPES[ctype]
    x = info["to_float"](value)
    text = (
        repr(x)
        if ctype == "double"
        else np.format_float_positional(np.float32(x), unique=True, trim="0")
        if abs(x) >= 1e-4 or x == 0
        else np.format_float_scientific(np.float32(x), unique=True, trim="0")
    )
    if text.endswith("."):
        text += "0"
    if "." not in text and "e" not in text and "inf" not in text:
        text += ".0"
    return text + info["suffix"]


class CPrinter(C99CodePrinter):
    """C99 for one scalar type (``ctype`` = "double" or "float")."""

    def __init__(self, ctype: str = "double"):
        super().__init__({"strict": False})
        self.ctype = ctype

    def _print_Float(self, expr):
        return float_literal(expr, self.ctype)

    def _print_Integer(self, expr):
        return float_literal(int(expr), self.ctype)

    def _print_Rational(self, expr):
        return float_literal(expr.p / expr.q, self.ctype)

    def _print_Pow(self, expr):
        base, exp = expr.args
        if exp.is_Integer and exp > 0:
            return "*".join(
                [self.parenthesize(base, sp.printing.precedence.PRECEDENCE["Mul"])] * int(exp)
            )
        raise NotImplementedError(f"the C printer takes only positive integer powers: {expr}")

    def _print_Function(self, expr):
        name = C_TYPES[self.ctype]["functions"][type(expr).__name__]
        return f"{name}({self._print(expr.args[0])})"

    _print_cos = _print_sin = _print_Function

    def _print_Symbol(self, expr):
        name = expr.name
        if name.startswith("q") and name[1:].isdigit():
            return f"q[{name[1:]}]"  # the input array
        return name


class NumPyPrinter(PythonCodePrinter):
    """Python expressions over numpy arrays; constants as round-trip doubles."""

    def _print_Float(self, expr):
        return repr(float(expr))

    def _print_Pow(self, expr):
        base, exp = expr.args
        if exp.is_Integer and exp > 0:
            return "*".join(
                [self.parenthesize(base, sp.printing.precedence.PRECEDENCE["Mul"])] * int(exp)
            )
        return super()._print_Pow(expr)

    def _print_cos(self, expr):
        return f"np.cos({self._print(expr.args[0])})"

    def _print_sin(self, expr):
        return f"np.sin({self._print(expr.args[0])})"


def numpy_array(values, indent: int = 4) -> str:
    """A nested list literal of round-trip doubles (for module constants)."""
    arr = np.asarray(values, dtype=float)
    if arr.ndim == 1:
        return "[" + ", ".join(repr(float(v)) for v in arr) + "]"
    pad = " " * indent
    rows = [numpy_array(row, indent + 4) for row in arr]
    return "[\n" + ",\n".join(pad + "    " + r for r in rows) + ",\n" + pad + "]"
