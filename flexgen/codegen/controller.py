"""The controller emitter: one scene as a self-contained C99 solver (``flexgen generate --scene``).

derive -> print -> render, as for a kernel: the scene is prepared exactly as the library
prepares it (``flexgen.problem.Problem``: the flexures in body order, the points, the stiffness,
the kernels each model uses), that problem is printed as constant C initializers, and the
templates under ``templates/controller`` render ``NAME.h`` (the interface), ``NAME.c`` (the
solver core of ``flexgen/compiled/chain_solver.c`` and the kernels, every function ``static``,
then the scene's tables and ``NAME_solve``), ``NAME_example.c``, ``CMakeLists.txt`` and
``NAME.mk``. ``controller_files`` returns {file name: text}; nothing touches the disk until
``render.write_files``.
"""

from __future__ import annotations

import functools
import json
import math
import re
import textwrap
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from flexgen.result import UNSTABLE
from flexgen.scene import MAX_MAGNITUDE, Scene, SceneError, _fmt, load_scene
from flexgen.settings import DEFAULT, SolverSettings
from flexgen.validity import BEND_LIMIT, NEAR_SINGULAR, PRB_LIMIT, STRAIN_LIMIT
from flexgen.warm import WARM_CHANGE

from .render import render

# the compiled core's sources, pasted into every controller (installed with the package)
CORE = Path(__file__).resolve().parents[1] / "compiled"


class EmitError(SceneError):
    """A scene, prefix or option the controller emitter refuses: one line naming it."""


@dataclass(frozen=True)
class Options:
    """What `flexgen generate --scene` was asked for (the emitted files quote it)."""

    scene_file: str  # the scene's file name as given on the command line (no folder)
    prefix: str
    single: bool = False  # --float: the single-precision twin


# The controller's settings are the library's: its warm start, like flexgen.Solver's, is
# accepted only on the load path from the unloaded state (warm_on_path), so a warm answer is
# the cold one. warm_on_path is emitted as the macro NAME_WARM_ON_PATH, 0 where the controller is
# compiled with NAME_WARM_FOLLOWS_HISTORY: Newton from the last answer is then accepted without
# the path samples, and the answer follows the mechanism's own history (docs/controller.md, "Warm
# and cold"). Found by review: following history by default, a warm answer sat on the other
# side of a buckled column than flexgen.solve's, with no flag
CONTROLLER = DEFAULT
# The float twin's largest load value and tension: MAX_MAGNITUDE (1e100) keeps a product of
# three of the solver's numbers finite in double (1e300); 1e12 does so in float (FLT_MAX 3.4e38;
# review: a load of 3e27 overflowed inside the float solve and was reported as a limit point)
SINGLE_MAX_MAGNITUDE = 1e12

# The float twin's margin to a critical load below which its rounding may pass its stated
# accuracy (1e-4): errors x margin reached 3e-5 on 6000 loads of the two-link finger and 3.9e-5
# in a review's search (a point's compliance 1.08e-4 off at margin 0.358; another review found
# 4.5e-4 of its length at margin 0.06 with no flag); 3.9e-5 / 0.45 = 8.7e-5
# (tests/test_scene_controller.py)
FLOAT_MARGIN = 0.45

# The single-precision twin's settings: the tolerances of CONTROLLER that are relative to double
# rounding (1e-12 .. 1e-14) raised to what float arithmetic (eps 1.2e-7) can meet; the rest as
# CONTROLLER. Its accuracy is measured, not derived: tests/test_scene_controller.py.
SINGLE = replace(
    CONTROLLER,
    tol=2e-5,
    polish_target=1e-6,
    eigenvalue_floor=1e-5,
    roundoff_tol=1e-5,
    bifurcation_threshold=1e-3,
    bracket_tol=1e-5,
    tie_tol=1e-2,
    circle_tol=1e-6,
    descent_eps=1e-2,
    # every Newton step evaluated: at this tol a linearized end's stiffness and Jacobians would
    # leave the compliance too far off
    linearized_step=0.0,
    # shorter continuation steps: at this tol Newton from a long step's predictor converges
    # more readily onto a stable equilibrium of another branch, past a snap-through the path
    # should have met (review: 3 in 4000 random cold loads of a fem8 finger ended up to 3 lengths
    # from the double solver, flags 0; 0 in 12,000 with 0.1, test_float_twin_meets_the_snap_
    # throughs_of_the_double_solver)
    max_step=0.1,
)

