"""The code generation pipeline: derive -> lower (CSE) -> print -> render -> write.

``generate_files(spec, langs)`` returns {relative path: text} for one kernel; nothing touches the
disk until ``render.write_files``. The checked-in set is ``CHECKED_IN``.
"""

from __future__ import annotations

from dataclasses import replace

import mpmath
import sympy as sp

from flexgen.codegen.lower import count_ops, lower
from flexgen.codegen.printers import CPrinter, NumPyPrinter, numpy_array
from flexgen.codegen.render import render
from flexgen.codegen.spec import BACKENDS, MAX_MODES, CConfig, KernelSpec, NumPyConfig
from flexgen.kernels import name_parts
from flexgen.symbolic.flexure import RANGE_SAMPLES, FlexureKernel

# Polynomial kernels at 90 degrees for 1..8 modes (mode selection may need up to 8) and Gauss
# kernels, certified on 180 degrees, for 1..8 modes (more modes are never worse):
# the runtime falls back to them past the polynomial range; and local Gauss kernels for 1..8
# modes (the error estimate's richer models evaluate with them: 0.5x to 0.2x the polynomial
# kernel's time), their pose error certified at each q to 1e-11 (the polynomial kernels': 1.3e-11).
LOCAL_TOL = 1e-11
CHECKED_IN = (
    tuple(KernelSpec(n) for n in range(1, MAX_MODES + 1))
    + tuple(KernelSpec(n, "gauss") for n in range(1, MAX_MODES + 1))
    + tuple(KernelSpec(n, "local", tol=LOCAL_TOL) for n in range(1, MAX_MODES + 1))
)


def checked_in_spec(name: str) -> KernelSpec | None:
    """The ``CHECKED_IN`` spec of a shipped kernel's name, its node count taken from the name
    (deriving it then does not search for the count again); None if flexgen ships no such
    kernel."""
    parts = name_parts(name)
    if parts is None:
        return None
    modes, family, nodes = parts
    for spec in CHECKED_IN:
        if spec.modes == modes and spec.family == family:
            return spec if nodes is None else replace(spec, nodes=nodes)
    return None


def exact_number(x: float | None) -> str:
    """``x`` as the command line takes it back exactly: the shortest round-trip form, an integral
    value without ".0" (90, 1e-11, 45.1234567). ``:g`` kept six digits: a kernel generated with
    --range 179.9999999 said --range 180, which the command refuses (review)."""
    assert x is not None  # a KernelSpec's range and tol are set (None: its family's default)
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def command_line(kernel: FlexureKernel, prefix: str = "") -> str:
    """The CLI call that reproduces this kernel (no paths, dates or versions)."""
    s = kernel.spec
    parts = [
        f"flexgen generate --modes {s.modes} --kernel {s.family} "
        f"--range {exact_number(s.range_deg)}"
    ]
    parts.append(f"--degree {kernel.degree}" if s.family == "poly" else f"--nodes {kernel.nodes}")
    if s.family == "local":  # the tolerance its in_range certifies
        parts.append(f"--tol {exact_number(s.tol)}")
    if prefix:  # the names of its files and functions
        parts.append(f"--prefix {prefix}")
    return " ".join(parts)


def _common(kernel: FlexureKernel, prefix: str = "") -> dict:
    s = kernel.spec
    what = (
        "closed-form polynomial (cos, sin -> Chebyshev interpolants of degree "
        f"{kernel.degree} on [-{exact_number(s.range_deg)}, {exact_number(s.range_deg)}] deg)"
        if s.family == "poly"
        else f"{kernel.nodes}-node Gauss-Legendre quadrature"
    )
    return {
        # the name its files and functions carry (review: a prefixed header's first line
        # named the unprefixed kernel)
        "title": f"{prefix + '_' if prefix else ''}{kernel.name}: tip pose, Jacobian and "
        f"Hessian of a {s.modes}-mode smooth "
        f"curvature flexure, {what}.",
        "description": (
            "The flexure's angle is phi(s) = sum_n q_n B_n(s/L), B_n the integral of the shifted "
            "Legendre polynomial P_n(2t - 1); its tip is x = L int cos(phi), y = L int sin(phi), "
            "theta = q_0."
            + (
                f" The polynomial is evaluated exactly in nodal form: {kernel.nodes} Gauss nodes "
                "integrate the degree "
                f"{kernel.interpolant.degree * s.modes} polynomial in s without error."
                if s.family == "poly"
                else " It evaluates at any angle; its error bound is certified only on "
                "|phi| <= PHI_MAX (in_range), and past it the error grows."
                if s.family == "gauss"
                else " Valid at any angle; the error bounds are certified at each q: where "
                "in_range(q) is 1 (a bound on the quadrature error at q, flexgen.symbolic."
                "certificate); the nodes certify the constant-curvature arc of PHI_MAX."
            )
        ),
        "command": command_line(kernel, prefix),
        "N": s.modes,
        "family": s.family,
        "nodes": kernel.nodes,
        "degree": kernel.degree,
        "phi_max": repr(kernel.a),
        "range_deg": exact_number(s.range_deg),
        "bounds": kernel.bounds,
        "range_samples": RANGE_SAMPLES,
    }


