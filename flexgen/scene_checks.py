"""Facts about a valid scene that are likely mistakes, put on every Result of the scene: notes
(``scene_notes``: a forgotten ``at``) and warnings (``scene_warnings``: a flexure too thick for
the slender-beam model, which no error estimate covers).

A link has no length of its own: its frame is its parent flexure's tip frame, and a child flexure
starts where its ``at`` puts it in that frame. A flexure that leaves ``at`` out starts at the link's
origin, so a link drawn 30 mm long in the author's head (its points out at 30 mm) becomes a
joint of zero length: the scene solves, silently, to another mechanism. The scene cannot say
whether ``at`` was written, so the sign is the geometry: the child starts at the link origin while
the link's own points reach farther from it than the shorter of the two flexures the link joins is
long. A link that reaches that far is a body of real extent (a pad a few millimetres off a
flexure is not), and a flexure starting at its near end is then more likely a forgotten ``at``
than a design.
"""

from __future__ import annotations

import math
from typing import cast

from .scene import Flexure, Scene


def scene_notes(scene: Scene) -> list[str]:
    """One note per flexure that looks like it forgot its ``at`` (see the module docstring),
    whose strengths cannot be checked, or whose ``at`` angle looks written in degrees."""
    notes = []
    for f in scene.flexures:
        if (f.yield_strength is not None or f.fatigue_strength is not None) and (
            f.E is None or f.thickness is None
        ):  # review: the designer believed the check ran
            notes.append(
                f"flexure {f.name!r}: its strengths are not checked (no safety factor): a "
                f"bending stress needs E and thickness, and it gives "
                f"{'EI' if f.E is None else 'E'}"
                f"{'' if f.thickness is None else ' and thickness'}"
            )
        if abs(f.at[2]) > 2 * math.pi:  # plain angles are radians; more than a turn: degrees?
            notes.append(
                f"flexure {f.name!r}: at angle {f.at[2]:g} is read in radians "
                f'({math.degrees(f.at[2]):.4g} deg); for degrees write "{f.at[2]:g} deg"'
            )
    for f in scene.flexures:
        if scene.body_kind(f.parent) != "link" or (f.at[0], f.at[1]) != (0.0, 0.0):
            continue
        link = scene.link(f.parent)
        if not link.points:
            continue
        name, (px, py) = max(link.points.items(), key=lambda kv: math.hypot(*kv[1]))
        reach = math.hypot(px, py)
        joined = min(f.length, scene.flexure(link.parent).length)
        if reach > joined:
            notes.append(
                f"flexure {f.name!r} starts at the origin of link {link.name!r} (the tip of "
                f"flexure {link.parent!r}) while the link's point {name!r} lies "
                f"{reach:.4g}{_spaced(scene.unit_of('length'))} "
                f"from that origin: a link has no length; if {f.name!r} should start further "
                f"along, give it at = [x, y, angle] in the frame of {link.name!r}"
            )
    return notes


def _spaced(unit: str) -> str:
    """A unit after a number: " mm", or nothing for a scene of plain numbers."""
    return f" {unit}" if unit else ""


# below this length/thickness the model's slender beam (no shear, plane sections: the elastica
# every model here approximates) is off by several percent, beyond any error estimate flexgen
# states (shear adds about (E/G)(t/L)^2 to a cantilever's deflection: 8 % at L = 5 t)
MIN_SLENDERNESS = 5.0


def thick_flexures(scene: Scene) -> list[Flexure]:
    """The flexures whose thickness (when given) is more than 1/MIN_SLENDERNESS of their
    length: outside the slender-beam model (the emitted controller flags them too)."""
    return [
        f
        for f in scene.flexures
        if f.thickness is not None and f.length < MIN_SLENDERNESS * f.thickness
    ]


# Plain numbers of a scene whose other values carry units are read in SI (docs/scene.md, "Units")
# when the scene declares no ``units``. A plain stress below 1 MPa (no flexure material: the
# softest elastomers are about that) or a plain length above 10 m (no flexure) read in SI is a
# scene whose plain numbers were written in another system (mm and MPa, say): review, one
# "1400 MPa" strength made a plain-mm steel flexure 20 m long with E = 200 kPa, unwarned.
SI_MIN_PLAIN_STRESS = 1e6
SI_MAX_PLAIN_LENGTH = 10.0