MAX_PREFIX = 64  # characters: names of files and identifiers stay far below the systems' limits
C_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
# names C99 reserves or the emitted code uses itself, which a prefix must not take
RESERVED = frozenset(
    "auto break case char const continue default do double else enum extern float for goto if "
    "inline int long register restrict return short signed sizeof static struct switch typedef "
    "union unsigned void volatile while fg main".split()
)

# the C standard's headers (C11) and POSIX's: the folder's NAME.h is on the include path of
# everything built with it (CMake's PUBLIC include directory, NAME.mk's -I), where math.h of
# --prefix math hides <math.h> (review: the emitted math.c did not compile); compared in lower
# case (NAME.h and Math.h are one file on a case-insensitive file system)
SYSTEM_HEADERS = frozenset(
    "assert complex ctype errno fenv float inttypes iso646 limits locale math setjmp signal "
    "stdalign stdarg stdatomic stdbool stddef stdint stdio stdlib stdnoreturn string tgmath "
    "threads time uchar wchar wctype "
    "aio cpio dirent dlfcn fcntl fmtmsg fnmatch ftw glob grp iconv langinfo libgen monetary "
    "mqueue ndbm netdb nl_types poll pthread pwd regex sched search semaphore spawn strings "
    "syslog tar termios trace ulimit unistd utime utmpx wordexp".split()
)


def default_prefix(path: Path) -> str:
    """The scene file's stem as a C identifier (``two-link finger.toml`` -> ``two_link_finger``)."""
    stem = re.sub(r"[^A-Za-z0-9_]", "_", path.stem)
    return stem if re.match(r"^[A-Za-z_]", stem) else f"scene_{stem}"


KEYWORDS = RESERVED - {"fg", "main"}


def _prefix_problem(prefix: str) -> str | None:
    """Why ``prefix`` cannot prefix the emitted C names, or None."""
    if not C_IDENTIFIER.match(prefix):
        return "not a C identifier: letters, digits and _, not starting with a digit"
    if prefix.startswith("_"):
        return "it starts with _, which C reserves"
    if len(prefix) > MAX_PREFIX:  # (250 characters: the files' names too long, after the work)
        return f"longer than {MAX_PREFIX} characters"
    if prefix.lower() in KEYWORDS:
        return (
            "a C keyword"
            if prefix in KEYWORDS
            else f"a C keyword in other case, {prefix.lower()!r}"
        )
    if prefix.lower() in RESERVED:
        return f"{prefix.lower()!r}, which the emitted code uses itself"
    if prefix.lower() in SYSTEM_HEADERS:
        return (
            f"its header {prefix}.h would hide the system header <{prefix.lower()}.h> from "
            "every file compiled with the folder on its include path"
        )
    return None


def check_prefix(prefix: str, scene: Path | None = None) -> str:
    """``prefix`` if it can prefix the emitted C names, else an EmitError saying why: for
    --prefix, or (``scene`` given) for the prefix taken from the scene file's name."""
    why = _prefix_problem(prefix)
    if why is None:
        return prefix
    if scene is None:
        raise EmitError(f"--prefix: {prefix!r} is not usable as a C identifier prefix ({why})")
    raise EmitError(
        f"{_from_file_name(scene, prefix)} is not a usable C prefix ({why}); give --prefix NAME"
    )


def _from_file_name(scene: Path, prefix: str) -> str:
    """How a message names a prefix taken from the scene file's name."""
    if scene.stem == prefix:
        return f"the file name {prefix!r}"
    return f"the file name {scene.name!r}, as the C prefix {prefix!r},"


# a prefix no core or kernel name starts with: the names the templates define, found by
# rendering them with it
_PROBE = "fgprobe"


def _check_no_clash(context: dict[str, Any], scene: Path | None = None) -> None:
    """The names the emitted code defines (``prefix_*``, ``PREFIX_*``) share one translation
    unit with the pasted core and kernels: none may be one of theirs (``--prefix direct``
    would define a second ``direct_solve``). The defined names are those of a rendering with
    the probe prefix (a name the templates merely use, such as a kernel's ``SCM3_ERROR_BOUND``,
    does not carry the prefix). ``scene``: the prefix is the scene file's name (no --prefix)."""
    prefix = context["name"]
    probe = dict(context, name=_PROBE, NAME=_PROBE.upper())
    emitted = "".join(render(TEMPLATES[out], probe) for out in ("{name}.h", "{name}.c"))
    found = re.findall(rf"\b(?:{_PROBE}|{_PROBE.upper()})_\w*", emitted)
    ours = {n.replace(_PROBE, prefix).replace(_PROBE.upper(), prefix.upper()) for n in found}
    pasted = context["core"] + "".join(context["kernel_blocks"])
    clash = sorted(ours & set(re.findall(r"\b[A-Za-z_]\w*", pasted)))
    if clash:
        why = (
            f"gives a name the solver core already has, {clash[0]!r} (the prefix names every "
            "emitted function and constant)"
        )
        if scene is None:
            raise EmitError(f"--prefix: {prefix!r} {why}; give another --prefix")
        raise EmitError(f"{_from_file_name(scene, prefix)} {why}; give --prefix NAME")