TRIG_ROWS = ("c", "dc", "ddc", "s", "ds", "dds")  # the row order of _trig's stacked result


def trig_coefficients(kernel: FlexureKernel) -> tuple[list[list[float]], list[bool]]:
    """The six polynomials c, c', c'', s, s', s'' of a poly kernel as rows of coefficients of
    u = phi^2, highest power first (zero-padded to one length), and which rows are odd in phi
    (those are multiplied by phi after the Horner steps in u)."""
    rows, odd = [], []
    interp = kernel.interpolant
    for _name, coeffs in (("c", interp.cos), ("s", interp.sin)):
        poly = [mpmath.mpf(c) for c in coeffs]
        for _ in range(3):  # value, first, second derivative
            # an all-zero derivative (degree 1 or 2: s'' = 0) is the even row [0.0]
            parity = next((k for k, c in enumerate(poly) if c != 0), 0) % 2
            rows.append([float(c) for c in poly[parity::2]][::-1])
            odd.append(bool(parity))
            poly = [k * poly[k] for k in range(1, len(poly))]
    width = max(len(r) for r in rows)
    return [[0.0] * (width - len(r)) + r for r in rows], odd


def numpy_files(kernel: FlexureKernel, prefix: str = "") -> dict[str, str]:
    N, G = kernel.modes, kernel.nodes
    with mpmath.workdps(40):
        w, b = kernel.weights, kernel.node_basis
        jw = [[float(w[g] * b[g][i]) for i in range(N)] for g in range(G)]
        hw = [
            [float(w[g] * b[g][i] * b[g][j]) for i in range(N) for j in range(N)] for g in range(G)
        ]
    S, m = kernel.range_check
    # the six polynomials as printed Horner forms sharing phi^2 (CSE): fastest on blocks of rows
    printer = NumPyPrinter()
    phi = sp.Symbol("phi")
    trig = kernel.trig_polynomials(phi)
    temps, reduced = sp.cse(
        [trig[k] for k in TRIG_ROWS], symbols=sp.numbered_symbols("u"), order="none"
    )
    lines = [f"{sym} = {printer.doprint(expr)}" for sym, expr in temps]
    # a constant row (c'' of degree 2 and below, s'' = 0) as an array of phi's shape: a scalar
    # would not broadcast in the block path's matrix products
    lines += [
        f"{k} = {printer.doprint(e)}"
        if e.free_symbols
        else f"{k} = np.full(phi.shape, {float(e)!r})"
        for k, e in zip(TRIG_ROWS, reduced)
    ]
    lines.append(f"return {', '.join(TRIG_ROWS)}")
    context = _common(kernel, prefix) | {
        "trig_lines": lines,
        "node_ops": str(count_ops([e for _, e in temps] + list(reduced))),
        "energy_weights": numpy_array([float(x) for x in kernel.energy_weights]),
        "node_basis": numpy_array([[float(v) for v in row] for row in b]),
        "weights": numpy_array([float(x) for x in w]),
        "jacobian_weights": numpy_array(jw),
        "hessian_weights": numpy_array(hw),
        "range_samples_matrix": numpy_array(S),
        "range_margin": numpy_array(m),
        "range_bound": numpy_array(kernel.range_bound),
    }
    if kernel.spec.family == "poly":
        coeffs, odd = trig_coefficients(kernel)
        context |= {
            "trig_coeffs": numpy_array(coeffs),
            "trig_odd": "[" + ", ".join(str(x) for x in odd) + "]",
        }
    if kernel.spec.family == "local":
        rows = kernel.local_rows
        context |= {
            "local_nu": numpy_array([list(r.nu) for r in rows]),
            "local_limit": numpy_array([r.limit for r in rows]),
        }
    config = BACKENDS["numpy"]
    assert isinstance(config, NumPyConfig)
    name = f"{prefix}_{kernel.name}" if prefix else kernel.name
    return {f"{config.folder}/{name}.py": render(config.template, context)}