def mixed_units(scene: Scene) -> str | None:
    """The warning of plain numbers read in SI that look written in another system, or None."""
    from .scenepath import thaw
    from .units import _get, locations

    if scene.units is None or scene.source is None or "units" in scene.source:
        return None
    src = thaw(scene.source)  # plain dicts and lists, as locations reads them
    found = []  # (key, value, SI unit) of every such plain number, in scene order
    for path, key, dim in locations(src):
        value = _get(src, path)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value == 0:
            continue
        if (dim == "stress" and abs(value) < SI_MIN_PLAIN_STRESS) or (
            dim == "length" and abs(value) > SI_MAX_PLAIN_LENGTH
        ):
            found.append((key, value, {"stress": "Pa", "length": "m"}[dim]))
    if not found:
        return None
    key, value, si = found[0]
    more = ""
    if len(found) > 1:
        others = ", ".join(f"{k} = {v:g} {u}" for k, v, u in found[1:4])
        more = f" (so are {others}{', ...' if len(found) > 4 else ''})"
    return (
        f"{key} = {value:g} is a plain number in a scene whose other values carry units "
        f"and which declares no units, so it is read in SI: {value:g} {si}{more}; if the plain "
        f'numbers are in other units, declare them (units = {{length = "mm", force = '
        f'"N"}}) or give each a unit'
    )


# no material is stiffer (diamond: 1.2e12 Pa) or stronger than this: an E or a strength above it
# is a value in Pa written in a scene whose stresses are in MPa or GPa (review: E = 200e9 in an
# mm/N scene, so 2e17 Pa, solved without a word)
MAX_MATERIAL_STRESS_PA = 2e12


def implausible_stresses(scene: Scene) -> list[str]:
    """One warning per key and value (E, a strength) that, in Pa, is beyond any material's, in
    a scene that declares its units (a plain-number scene is one consistent set of any units:
    cgs steel has E = 2e12 dyn/cm^2; review), naming every flexure that has it (a [model]
    strength is every flexure's: said once)."""
    if scene.units is None:
        return []
    from .units import registry

    unit = f"{scene.units.force} / {scene.units.length} ** 2"
    pa = float(registry().Quantity(1.0, unit).to("Pa").magnitude)
    label = scene.units.label("stress")
    found: dict[tuple[str, float], list[str]] = {}  # (key, value) -> flexures, in scene order
    for f in scene.flexures:
        given = {
            "E": f.E,
            "yield_strength": f.yield_strength,
            "fatigue_strength": f.fatigue_strength,
        }
        for key, value in given.items():
            if value is not None and value * pa > MAX_MATERIAL_STRESS_PA:
                found.setdefault((key, value), []).append(f.name)
    out = []
    for (key, value), names in found.items():
        who = ", ".join(repr(n) for n in names)
        out.append(
            f"flexure{'s' if len(names) > 1 else ''} {who}: {key} = {value:g} {label} is "
            f"{value * pa:.3g} Pa, beyond any material's ({MAX_MATERIAL_STRESS_PA:g} Pa): a "
            f"value in Pa in a scene whose stresses are in {label}? (or give it a unit, as "
            f'"{value:g} Pa")'
        )
    return out


def scene_warnings(scene: Scene) -> list[str]:
    """One warning per flexure of ``thick_flexures``: outside the beam model, and often a unit
    slip (a length in m in an mm scene); one for plain numbers read in SI that look written in
    another system (``mixed_units``); one per flexure whose E or strength is beyond any
    material's (``implausible_stresses``)."""
    out = []
    mixed = mixed_units(scene)
    if mixed:
        out.append(mixed)
    out.extend(implausible_stresses(scene))
    unit = _spaced(scene.unit_of("length"))  # (review: "lies 30 from that origin" in mm)
    for f in thick_flexures(scene):
        t = cast(float, f.thickness)  # given: thick_flexures reads only given thicknesses
        out.append(
            f"flexure {f.name!r}: length {f.length:.4g}{unit} is only {f.length / t:.2g} times "
            f"its thickness {t:.4g}{unit}: the model is a slender beam (no shear), off by several "
            f"percent below {MIN_SLENDERNESS:g} thicknesses (check the units of both)"
        )
    return out