def identifier(name: str) -> str:
    """A point or flexure name as the tail of a C enum name: ``fingertip.pad`` -> ``FINGERTIP_PAD``."""
    return re.sub(r"[^A-Za-z0-9]", "_", name).upper()


def _enum(kind: str, names: list[str]) -> list[tuple[str, str]]:
    """[(C identifier, scene name)]: a name given again (two loads on one point) is numbered
    (``TIP``, ``TIP_2``, ...); two different names that give one identifier are an EmitError."""
    seen: dict[str, str] = {}
    count: dict[str, int] = {}
    out = []
    for name in names:
        count[name] = count.get(name, 0) + 1
        ident = identifier(name) + (f"_{count[name]}" if count[name] > 1 else "")
        if ident in seen:
            raise EmitError(
                f"{kind}: {seen[ident]!r} and {name!r} give one C name {ident}; rename one of "
                f"them ({kind} names become enum constants)"
            )
        seen[ident] = name
        out.append((ident, name))
    return out


def c_comment(text: str) -> str:
    """Scene text (a name, a file name) safe inside a C /* comment */: control characters as
    spaces, and no comment end or start, and no trigraph (C99 still reads "??/" as a
    backslash) left in it."""
    out = "".join(" " if ord(c) < 32 or ord(c) == 127 else c for c in text)
    while True:
        safer = out.replace("*/", "* /").replace("/*", "/ *").replace("??", "? ?")
        if safer == out:
            return out
        out = safer


def c_json_string(text: str) -> str:
    """The body of a C string literal that prints ``text`` as the body of a JSON string, as
    ``flexgen solve --json`` writes it (ASCII, escaped by the json module); in C, backslash,
    quote and "?" (trigraphs) escaped. Passed to printf as an argument, never as the format."""
    body = json.dumps(text)[1:-1]
    return body.replace("\\", "\\\\").replace('"', '\\"').replace("?", "\\?")


def c_double(x: float) -> str:
    """A double literal that reads back exactly (repr: the shortest round trip)."""
    if not math.isfinite(x):
        raise EmitError(f"a constant of the scene is not finite: {x!r}")
    text = repr(float(x))
    return text if any(c in text for c in ".en") else text + ".0"


FLT_MIN = 1.1754943508222875e-38  # the smallest normal float


FLT_MAX = 3.4028234663852886e38  # the largest float


def c_float(x: float) -> str:
    """A float literal of the double x (9 significant digits: one float exactly); a constant
    of the scene beyond float's normal range either way is an EmitError (``c_float_noise``
    flushes a kernel's rounding noise to 0 instead)."""
    if not math.isfinite(x):
        raise EmitError(f"a constant of the scene is not finite: {x!r}")
    if abs(x) > FLT_MAX or 0.0 < abs(x) < FLT_MIN:
        # gcc -pedantic -Werror refuses the large literal; the small one would be 0 and leave
        # the twin's stiffness singular (review: both exit 0 before, the twin 'unstable')
        raise EmitError(
            f"--float: a constant of the scene, {x!r}, is outside float's range ({FLT_MIN:.3g} "
            f"to {FLT_MAX:.3g}); the double controller (without --float) holds it"
        )
    text = f"{x:.9g}"
    return (text if any(c in text for c in ".e") else text + ".0") + "f"


def c_float_noise(x: float) -> str:
    """``c_float`` of a kernel's value at q = 0 (fg_flexure.tip0), whose rounding noise may
    lie below float's normal range: 0 there, which -pedantic does not reject as a truncated
    constant."""
    return "0.0f" if math.isfinite(x) and abs(x) < FLT_MIN else c_float(x)