def c_context(kernel: FlexureKernel, prefix: str = "", linkage: str = "") -> dict:
    """The template context of one C kernel: its functions are named ``<prefix>_<kernel>_*``
    (``<kernel>_*`` without a prefix) and declared with ``linkage`` ("static " where a
    controller embeds them)."""
    lowered = lower(kernel)
    # H's symmetric twin H[j][i] (the same expression object as H[i][j]) is copied, not computed
    # again: the emitted code is what lowered.ops counts
    first: dict[int, int] = {}
    copy_of: dict[int, int] = {}
    for o in lowered.outputs:
        if o.array == "H" and not o.expr.is_Number:
            if id(o.expr) in first:
                copy_of[o.index] = first[id(o.expr)]
            else:
                first[id(o.expr)] = o.index
    variants = []
    for ctype, suffix in (("double", ""), ("float", "_f")):
        printer = CPrinter(ctype)
        variants.append(
            {
                "type": ctype,
                "suffix": suffix,
                "temporaries": [
                    (str(sym), printer.doprint(expr)) for sym, expr in lowered.temporaries
                ],
                "outputs": [
                    (
                        o.array,
                        o.index,
                        f"H[{copy_of[o.index]}]"
                        if o.array == "H" and o.index in copy_of
                        else printer.doprint(o.expr),
                    )
                    for o in lowered.outputs
                ],
            }
        )
    printer = CPrinter("double")
    S, m = kernel.range_check
    q = kernel.q
    range_lines = [
        printer.doprint(sp.Add(*[sp.Float(v, 17) * qn for v, qn in zip(row, q) if v]))
        if any(row)
        else "0.0"
        for row in S
    ]
    margin_terms = [
        f"{printer.doprint(sp.Float(mn, 17))}*fabs(q[{n}])" for n, mn in enumerate(m) if mn
    ]
    bound_line = " + ".join(
        f"{printer.doprint(sp.Float(b, 17))}*fabs(q[{n}])"
        for n, b in enumerate(kernel.range_bound)
        if b
    )
    local_rows = [
        (
            f"{row.rho:g}",
            " + ".join(f"{printer.doprint(sp.Float(v, 17))}*a{n}" for n, v in enumerate(row.nu)),
            printer.doprint(sp.Float(row.limit, 17)),
        )
        for row in (kernel.local_rows if kernel.spec.family == "local" else ())
    ]
    name = f"{prefix}_{kernel.name}" if prefix else kernel.name
    return _common(kernel, prefix) | {
        "local_rows": local_rows,
        "prefix": name,
        "macro": name.upper(),
        "guard": f"FLEXGEN_{name.upper()}_H",
        "linkage": linkage,
        "ops": str(lowered.ops),
        "variants": variants,
        "range_lines": range_lines,
        "margin_line": " + ".join(margin_terms) if margin_terms else "0.0",
        "bound_line": bound_line or "0.0",
    }


def c_files(kernel: FlexureKernel, prefix: str = "") -> dict[str, str]:
    context = c_context(kernel, prefix)
    config = BACKENDS["c"]
    assert isinstance(config, CConfig)
    name = context["prefix"]
    return {
        f"{config.folder}/{name}.h": render(config.header_template, context),
        f"{config.folder}/{name}.c": render(config.source_template, context),
    }


EMITTERS = {"numpy": numpy_files, "c": c_files}


def generate_files(spec: KernelSpec, langs=("numpy", "c"), prefix: str = "") -> dict[str, str]:
    """{relative path: text} of one kernel in each of ``langs``; ``prefix``: its files and
    functions are named ``<prefix>_<kernel>`` (so that a custom kernel links beside a shipped
    one)."""
    kernel = FlexureKernel(spec)
    files: dict[str, str] = {}
    for lang in langs:
        files |= EMITTERS[lang](kernel, prefix)
    return files
