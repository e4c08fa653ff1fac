"""Scene values with units: ``length = "20 mm"``, ``E = "200 GPa"``, ``at = [0, 0, "30 deg"]``.

One job: turn the unit strings of a raw scene dict (what ``tomllib`` returns) into plain floats in
one consistent system, before ``flexgen.scene`` validates it (``normalise``), and name that
system's units for the output (``Units``). docs/scene.md, "Units", is the user's description.

The internal system is the output system: the scene's ``units`` choice (``"SI"``, or a table
``{length = "mm", force = "N"}``; SI when a value carries a unit and there is no choice) converts
every quantity into it, so the solver computes in it and every answer is already in it
(compliance length/force, stress force/length^2, generalized stiffness force x length). Angles are
always radians. Plain numbers are read as being in that system. A scene without a unit string
and without ``units`` is returned untouched (``Units`` None), and pint is not even imported:
it costs about 0.5 s, which ``import flexgen`` and a plain scene do not pay.

This module imports only the standard library at load time (pint inside functions) and nothing
from flexgen: ``flexgen.scene`` imports it and turns its ``UnitsError`` into a ``SceneError``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Any, cast

if TYPE_CHECKING:  # pint is imported only when a scene uses units
    import pint

# The dimensions of scene values, and an example unit of each for messages. Each is a product of
# powers of the system's length L and force F (and rad for "angle"): (power of L, power of F).
DIMENSIONS: dict[str, tuple[int, int]] = {
    "length": (1, 0),
    "force": (0, 1),
    "moment": (1, 1),  # force x length
    "bending stiffness": (2, 1),  # EI: force x length^2
    "stress": (-2, 1),  # E and the strengths: force / length^2
    "second moment of area": (4, 0),  # I: length^4
    "angle": (0, 0),  # radians, whatever L and F are
}
EXAMPLES = {
    "length": "mm",
    "force": "N",
    "moment": "N*mm",
    "bending stiffness": "N*mm^2",
    "stress": "GPa",
    "second moment of area": "mm^4",
    "angle": "deg",
}

# Where each dimension lives in a scene (the key table). The counts ``modes``, ``elements`` and
# ``tolerance`` are dimensionless and not listed: a string there is the validator's error.
FLEXURE = {
    "length": "length",
    "width": "length",
    "thickness": "length",
    "EI": "bending stiffness",
    "E": "stress",
    "I": "second moment of area",
    "yield_strength": "stress",
    "fatigue_strength": "stress",
}
MODEL = {"yield_strength": "stress", "fatigue_strength": "stress"}  # [model], flexure's model
AT = ("length", "length", "angle")  # [[flexure]].at = [x, y, angle]
POINT = ("length", "length")  # every named point [x, y]
LOAD = {"moment": "moment"}  # and force = [fx, fy]: force
TENDON = {"tension": "force"}
UNITS_KEYS = ("length", "force")


def key_dimension(path: str) -> str | None:
    """The dimension of the value a study's dotted path names (``flexure.0.thickness``,
    ``load.1.force.0``, ``link.pad.points.tip.1``, as ``flexgen sweep --vary`` takes them),
    from the key table above; None for a count or a path the table does not cover. Every
    spelling the study takes names the same key (``flexure[0].thickness``, ``load.0.force.01``:
    review, the plot's axis lost its unit)."""
    from .scenepath import PathError, _position, _segments

    try:
        segs = [seg if (i := _position(seg)) is None else str(i) for seg in _segments(path)]
    except PathError:
        return None
    head, last = segs[0], segs[-1]
    if head == "flexure" and len(segs) >= 3:
        if segs[2] == "at" and len(segs) == 4 and segs[3] in ("0", "1", "2"):
            return AT[int(segs[3])]
        return MODEL.get(last) if segs[2] == "model" else FLEXURE.get(last)
    if head == "model":
        return MODEL.get(last)
    if head == "load":
        return "force" if "force" in segs else LOAD.get(last)
    if head == "tendon":
        return TENDON.get(last)
    if "points" in segs:
        return "length"
    return None


MAX_TEXT = 100  # characters of a unit string (longer is an error before pint sees it)
# a leading decimal number (no nan/inf, no underscores), then the unit expression
_QUANTITY = re.compile(r"\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(.*?)\s*", re.S)
# pint evaluates a unit expression's numbers as Python numbers ("10**10**10" would take hours), so
# a unit expression may hold digits only in exponents of at most two digits, not chained
# ("mm^4", "N/mm**2", "m**(-1)"), and as a leading "1/" ("1/mm"); anything else is refused first
_EXPONENT = re.compile(r"(?:\*\*|\^)\s*(?:[+-]?\d{1,2}|\(\s*[+-]?\d{1,2}\s*\))(?!\s*(?:\*\*|\^))")
_RECIPROCAL = re.compile(r"(?:^|(?<=\())\s*1\s*/")
# units pint counts as dimensionless that are plane angles (pint's canonical names, any prefix;
# "grade" is also gradian and gon, "turn" also cycle and revolution). Matched by the unit's name
# less its prefix: a suffix match read a steradian or a square degree as an angle (review).
# Not "mil": an angular mil to pint, a thousandth of an inch to many engineers
_ANGLES = frozenset({"radian", "degree", "arcminute", "arcsecond", "turn", "grade"})


class UnitsError(ValueError):
    """A unit string or ``units`` choice that cannot be used; one line naming the key."""


@dataclass(frozen=True)
class Units:
    """The units of a scene's numbers and of its answers: a length and a force unit (short,
    ASCII symbols such as "mm", "N"; angles are radians)."""

    length: str = "m"
    force: str = "N"

    def label(self, quantity: str) -> str:
        """The unit of ``quantity``: "length", "force", "moment", "angle", "compliance"
        (length/force), "rotational compliance" (rad/(force x length)), "cross compliance"
        (compliance3's d(position)/d(moment) and d(angle)/d(force): 1/force), "stress"
        (force/length^2, named: N/mm^2 is "MPa"), "curvature" (1/length), "stiffness" (the
        generalized stiffness, force x length), "EI" (force x length^2)."""
        L, F = _group(self.length), _group(self.force)
        labels = {
            "length": self.length,
            "force": self.force,
            "moment": f"{F}*{L}",
            "angle": "rad",
            "compliance": f"{L}/{F}",
            "rotational compliance": f"rad/({F}*{L})",
            "cross compliance": f"1/{F}",
            "curvature": f"1/{L}",
            "stiffness": f"{F}*{L}",
            "EI": f"{F}*{L}^2",
            "bending stiffness": f"{F}*{L}^2",
            "second moment of area": f"{L}^4",
        }
        if quantity == "stress":
            return _stress_name(self.length, self.force) or f"{F}/{L}^2"
        try:
            return labels[quantity]
        except KeyError:
            raise ValueError(
                f"units: no label for {quantity!r} (known: {', '.join(labels)}, stress)"
            ) from None

    def as_dict(self) -> dict[str, str]:
        """The JSON "units" object of a result."""
        keys = ("length", "force", "moment", "angle", "compliance", "stress", "curvature")
        # compliance3's blocks other than the 2x2 (review: one label for three units)
        more = ("stiffness", "cross compliance", "rotational compliance")
        return {k: self.label(k) for k in keys + more}


def result_units(scene: Any) -> dict[str, str] | None:
    """The "units" object of a result of ``scene`` (a Scene; None when it gave no units)."""
    return None if scene.units is None else scene.units.as_dict()


# -- the registry (pint, loaded on first use) --------------------------------------------------


@cache
def registry() -> pint.UnitRegistry:
    """The one pint registry (created on first use: importing pint and building the registry
    take about 0.5 s)."""
    import pint

    return pint.UnitRegistry()


def _group(symbol: str) -> str:
    """A unit symbol as a factor of a product or quotient: "N" stays, "kg*m/s^2" is bracketed."""
    return f"({symbol})" if any(c in symbol for c in "*/^ ") else symbol


def _symbol(unit: pint.Unit) -> str:
    """pint's short symbol, ASCII and without spaces: "mm", "N", "um" (not "µm"), "kg*m/s^2"."""
    text = format(unit, "~").replace("µ", "u").replace(" ** ", "^").replace("**", "^")
    return text.replace(" * ", "*").replace(" / ", "/").replace(" ", "")


def _stress_name(length: str, force: str) -> str | None:
    """A pascal with an SI prefix if force/length^2 is one exactly ("MPa" for N/mm^2), else None."""
    ureg = registry()
    try:
        pa = ureg.Quantity(1.0, f"({force})/({length})**2").to("Pa").magnitude
    except Exception:  # a unit pint cannot read or convert: keep the plain quotient
        return None
    for prefix, factor in (("m", 1e-3), ("", 1.0), ("k", 1e3), ("M", 1e6), ("G", 1e9), ("T", 1e12)):
        if abs(pa - factor) <= 1e-9 * factor:
            return f"{prefix}Pa"
    return None


# -- where the values are ------------------------------------------------------------------------


def _key(k: Any) -> str:
    """A key as ``flexgen.scene`` shows it in a message (``scene._key``): itself if printable and
    short, else its repr, cut to 80 characters."""
    text = k if isinstance(k, str) else repr(k)
    if text.isprintable() and len(text) <= 80:
        return text
    text = repr(text)
    return text if len(text) <= 80 else text[:77] + "..."


def _vector(v: Any, dims: tuple[str, ...], path: tuple, key: str) -> Iterator[tuple]:
    # a list of the wrong length is left to the validator (its message names the expected form)
    if isinstance(v, (list, tuple)) and len(v) == len(dims):
        for i, dim in enumerate(dims):
            yield path + (i,), f"{key}[{i}]", dim


def _table(tbl: Any, dims: Mapping[str, str], path: tuple, key: str) -> Iterator[tuple]:
    if isinstance(tbl, Mapping):
        for k, dim in dims.items():
            if k in tbl:
                yield path + (k,), f"{key}.{k}", dim


def _points(tbl: Any, path: tuple, key: str) -> Iterator[tuple]:
    if isinstance(tbl, Mapping):
        for name, xy in tbl.items():
            yield from _vector(xy, POINT, path + (name,), f"{key}.{_key(name)}")


def _tables(d: Mapping, name: str) -> Iterator[tuple[int, Mapping]]:
    items = d.get(name)
    if isinstance(items, list):
        for i, t in enumerate(items):
            if isinstance(t, Mapping):
                yield i, t


def locations(d: Mapping) -> Iterator[tuple[tuple, str, str]]:
    """(path into ``d``, key as scene.py names it, dimension) of every value of a scene dict that
    has a dimension. Values in a structure of the wrong shape are skipped: the validator rejects
    the structure."""
    yield from _table(d.get("model"), MODEL, ("model",), "model")
    base = d.get("base")
    if isinstance(base, Mapping):
        yield from _points(base.get("points"), ("base", "points"), "base.points")
    for i, t in _tables(d, "flexure"):
        p, k = ("flexure", i), f"flexure[{i}]"
        yield from _table(t, FLEXURE, p, k)
        yield from _vector(t.get("at"), AT, p + ("at",), f"{k}.at")
        yield from _table(t.get("model"), MODEL, p + ("model",), f"{k}.model")
    for i, t in _tables(d, "link"):
        yield from _points(t.get("points"), ("link", i, "points"), f"link[{i}].points")
    for i, t in _tables(d, "load"):
        yield from _vector(
            t.get("force"), ("force", "force"), ("load", i, "force"), f"load[{i}].force"
        )
        yield from _table(t, LOAD, ("load", i), f"load[{i}]")
    for i, t in _tables(d, "tendon"):
        yield from _table(t, TENDON, ("tendon", i), f"tendon[{i}]")


def keep_unit_strings(before: Mapping, after: dict) -> None:
    """Keep ``after`` (a changed copy of the scene dict ``before``, no ``units`` key) a scene with
    unit strings where ``before`` was one and the change replaced every unit string by a plain
    number: those numbers are written back as strings in SI, the system both are read in
    (``"2.1e+11 Pa"``). Without it the changed scene had no units at all: its answers unlabelled
    and the warning of plain numbers that look written in another system gone (review: a study
    of the only unit-string value, E)."""
    if "units" in after:
        return
    strings = [(path, dim) for path, _, dim, _ in _unit_strings(before)]
    if not strings or _unit_strings(after):
        return
    si = _system("SI")
    for path, dim in strings:
        try:
            value = _get(after, path)
        except (KeyError, IndexError, TypeError):
            continue  # the change removed it
        if isinstance(value, bool) or not isinstance(value, int | float):
            continue  # the validator's to refuse
        try:
            number = float(value)
        except OverflowError:  # 10**400
            continue
        if not math.isfinite(number):
            continue  # as given: the validator's message quotes the user's own value (review)
        unit = "Pa" if dim == "stress" else _symbol(si.unit(dim))
        container = _get(after, path[:-1])
        container[path[-1]] = f"{number!r} {unit}"


def _unit_strings(d: Mapping) -> list[tuple[tuple, str, str, str]]:
    """(path, key, dimension, text) of every value of a scene dict written with a unit."""
    return [
        (path, key, dim, value)
        for path, key, dim in locations(d)
        if isinstance(value := _get(d, path), str)
    ]


def _get(d: Any, path: tuple) -> Any:
    for k in path:
        d = d[k]
    return d


def _replaced(d: Mapping, values: dict[tuple, float]) -> dict:
    """A copy of ``d`` with the value at each path replaced; only the containers on those paths
    are copied (never a deep copy: the rest may be anything, nested arbitrarily deep)."""
    root = dict(d)
    copies: dict[tuple, Any] = {(): root}
    for path, value in values.items():
        node = root
        for depth in range(1, len(path)):
            sub = path[:depth]
            if sub not in copies:
                child = node[path[depth - 1]]
                copies[sub] = dict(child) if isinstance(child, Mapping) else list(child)
                node[path[depth - 1]] = copies[sub]
            node = copies[sub]
        node[path[-1]] = value
    return root


# -- reading units -------------------------------------------------------------------------------


def _parse_unit(text: str) -> pint.Unit:
    """pint's Unit for ``text``; UnitsError's message (without the key) if it is none."""
    rest = _RECIPROCAL.sub("", _EXPONENT.sub("", text))
    # superscripts are digits too: one at a time ("mm⁴", "m⁻¹"; pint reads "m⁹⁹⁹" as m**999)
    sup = "⁰¹²³⁴⁵⁶⁷⁸⁹"
    if any(c.isdigit() and c not in sup for c in rest) or re.search(
        f"[{sup}]{{2}}|\\*\\*|\\^", rest
    ):
        raise UnitsError(f"cannot read the unit {text!r} (numbers only as small exponents)")
    ureg = registry()
    try:
        return ureg.parse_units(text)
    except Exception as e:  # pint raises many types (undefined unit, token and syntax errors)
        import pint

        if isinstance(e, pint.UndefinedUnitError):
            names = e.unit_names if isinstance(e.unit_names, (list, tuple)) else [e.unit_names]
            raise UnitsError(f"unknown unit {', '.join(map(repr, names))}") from None
        raise UnitsError(f"cannot read the unit {text!r}") from None


def _is_angle(unit: pint.Unit) -> bool:
    parts = dict(unit._units)
    if len(parts) != 1 or next(iter(parts.values())) != 1:
        return False
    readings = registry().parse_unit_name(next(iter(parts)))  # ((prefix, name, suffix), ...)
    return any(name in _ANGLES for _, name, _ in readings)


def _dimensionless_factor(unit: pint.Unit) -> str | None:
    """The first factor of ``unit`` that has no dimension ("degree" in mm*deg), else None."""
    ureg = registry()
    return next((name for name in unit._units if ureg.Unit(name).dimensionless), None)


def _dimension_name(unit: pint.Unit) -> str:
    """The name of a unit's dimension as this module names them, else pint's ("[mass] / ...")."""
    if unit.dimensionless:
        return "angle" if _is_angle(unit) else "none (a plain ratio)"
    si = System(registry().meter, registry().newton)
    for name in DIMENSIONS:
        if name != "angle" and unit.dimensionality == si.unit(name).dimensionality:
            return name
    return str(unit.dimensionality)


@dataclass(frozen=True)
class System:
    """The pint units of a scene's internal (= output) system."""

    length: pint.Unit
    force: pint.Unit

    def unit(self, dimension: str) -> pint.Unit:
        if dimension == "angle":
            return registry().radian
        p, q = DIMENSIONS[dimension]
        # no zero power: pint would keep it in the unit's name ("m^0*N")
        unit = (
            self.force**q
            if p == 0
            else self.length**p
            if q == 0
            else self.length**p * self.force**q
        )
        return cast("pint.Unit", unit)

    @property
    def units(self) -> Units:
        return Units(length=_symbol(self.length), force=_symbol(self.force))


def _system(choice: Any) -> System:
    """The system of a ``units`` choice: "SI" or a table {length = ..., force = ...} (a key not
    given is SI's)."""
    ureg = registry()
    if choice == "SI":
        return System(ureg.meter, ureg.newton)
    if not isinstance(choice, Mapping):
        shown = repr(choice) if len(repr(choice)) <= 60 else repr(choice)[:57] + "..."
        raise UnitsError(
            f'units: must be "SI" or a table such as {{length = "mm", force = "N"}}, got {shown}'
        )
    for k in choice:
        if k not in UNITS_KEYS:
            raise UnitsError(f"units.{_key(k)}: unknown key (allowed: {', '.join(UNITS_KEYS)})")
    chosen = {}
    for k in UNITS_KEYS:
        text = choice.get(k, {"length": "m", "force": "N"}[k])
        key = f"units.{k}"
        if not isinstance(text, str) or not text.strip() or len(text) > MAX_TEXT:
            raise UnitsError(f'{key}: must be a unit such as "{EXAMPLES[k]}", got {_show(text)}')
        try:
            unit = _parse_unit(text)
        except UnitsError as e:
            raise UnitsError(f"{key}: {_show(text)}: {e}") from None
        if (ratio := _dimensionless_factor(unit)) is not None:
            raise UnitsError(f"{key}: {_show(text)}: a {k} unit cannot have the factor {ratio!r}")
        if unit.dimensionality != System(ureg.meter, ureg.newton).unit(k).dimensionality:
            raise UnitsError(
                f"{key}: {_show(text)} has dimension {_dimension_name(unit)}, expected {k}"
            )
        chosen[k] = unit
    return System(chosen["length"], chosen["force"])


def _show(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 80 else text[:77] + "..."


# the spellings of a newton metre that pint reads as something else: "Nm" is a yarn count
# (number_meter) to pint, "Nmm" no unit at all
_NEWTON_METRE = re.compile(r"[kmuµ]?N\s?[mµu]?m")


def quantity(text: str, dimension: str, system: System, key: str) -> float:
    """The value of the unit string ``text`` in ``system``, as a float; UnitsError naming
    ``key`` if it is not a finite number and a unit of ``dimension``."""

    def fail(msg: str) -> UnitsError:
        return UnitsError(f"{key}: {_show(text)}: {msg}" if msg else key)

    # a strength's example unit is MPa (E's GPa: "1400" is no steel's strength in GPa)
    example = "MPa" if key.endswith("_strength") else EXAMPLES[dimension]

    if len(text) > MAX_TEXT:
        raise fail(f"too long for a quantity (at most {MAX_TEXT} characters)")
    m = _QUANTITY.fullmatch(text)
    if m is None:
        raise fail(f'expected a number and a unit, such as "20 {example}"')
    number, unit_text = float(m[1]), m[2]
    if not unit_text:
        raise fail(
            f'a number without a unit: write it as a number, or with a unit ("{m[1]} {example}")'
        )
    if not math.isfinite(number):
        raise fail("not a finite number")
    newton_metre = '; a newton metre is written "N*m"' if _NEWTON_METRE.fullmatch(unit_text) else ""
    try:
        unit = _parse_unit(unit_text)
    except UnitsError as e:
        raise fail(str(e) + newton_metre) from None
    target = system.unit(dimension)
    wrong = unit.dimensionality != target.dimensionality
    if dimension == "angle":
        wrong = not _is_angle(unit)
    if wrong:
        raise UnitsError(
            f"{key}: {_show(text)} has dimension {_dimension_name(unit)}, expected {dimension}"
            + newton_metre
        )
    if dimension != "angle" and (ratio := _dimensionless_factor(unit)) is not None:
        # pint counts angles and ratios as no dimension: "20 mm*deg" would pass as a length
        raise fail(f"a {dimension} cannot have the factor {ratio!r} (an angle or a ratio)")
    try:
        value = float(registry().Quantity(number, unit).to(target).magnitude)
    except (OverflowError, ZeroDivisionError):
        value = math.inf
    if not math.isfinite(value):
        raise fail(f"not finite in {_symbol(target)}")
    return value


def normalise(
    d: Any,
    max_magnitude: float = math.inf,
    wrap: Callable[[float, str, str], float] | None = None,
) -> tuple[Any, Units | None]:
    """(the scene dict with every unit string replaced by its float in the scene's system, the
    system's Units), or (``d`` itself, None) when ``d`` has no unit string and no ``units`` key.
    A converted magnitude above ``max_magnitude`` is an error naming the string (the validator
    checks the plain numbers). UnitsError for anything that cannot be converted. ``wrap(value,
    text, unit symbol)``, if given, makes each converted value (``flexgen.scene`` keeps the text
    as written for its messages: ``'-20 mm' (-0.02 m)``)."""
    if not isinstance(d, Mapping):
        return d, None  # the validator's error
    found = _unit_strings(d)
    if not found and "units" not in d:
        return d, None
    system = _system(d.get("units", "SI"))
    values = {}
    for path, key, dim, text in found:
        value = quantity(text, dim, system, key)
        # the unit as a result names it (a stress in MPa, not N/mm^2: review)
        unit = system.units.label(dim) if dim == "stress" else _symbol(system.unit(dim))
        if abs(value) > max_magnitude:
            raise UnitsError(
                f"{key}: {_show(text)} is {value:g} {unit}, beyond the limit {max_magnitude:g}"
            )
        values[path] = value if wrap is None else wrap(value, text, unit)
    return _replaced(d, values) if values else d, system.units