def _prepared_scene(path: Path) -> tuple[Scene, list[str] | None]:
    """The scene as the controller solves it: a `tolerance` resolved into modes per flexure
    (flexgen.select, as `flexgen solve` does), the exact model refused; and, for a scene with a
    tolerance, what the header says of it (the modes chosen, at the scene's own loads)."""
    from flexgen.api import uses_exact
    from flexgen.select import scene_tolerance, select_models

    scene = load_scene(path)
    if uses_exact(scene):
        raise EmitError(
            'model.kind: "exact" (the reference elastica) has no C solver; choose "scm", "fem" '
            'or "prb" for a controller (`flexgen select` says which is accurate enough)'
        )
    tol = scene_tolerance(scene)
    if tol is None:
        return scene, None
    modes = select_models(scene, tol).modes
    flexures = tuple(
        replace(f, model=replace(f.model, modes=modes[f.name], tolerance=None))
        for f in scene.flexures
    )
    scene = replace(scene, model=replace(scene.model, tolerance=None), flexures=flexures)
    chosen = ", ".join(f"{name!r} {n}" for name, n in modes.items())
    # found by review: at other inputs flexgen.solve chose more modes, and nothing said so
    note = c_comment(
        f"Models: the scene's tolerance {tol:g} chose the modes at generation, at the scene's "
        f"own loads ({chosen}), and they are fixed here; flexgen.solve chooses them per "
        f"answer, so other inputs may need more: check with `flexgen select` over the inputs "
        f"the controller gives."
    )
    return scene, textwrap.wrap(note, 92, break_long_words=False)


@functools.cache
def _kernel_addresses() -> dict[int, str]:
    """{address of <kernel>_evaluate in flexgen._core: kernel name}, for every shipped kernel."""
    from flexgen import kernels
    from flexgen.core import ffi, kernel_functions

    out = {}
    for name in kernels.available():
        evaluate, _ = kernel_functions(name)
        out[int(ffi.cast("uintptr_t", evaluate))] = name
    return out


def _kernel_name(pointer: Any) -> str | None:
    from flexgen.core import ffi

    address = int(ffi.cast("uintptr_t", pointer))
    return None if address == 0 else _kernel_addresses()[address]


@functools.cache
def _kernel_block(name: str, single: bool) -> str:
    """The C functions of a shipped kernel, static, in double (or float) precision."""
    from flexgen.codegen.generate import c_context, checked_in_spec
    from flexgen.symbolic.flexure import FlexureKernel

    # the one spec of that name, derived once (deriving every shipped spec to compare names,
    # each searching for its node count, took most of an emission: 16 s for the finger)
    spec = checked_in_spec(name)
    if spec is None:  # pragma: no cover - every kernel of flexgen._core is shipped
        raise EmitError(f"kernel {name!r} is not one flexgen ships")
    kernel = FlexureKernel(spec)
    assert kernel.name == name, (kernel.name, name)
    context = c_context(kernel, linkage="static ")
    suffix = "_f" if single else ""
    context["variants"] = [v for v in context["variants"] if v["suffix"] == suffix]
    context["range_type"] = "float" if single else "double"
    return render("controller/kernel_block.c.jinja", context)


def _core_text() -> str:
    """chain_solver.h and chain_solver.c as one block (the header pasted where the source
    includes it)."""
    header = (CORE / "chain_solver.h").read_text()
    source = (CORE / "chain_solver.c").read_text()
    include = '#include "chain_solver.h"\n'
    assert source.count(include) == 1, "chain_solver.c includes its header once"
    return source.replace(include, header)


def _flexure_rows(scene: Scene, problem: Any, models: dict, number) -> list[dict]:
    from flexgen.core import lib
    from flexgen.models.registry import model_info

    kinds = {lib.FG_MODEL_KERNEL: "FG_MODEL_KERNEL", lib.FG_MODEL_FEM: "FG_MODEL_FEM"}
    kinds[lib.FG_MODEL_PRB] = "FG_MODEL_PRB"
    by_name = {f.name: f for f in scene.flexures}
    rows = []
    p = problem.struct
    for i, name in enumerate(problem.flexure_order):
        f, fl = p.flex[i], by_name[name]
        poly, gauss, local = _kernel_name(f.poly), _kernel_name(f.gauss), _kernel_name(f.local)
        info = model_info(models[name])
        model = ", ".join(f"{k} {v}" for k, v in info.items() if k != "kind")
        rows.append(
            {
                "name": name,
                "index": i,
                "scene_index": [g.name for g in scene.flexures].index(name),
                "comment": c_comment(
                    f'[[flexure]] "{name}": {info["kind"]}'
                    + (f" ({model})" if model else "")
                    + f", length {fl.length:g}, EI {fl.EI:g}, parent {fl.parent!r}"
                ),
                "kind": kinds[f.kind],
                "ndof": f.ndof,
                "offset": f.offset,
                "parent": f.parent,
                "at": [number(float(v)) for v in f.at],
                "length": float(f.length),
                "gamma": float(f.gamma),
                "poly": poly,
                "gauss": gauss,
                "local": local,
                "tip0": _tip0(problem.tip0[i], c_float_noise if number is c_float else number),
                "poly_bound": f"{poly.upper()}_ERROR_BOUND" if poly else "0",
                "gauss_bound": f"{gauss.upper()}_ERROR_BOUND" if gauss else "0",
                "local_bound": f"{local.upper()}_ERROR_BOUND" if local else "0",
            }
        )
    return rows


def _same(values: Any) -> int | None:
    """The one value all of ``values`` have, None if they differ or there are none."""
    found = set(values)
    return found.pop() if len(found) == 1 else None


def _tip0(values: Any, number) -> list[str] | None:
    """fg_flexure.tip0 of a flexure (``Problem.tip0``: its kernel at q = 0) as C numbers, None
    for a model without a kernel."""
    return None if values is None else [number(float(v)) for v in values]


def _prb_runtime(scene: Scene, models: dict) -> dict | None:
    """What the controller checks per call for a prb flexure of a one-flexure scene, as the
    library judges each answer (validity._prb_case_problem): a moment in any load, a tendon
    that pulls, a force in a load off the tip (the indices); None without a prb flexure or
    where the scene leaves the case in every answer."""
    from flexgen.validity import prb_off_tip_loads, prb_several_flexures

    if not any(_kind(m) == "prb" for m in models.values()) or prb_several_flexures(scene):
        return None
    return {"tendons": bool(scene.tendons), "off_tip": prb_off_tip_loads(scene)}


def _prb_structure(scene: Scene, models: dict) -> str | None:
    """What leaves the prb fitted case in every answer (several flexures), for the header."""
    from flexgen.validity import prb_several_flexures

    if not any(_kind(m) == "prb" for m in models.values()):
        return None
    problem = prb_several_flexures(scene)
    return None if problem is None else c_comment(problem)


def _kind(model: Any) -> str:
    from flexgen.models.registry import model_info

    return str(model_info(model)["kind"])


def _claim_limits(scene: Scene, models: dict, order: list[str]) -> list[float]:
    """The bend of each flexure (body order) past which flexgen/validity.py claims no accuracy:
    BEND_LIMIT; for prb, its pin-rotation validity, or -1 (never claimed) in a scene whose
    structure its constants are not fitted for in every answer (a moment, a tendon's pull, a
    force off the tip are checked at run time: _prb_runtime)."""
    from flexgen.models.registry import model_info
    from flexgen.validity import BEND_LIMIT, PRB_LIMIT, prb_several_flexures

    prb_problem = prb_several_flexures(scene)
    thick = _thick_flexures(scene)
    limits = []
    for name in order:
        limit = BEND_LIMIT
        if model_info(models[name])["kind"] == "prb":
            limit = -1.0 if prb_problem is not None else min(limit, PRB_LIMIT)
        if name in thick:  # outside the slender-beam model at any bend (scene_warnings)
            limit = -1.0
        limits.append(float(limit))
    return limits


def _strain_checks(scene: Scene, models: dict, order: list[str]) -> tuple[list, list, list]:
    """Per flexure in body order: thickness / 2 (0: no thickness, no strain check) and its
    model's ``curvature_bound()`` (by the largest |q_i| or by their sum; its factor), the
    validity.STRAIN_LIMIT screen the library's ``calm`` takes, in C."""
    half, by_max, factor = [], [], []
    for name in order:
        f = scene.flexure(name)
        half.append(0.0 if f.thickness is None else 0.5 * float(f.thickness))
        use_max, k = models[name].curvature_bound()
        by_max.append(int(use_max))
        factor.append(float(k))
    return half, by_max, factor


def _thick_flexures(scene: Scene) -> list[str]:
    """The flexures the library warns about on every answer of the scene (scene_checks:
    shorter than MIN_SLENDERNESS thicknesses): NO_CLAIM on every answer of the controller
    (found by review: the warning was dropped)."""
    from flexgen.scene_checks import thick_flexures

    return [f.name for f in thick_flexures(scene)]


def _units(scene: Scene) -> dict[str, str]:
    """The unit of each quantity the header names: the scene's ``units`` as ``Units.label``
    names them (the JSON's "units" object), else L and F, the length and force units of the
    scene's consistent set."""
    units = scene.units
    if units is None:
        return {
            "given": "",
            "length": "L",
            "force": "F",
            "moment": "F*L",
            "compliance": "L/F",
            "length_per_moment": "1/F",
            "angle_per_force": "rad/F",
            "rotational": "rad/(F*L)",
        }
    force = units.label("force")
    grouped = f"({force})" if any(c in force for c in "*/^ ") else force  # as Units.label does
    return {
        "given": c_comment(f'units = {{length = "{units.length}", force = "{units.force}"}}'),
        "length": units.label("length"),
        "force": force,
        "moment": units.label("moment"),
        "compliance": units.label("compliance"),
        "length_per_moment": f"1/{grouped}",
        "angle_per_force": f"rad/{grouped}",
        "rotational": units.label("rotational compliance"),
    }


def _q_meaning(models: dict) -> list[str]:
    """Each flexure's model as the header's list of q slices names it, in scene order (the
    template defines each kind's coordinates below the list)."""
    from flexgen.models.registry import model_info

    out = []
    for model in models.values():
        info = model_info(model)
        if info["kind"] == "fem":
            out.append(f"fem, {info['elements']} elements")
        elif info["kind"] == "prb":
            out.append("prb")
        else:
            out.append(f"{info['kind']}, {info.get('modes', 1)} modes")
    return out


def _warning_texts(scene: Scene, models: dict, order: list[str]) -> dict[str, Any]:
    """The library's warning texts (flexgen/validity.py: assess; flexgen/solver.py;
    flexgen.result.UNSTABLE) that the example prints for the flags, as C string bodies: whole
    texts, or a head and a tail around a bend in degrees (``%.0f deg``) or a point name. The
    near-critical warning's numbers (the margin) are not computed in C: its text is the C's."""
    from flexgen.scene_checks import scene_warnings
    from flexgen.validity import (
        PRB_TENDON,
        STRAIN_LIMIT,
        _deg,
        _names,
        model_label,
        prb_off_tip,
        prb_several_flexures,
        strain_warning_parts,
    )

    flex_index = {f.name: i for i, f in enumerate(scene.flexures)}
    idents = dict(zip([f.name for f in scene.flexures], [i for i, _ in _enum_names(scene)]))
    scm, pins = [], []
    for name, m in models.items():
        if getattr(m, "kind", "") == "scm":
            head = f"flexure {name!r} ({model_label(m)}): bend "
            past = gauss = None
            if m.poly is not None or m.local is not None:
                past = f", past {m.first_range()}; the answer may be wrong by any amount"
            if m.gauss is not None:
                gauss = (
                    f" is past the certified range of the Gauss kernel {m.gauss_name} "
                    f"({math.degrees(m.gauss.PHI_MAX):.0f} deg); its error bound does not hold"
                )
            scm.append(
                {
                    "ident": idents[name],
                    "head": c_json_string(head),
                    "past": None if past is None else c_json_string(past),
                    "gauss": None if gauss is None else c_json_string(gauss),
                }
            )
        elif getattr(m, "kind", "") == "prb":
            pins.append(
                {
                    "ident": idents[name],
                    "head": c_json_string(f"flexure {name!r} (prb): pin rotation "),
                    "tail": c_json_string(
                        f" is past the pseudo-rigid-body model's {_deg(PRB_LIMIT)} validity; no "
                        "accuracy is claimed for it"
                    ),
                }
            )
    prb = [n for n, m in models.items() if getattr(m, "kind", "") == "prb"]
    case_head = (
        f"{_names(prb)} (prb): the pseudo-rigid-body constants are fitted for a force at the tip "
        "of a single flexure, and this scene has "
    )
    case_tail = "; no accuracy is claimed"
    structure = prb_several_flexures(scene) if prb else None
    runtime = _prb_runtime(scene, models)
    return {
        "unstable": c_json_string(UNSTABLE),
        "prb_limit": c_double(PRB_LIMIT),
        "bend_limit": c_double(BEND_LIMIT),
        "scm": scm,
        "pins": pins,
        "prb_structure": None
        if structure is None
        else c_json_string(case_head + structure + case_tail),
        # checked per call, after a moment, in the library's order (validity._prb_case_problem)
        "prb_tendon": c_json_string(case_head + PRB_TENDON + case_tail)
        if runtime is not None and runtime["tendons"]
        else None,
        "prb_off_tip": []
        if runtime is None
        else [
            {
                "index": i,
                "text": c_json_string(case_head + prb_off_tip(scene.loads[i].point) + case_tail),
            }
            for i in runtime["off_tip"]
        ],
        "scene": [c_json_string(w) for w in scene_warnings(scene)],
        # the library's order (validity._prb_case_problem): a moment first, then the structure
        "prb_moment": None
        if not prb or not scene.loads
        else {
            "head": c_json_string(case_head + "a moment at "),
            "tail": c_json_string(case_tail),
            "points": [c_json_string(repr(ld.point)) for ld in scene.loads],
        },
        # the flexure bent most, in body order (flexgen.Result.bend's order), as assess picks it
        "body_order": [flex_index[n] for n in order],
        "bend_heads": [
            c_json_string(f"flexure {f.name!r} ({model_label(models[f.name])}): bent ")
            for f in scene.flexures
        ],
        "bend_tail": c_json_string(
            f", past the {_deg(BEND_LIMIT)} to which the error estimate's Gauss kernels are "
            "certified; no accuracy is claimed"
        ),
        # every flexure with a thickness, in the scene's order (validity.strain_warnings)
        "strain": [
            {
                "ident": idents[f.name],
                "half": c_double(0.5 * float(f.thickness)),
                "head": c_json_string(strain_warning_parts(f.name)[0]),
                "tail": c_json_string(strain_warning_parts(f.name)[1]),
            }
            for f in scene.flexures
            if f.thickness is not None
        ],
        "strain_limit": c_double(STRAIN_LIMIT),
    }


def _enum_names(scene: Scene) -> list[tuple[str, str]]:
    return _enum("flexure.name", [f.name for f in scene.flexures])


def _settings_rows(settings: SolverSettings, number, upper: str) -> list[tuple[str, str]]:
    rows = []
    for f in fields(settings):
        value = getattr(settings, f.name)
        if f.name == "warm_on_path":  # the controller's compile-time choice (CONTROLLER)
            rows.append((f.name, f"{upper}_WARM_ON_PATH"))
            continue
        rows.append((f.name, str(value) if isinstance(value, int) else number(value)))
    return rows


def _check_single_inputs(scene: Scene) -> None:
    """The scene's own loads and tensions within the float twin's inputs (SINGLE_MAX_MAGNITUDE),
    which its NAME_inputs_default gives and its solve would refuse as bad input."""
    limit = SINGLE_MAX_MAGNITUDE
    for i, load in enumerate(scene.loads):
        for key, values in (("force", load.force), ("moment", (load.moment,))):
            if any(abs(v) > limit for v in values):
                raise EmitError(
                    f"load[{i}].{key}: {_fmt(list(values) if key == 'force' else load.moment)} "
                    f"is beyond the float twin's largest input {limit:g} (--float); the double "
                    "controller takes it"
                )
    for i, tendon in enumerate(scene.tendons):
        if abs(tendon.tension) > limit:
            raise EmitError(
                f"tendon[{i}].tension: {_fmt(tendon.tension)} is beyond the float twin's largest "
                f"input {limit:g} (--float); the double controller takes it"
            )


def controller_context(path: Path, options: Options) -> dict[str, Any]:
    """Everything the controller templates print, from the scene at ``path``."""
    from flexgen.core import lib
    from flexgen.models.registry import build_models
    from flexgen.problem import Problem

    scene, tolerance_note = _prepared_scene(path)
    if options.single:
        _check_single_inputs(scene)
    models = build_models(scene)
    problem = Problem(scene, models, DEFAULT)
    settings = SINGLE if options.single else CONTROLLER
    p = problem.struct
    number = c_float if options.single else c_double
    loads = _enum("load.point", [ld.point for ld in scene.loads])
    outputs = _enum("output.points", list(problem.outputs))
    flex_names = _enum_names(scene)
    rows = _flexure_rows(scene, problem, models, number)
    strain_half, bound_by_max, bound_factor = _strain_checks(
        scene, models, list(problem.flexure_order)
    )
    kernel_names = sorted({k for r in rows for k in (r["local"], r["poly"], r["gauss"]) if k})
    points = [
        {"frame": int(p.points[i].frame), "x": float(p.points[i].x), "y": float(p.points[i].y)}
        for i in range(max(int(p.npoints), 0))
    ]
    ints = lambda ptr, n: [int(ptr[i]) for i in range(n)]  # noqa: E731
    nroute = sum(ints(p.route_len, int(p.ntendons)))
    slices = problem.chain.slices
    return {
        "name": options.prefix,
        "NAME": options.prefix.upper(),
        # scene text in comments and strings, escaped (c_comment, c_json_string)
        "scene_file": c_comment(options.scene_file),
        "scene_name": c_comment(scene.name),
        "scene_name_json": c_json_string(scene.name),
        "command": c_comment(
            f"flexgen generate --scene {options.scene_file} --prefix {options.prefix}"
            + (" --float" if options.single else "")
        ),
        "real": "float" if options.single else "double",
        "kernel_suffix": "_f" if options.single else "",
        "tol": f"{settings.tol:g}",
        "single": options.single,
        "number": number,
        "ndof": int(p.ndof),
        "nflex": int(p.nflex),
        "npoints": int(p.npoints),
        "nloads": int(p.nloads),
        "ntendons": int(p.ntendons),
        "noutputs": int(p.noutputs),
        # every flexure's number of coordinates where they all have the same (else None)
        "flex_ndof": _same(int(p.flex[i].ndof) for i in range(int(p.nflex))),
        "nroute": nroute,
        "nwork": max(int(lib.fg_work_size(p)), 1),
        "niwork": max(int(lib.fg_iwork_size(p)), 1),
        "loads": [
            {"ident": ident, "point": c_comment(point), "value": [*ld.force, ld.moment]}
            for (ident, point), ld in zip(loads, scene.loads)
        ],
        "tensions": [t.tension for t in scene.tendons],
        "tendon_routes": [c_comment(" -> ".join(t.route)) for t in scene.tendons],
        "outputs": [(ident, c_comment(point)) for ident, point in outputs],
        "output_json": [c_json_string(point) for _, point in outputs],
        "output_repr": [c_json_string(repr(point)) for _, point in outputs],
        "flexure_enum": [(ident, c_comment(flexure)) for ident, flexure in flex_names],
        "flexure_slices": [
            (c_comment(name), c_json_string(name), slices[name].start, slices[name].stop)
            for name in slices
        ],
        "flexures": rows,
        "points": points,
        "point_names": [c_comment(n) for n in problem.points],
        "load_point": ints(p.load_point, int(p.nloads)),
        "route_start": ints(p.route_start, int(p.ntendons)),
        "route_len": ints(p.route_len, int(p.ntendons)),
        "route": ints(p.route, nroute),
        "output_index": ints(p.outputs, int(p.noutputs)),
        "stiffness": [number(float(v)) for v in problem.stiffness],
        "claim_limits": [number(v) for v in _claim_limits(scene, models, problem.flexure_order)],
        "strain_half": [number(v) for v in strain_half],
        "bound_by_max": bound_by_max,
        "bound_factor": [number(v) for v in bound_factor],
        "strain_limit": number(STRAIN_LIMIT),
        "strain_percent": f"{100 * STRAIN_LIMIT:g}",
        "strain_checked": any(v > 0.0 for v in strain_half),
        "prb_structure": _prb_structure(scene, models),
        "tolerance_note": tolerance_note,
        "thick": [c_comment(repr(n)) for n in _thick_flexures(scene)],
        "prb_runtime": _prb_runtime(scene, models),
        "near_critical": f"{NEAR_SINGULAR!r}",
        "float_margin": f"{FLOAT_MARGIN!r}",
        "near_critical_percent": f"{NEAR_SINGULAR:.0%}",
        "near_critical_factor": f"{1 / NEAR_SINGULAR:.3g}",
        # the library's limit on every load value and tension (flexgen/scene.py: _number); the
        # float twin's is its float counterpart (SINGLE_MAX_MAGNITUDE)
        "max_magnitude": c_double(SINGLE_MAX_MAGNITUDE if options.single else MAX_MAGNITUDE),
        "units": _units(scene),
        "q_meaning": _q_meaning(models),
        "kinds": sorted({_kind(m) for m in models.values()}),
        "texts": _warning_texts(scene, models, list(problem.flexure_order)),
        "warm_change": f"{WARM_CHANGE!r}",  # flexgen/warm.py: the studies' rule too
        "settings": _settings_rows(settings, c_double, options.prefix.upper()),
        "kernels": kernel_names,
        "kernel_blocks": [_kernel_block(k, options.single) for k in kernel_names],
        "core": _core_text(),
    }


TEMPLATES = {
    "{name}.h": "controller/controller.h.jinja",
    "{name}.c": "controller/controller.c.jinja",
    "{name}_example.c": "controller/example.c.jinja",
    "{name}.mk": "controller/controller.mk.jinja",
    "CMakeLists.txt": "controller/CMakeLists.txt.jinja",
}


def controller_files(path: Path, prefix: str | None = None, single: bool = False) -> dict[str, str]:
    """{file name: text} of the controller of the scene file ``path`` (see the module doc).
    ``prefix`` None: the scene file's stem (``default_prefix``)."""
    path = Path(path)
    stem = path if prefix is None else None  # the prefix is the file name's: messages say so
    options = Options(
        path.name,
        check_prefix(prefix if prefix is not None else default_prefix(path), stem),
        bool(single),
    )
    context = controller_context(path, options)
    _check_no_clash(context, stem)
    return {
        out.format(name=options.prefix): render(template, context)
        for out, template in TEMPLATES.items()
    }
