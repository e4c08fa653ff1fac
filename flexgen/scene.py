"""Scene model: a planar mechanism of rigid bodies joined by flexures, with loads and tendons.

A scene is loaded from TOML (``load_scene``) or a plain dict (``scene_from_dict``) and validated
into immutable dataclasses. Every validation error is a ``SceneError`` whose message names the
offending key and value in one line. See ``../shared/scene-format.md`` and ``docs/scene.md``.

Frames: the base frame is the world frame. A flexure's root frame is ``at`` in its parent body's
frame; its tip frame follows from its deformation. A link's frame is its parent flexure's tip
frame. Every flexure has the point ``"<flexure>.tip"`` = (0, 0) in its tip frame.
"""

from __future__ import annotations

import copy
import difflib
import math
import numbers
import os
import re
import reprlib
import stat
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from pathlib import Path
from types import MappingProxyType
from typing import Any

from .codegen.spec import MAX_MODES  # the shipped kernels: scm1 .. scm8
from .models.registry import MODEL_KINDS
from .tomlorder import array_order
from .units import Units, UnitsError, normalise

KERNELS = ("auto", "poly", "gauss", "local")
BASE = "base"
TIP = "tip"

MODEL_KEYS = ("kind", "modes", "elements", "kernel", "tolerance")
TOP_KEYS = ("name", "units", "model", "base", "flexure", "link", "load", "tendon", "output")
BASE_KEYS = ("points",)
STIFFNESS_KEYS = ("EI", "E", "I", "width", "thickness")
# material strengths (stress units): a [model] value is every flexure's default, a flexure's own
# (directly or in its model subtable) wins; they only give the Result's safety factors
STRENGTH_KEYS = ("yield_strength", "fatigue_strength")
FLEXURE_KEYS = (
    ("name", "parent", "at", "length") + STIFFNESS_KEYS + ("model",) + MODEL_KEYS + STRENGTH_KEYS
)
LINK_KEYS = ("name", "parent", "points")
LOAD_KEYS = ("point", "force", "moment")
TENDON_KEYS = ("tension", "route")
OUTPUT_KEYS = ("points",)
# the keys each kind of table may have, for paths into a scene (flexgen/scenepath.py)
TABLE_KEYS = {
    "": TOP_KEYS,
    "model": MODEL_KEYS + STRENGTH_KEYS,
    "base": BASE_KEYS,
    "flexure": FLEXURE_KEYS,
    "flexure.model": MODEL_KEYS + STRENGTH_KEYS,
    "link": LINK_KEYS,
    "load": LOAD_KEYS,
    "tendon": TENDON_KEYS,
    "output": OUTPUT_KEYS,
}

# Limits that keep a scene's memory and time bounded (docs/scene.md, "Limits"), checked before
# any work: a solve at the limits takes seconds, not minutes.
MAX_ELEMENTS = 512  # fem elements per flexure
MAX_BODIES = 512  # flexures and links together
MAX_COORDINATES = 2048  # generalized coordinates of the whole scene (the solver's matrices)
MAX_ENTRIES = 1000  # loads; named points; output points; tendon route points (each in total)
MAX_FILE_BYTES = 4 * 1024 * 1024  # a scene file
MAX_MAGNITUDE = 1e100  # every number's magnitude (so that products of a few stay finite)
MIN_POSITIVE = 1e-100  # the smallest length, stiffness or section dimension


class SceneError(ValueError):
    """An invalid scene; the message is one line naming the bad key and value."""


@dataclass(frozen=True)
class ModelSpec:
    kind: str = "scm"  # one of MODEL_KINDS
    modes: int = 3  # scm: Legendre curvature modes
    elements: int = 16  # fem: rigid elements per flexure
    kernel: str = (
        "auto"  # scm: "auto" (local, poly, gauss: models/scm.py), "poly", "gauss", "local"
    )
    tolerance: float | None = None  # choose modes per flexure to meet this accuracy


@dataclass(frozen=True)
class Flexure:
    name: str
    parent: str  # body name: "base", a link, or another flexure (its tip frame)
    at: tuple[float, float, float]  # root frame (x, y, angle) in the parent's frame
    length: float
    EI: float
    model: ModelSpec
    # the section as given (None: not given); thickness alone (with EI, or with E and I) only
    # places the outer fibre at thickness / 2 (docs/scene.md, "Stiffness and section")
    E: float | None = None
    width: float | None = None
    thickness: float | None = None
    I: float | None = None  # the second moment of area
    yield_strength: float | None = None
    fatigue_strength: float | None = None


# -- pickling: the read-only mappings (MappingProxyType) do not pickle, so a Scene and a Link
# pickle as their fields with those mappings as plain dicts (tagged) and are rebuilt read-only:
# scenes go to worker processes (multiprocessing, concurrent.futures), and copy.deepcopy uses it


class _FrozenMapping(dict):
    """A read-only mapping's items while pickled."""


def _pickled(v: Any) -> Any:
    if isinstance(v, MappingProxyType):
        return _FrozenMapping({k: _pickled(x) for k, x in v.items()})
    if isinstance(v, tuple):
        return tuple(_pickled(x) for x in v)
    return v


def _unpickled(v: Any) -> Any:
    if isinstance(v, _FrozenMapping):
        return MappingProxyType({k: _unpickled(x) for k, x in v.items()})
    if isinstance(v, tuple):
        return tuple(_unpickled(x) for x in v)
    return v


def _rebuilt(cls: type, state: dict[str, Any]) -> Any:
    return cls(**{k: _unpickled(v) for k, v in state.items()})


def _reduce_frozen(self: Any) -> tuple[Any, ...]:
    """``__reduce__`` of a frozen dataclass holding read-only mappings (its fields only: lazy
    lookups are rebuilt on use)."""
    return (_rebuilt, (type(self), {f.name: _pickled(getattr(self, f.name)) for f in fields(self)}))


@dataclass(frozen=True)
class Link:
    name: str
    parent: str  # a flexure name: the link's frame is that flexure's tip frame
    points: Mapping[str, tuple[float, float]]

    __reduce__ = _reduce_frozen


@dataclass(frozen=True)
class Load:
    point: str  # "<body>.<point>"
    force: tuple[float, float]
    moment: float = 0.0


@dataclass(frozen=True)
class Tendon:
    tension: float
    route: tuple[str, ...]  # point references, at least two


@dataclass(frozen=True)
class Scene:
    name: str
    model: ModelSpec
    base_points: Mapping[str, tuple[float, float]]
    flexures: tuple[Flexure, ...]
    links: tuple[Link, ...] = ()
    loads: tuple[Load, ...] = ()
    tendons: tuple[Tendon, ...] = ()
    outputs: tuple[str, ...] = field(default=())
    # Names of flexures and links in file (declaration) order. Empty: flexures, then links.
    declaration_order: tuple[str, ...] = ()
    # The units of every number above and of the answers (flexgen/units.py); None: the scene
    # gave none (plain numbers in any consistent set)
    units: Units | None = None
    # The mapping this scene was validated from (deep-frozen; flexgen/scenepath.py), so that
    # ``with_value`` re-validates a changed copy with the same rules and derived values. None for
    # a Scene built by hand.
    source: Mapping[str, Any] | None = field(default=None, compare=False, repr=False)

    __reduce__ = _reduce_frozen

    # -- lookups (built lazily; the dataclass fields stay the single source of truth) ---------

    @cached_property
    def _index(self) -> dict[str, Any]:
        kinds: dict[str, str] = {BASE: "base"}
        parents: dict[str, str | None] = {BASE: None}
        points: dict[str, Mapping[str, tuple[float, float]]] = {BASE: self.base_points}
        flex = {f.name: f for f in self.flexures}
        links = {lk.name: lk for lk in self.links}
        for f in self.flexures:
            kinds[f.name] = "flexure"
            parents[f.name] = f.parent
            points[f.name] = MappingProxyType({TIP: (0.0, 0.0)})
        for lk in self.links:
            kinds[lk.name] = "link"
            parents[lk.name] = lk.parent
            points[lk.name] = lk.points
        order = self.declaration_order or tuple(flex) + tuple(links)
        children: dict[str, list[str]] = {name: [] for name in kinds}
        for name in order:
            parent = parents.get(name)
            if parent in children:
                children[parent].append(name)
        return {
            "kinds": kinds,
            "parents": parents,
            "points": points,
            "flex": flex,
            "links": links,
            "order": order,
            "children": {k: tuple(v) for k, v in children.items()},
        }

    def with_value(self, path: str, value: Any) -> Scene:
        """A new validated Scene with the value at the dotted ``path`` (``"flexure.proximal.
        thickness"``, ``"flexure.0.length"``, ``"load.0.force.1"``, ``"tendon.0.tension"``,
        ``"model.modes"``; flexgen/scenepath.py) replaced: the scene's source re-validated by
        ``scene_from_dict``, so derived values and every check are the scene's own. A one-line
        SceneError naming the path otherwise."""
        return self.with_values({path: value})

    def with_values(self, values: Mapping[str, Any]) -> Scene:
        """``with_value`` for several paths at once (one validation)."""
        from .scenepath import PathError, set_value

        if not isinstance(values, Mapping):  # review: None was an AttributeError
            raise TypeError(
                f"with_values: expected a mapping of scene paths to values, got "
                f"{type(values).__name__}"
            )
        root = self.editable_source()
        try:
            for path, value in values.items():
                set_value(root, path, value, TABLE_KEYS)
        except PathError as exc:
            raise SceneError(str(exc)) from None
        as_given = root
        if self.units is not None and self.source is not None:
            from .scenepath import thaw
            from .units import keep_unit_strings

            as_given = copy.deepcopy(root)  # for the messages: the values as the caller gave
            keep_unit_strings(thaw(self.source), root)
        order = self._kinds_in_order()
        try:
            return scene_from_dict(root, order=order, default_name=self.name)
        except SceneError as exc:
            error = exc
        if as_given is not root:
            try:  # the same failure told with the caller's values ('-5.0', not '-5.0 Pa': review)
                scene_from_dict(as_given, order=order, default_name=self.name)
            except SceneError as exc:
                error = exc
        # the validator's message names its key; the paths are prefixed only when it names
        # another (review: "model.modes: model.modes: must be an integer ...")
        text = str(error)
        if any(text.startswith(f"{path}:") for path in values):
            raise SceneError(text) from None
        raise SceneError(f"{', '.join(values)}: {text}") from None

    def editable_source(self) -> dict[str, Any]:
        """A mutable copy of the mapping this scene was read from; SceneError when it has none or
        it no longer describes the scene (changed with dataclasses.replace after it was read)."""
        from .scenepath import thaw

        if self.source is None:
            raise SceneError(
                "scene: this Scene was built without its source (a study or with_value changes "
                "its source); read it with "
                "flexgen.load_scene or flexgen.scene_from_dict"
            )
        if "_source_matches" not in self.__dict__:  # once per Scene object (it is immutable)
            again = scene_from_dict(
                thaw(self.source), order=self._kinds_in_order(), default_name=self.name
            )
            object.__setattr__(self, "_source_matches", again == self)
        if not self.__dict__["_source_matches"]:
            raise SceneError(
                "scene: this Scene was changed after it was read (dataclasses.replace or a "
                "model override), so its source no longer describes it; change the source instead"
            )
        return thaw(self.source)

    def _kinds_in_order(self) -> list[str]:
        """scene_from_dict's ``order=`` ("flexure"/"link" in file order) of this scene."""
        kinds = {f.name: "flexure" for f in self.flexures} | {lk.name: "link" for lk in self.links}
        return [kinds[n] for n in self.declaration_order or tuple(kinds)]

    def _known(self, name: str) -> None:
        if name not in self._index["kinds"]:
            known = _names(self.bodies())
            raise SceneError(f"unknown body {name!r} (known: {known})")

    def bodies(self) -> tuple[str, ...]:
        """Every body name: "base", then flexures and links in declaration order."""
        return (BASE,) + tuple(self._index["order"])

    def unit_of(self, quantity: str) -> str:
        """The unit of ``quantity`` (``Units.label``'s names) in the scene's units system, which
        every answer is in, or "" for a scene of plain numbers (any consistent set, unnamed:
        docs/scene.md, Units)."""
        return "" if self.units is None else self.units.label(quantity)

    def body_kind(self, name: str) -> str:
        """ "base", "flexure" or "link"."""
        self._known(name)
        return self._index["kinds"][name]

    def body_parent(self, name: str) -> str | None:
        """The parent body of a flexure or link; None for "base"."""
        self._known(name)
        return self._index["parents"][name]

    def body_points(self, name: str) -> Mapping[str, tuple[float, float]]:
        """Named points of a body, in its frame (a flexure has only "tip" = (0, 0))."""
        self._known(name)
        return self._index["points"][name]

    def children(self, body_name: str) -> tuple[str, ...]:
        """Flexures and links whose parent is ``body_name``, in declaration order."""
        self._known(body_name)
        return self._index["children"][body_name]

    def flexure(self, name: str) -> Flexure:
        try:
            return self._index["flex"][name]
        except KeyError:
            raise SceneError(
                f"unknown flexure {name!r} (known: {_names(self._index['flex']) or 'none'})"
            ) from None

    def link(self, name: str) -> Link:
        try:
            return self._index["links"][name]
        except KeyError:
            raise SceneError(
                f"unknown link {name!r} (known: {_names(self._index['links']) or 'none'})"
            ) from None

    def flexure_order(self) -> tuple[Flexure, ...]:
        """All flexures, parents before children (depth-first from the base, siblings in
        declaration order)."""
        out: list[Flexure] = []
        stack = [BASE]
        seen = set()
        while stack:
            body = stack.pop()
            if body in seen:
                continue
            seen.add(body)
            if self._index["kinds"][body] == "flexure":
                out.append(self._index["flex"][body])
            stack.extend(reversed(self._index["children"][body]))
        if len(out) != len(self.flexures):
            lost = [f.name for f in self.flexures if f.name not in seen]
            raise SceneError(f"flexures not connected to the base: {_names(lost)}")
        return tuple(out)

    def load_levels(self) -> dict[str, float]:
        """How far each flexure's loads are from small deflection (nondimensional): L^2/EI x
        (the forces + twice the tendon tensions) + L/EI x the moments, every load of the scene
        counted on every flexure (an upper bound of what the flexure carries)."""
        return load_levels(
            self.flexures,
            [(*ld.force, ld.moment) for ld in self.loads],
            [t.tension for t in self.tendons],
        )

    def flexure_path(self, body: str) -> tuple[str, ...]:
        """Names of the flexures between the base and ``body``, root first; ``body`` itself is
        the last entry when it is a flexure. Empty for "base"."""
        self._known(body)
        path: list[str] = []
        seen = set()
        name: str | None = body
        while name is not None and name != BASE:
            if name in seen:
                raise SceneError(f"cycle in parents at body {name!r}")
            seen.add(name)
            if self._index["kinds"].get(name) == "flexure":
                path.append(name)
            name = self._index["parents"].get(name)
        return tuple(reversed(path))

    def output_points(self) -> tuple[str, ...]:
        """The points an answer reports: ``outputs`` (the [output] points, else every loaded
        point in load order); with neither, the tip of every flexure that carries no other
        flexure (directly or through a link), in declaration order."""
        if self.outputs:
            return self.outputs
        loaded = tuple(dict.fromkeys(ld.point for ld in self.loads))
        if loaded:
            return loaded
        carriers = {path[-1] for f in self.flexures if (path := self.flexure_path(f.parent))}
        return tuple(f"{f.name}.tip" for f in self.flexures if f.name not in carriers)

    def resolve_point(self, ref: str) -> tuple[str, tuple[float, float]]:
        """``"<body>.<point>"`` -> (body name, (x, y) in that body's frame)."""
        if not isinstance(ref, str) or ref.count(".") != 1:
            raise SceneError(f"point reference must be '<body>.<point>', got {_fmt(ref)}")
        body, point = ref.split(".")
        self._known(body)
        pts = self._index["points"][body]
        if point not in pts:
            known = _names(f"{body}.{p}" for p in pts) or "none"
            raise SceneError(f"unknown point {ref!r} (known: {known})")
        x, y = pts[point]
        return body, (float(x), float(y))


# -- loading ---------------------------------------------------------------------------------


def _declaration_order(text: str, d: Mapping[str, Any]) -> tuple[str, ...] | None:
    """The file order of the flexure and link tables: their [[flexure]]/[[link]] headers, and
    the items of an inline array (``flexure = [{...}, ...]``) at the place of its key (read by a
    scanner of the TOML grammar: flexgen/tomlorder.py); None if that does not match what tomllib
    read: then only default parents that need no order are inferred."""
    kinds: list[str] = []
    for key, inline in array_order(text):
        if key not in (("flexure",), ("link",)):
            continue
        items = d.get(key[0])
        kinds += [key[0]] * (len(items) if inline and isinstance(items, list) else 1)
    for kind in ("flexure", "link"):
        items = d.get(kind, [])
        if not isinstance(items, list) or kinds.count(kind) != len(items):
            return None
    return tuple(kinds)


def _read_regular_file(path: Path) -> bytes:
    """The bytes of a regular file of at most MAX_FILE_BYTES; anything else (a folder, a FIFO, a
    device, a larger file) is a SceneError before anything is read (a FIFO is opened without
    blocking)."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as e:
        raise SceneError(f"{path}: cannot read scene file: {e.strerror or e}") from None
    except ValueError as e:  # a NUL byte in the path
        raise SceneError(f"scene: cannot read scene file {_fmt(str(path))}: {e}") from None
    try:
        info = os.fstat(fd)
        if stat.S_ISDIR(info.st_mode):
            raise SceneError(f"{path}: cannot read scene file: it is a folder")
        if not stat.S_ISREG(info.st_mode):
            raise SceneError(f"{path}: cannot read scene file: not a regular file")
        if info.st_size > MAX_FILE_BYTES:
            raise SceneError(
                f"{path}: scene file too large ({info.st_size} bytes; at most {MAX_FILE_BYTES})"
            )
        with os.fdopen(fd, "rb", closefd=False) as handle:
            raw = handle.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        raise SceneError(f"{path}: cannot read scene file: {e.strerror or e}") from None
    finally:
        os.close(fd)
    if len(raw) > MAX_FILE_BYTES:
        raise SceneError(f"{path}: scene file too large (at most {MAX_FILE_BYTES} bytes)")
    return raw


def scene_name_of(path: str) -> str:
    """The name a scene file's answer carries, as far as the file says it, for the answer to a
    scene that could not be solved or read (``"converged": false``): its ``name`` when the file
    reads as TOML with a string ``name``, else the file's stem (as ``load_scene`` defaults it).
    Never raises (found by review: the JSON of a bad scene named it by its file name)."""
    try:
        text = _read_regular_file(Path(path)).decode("utf-8")
        _check_toml_text(text, Path(path))
        d = tomllib.loads(text)
        name = d.get("name")
        if isinstance(name, str) and name.strip():
            return name
    except (SceneError, ValueError, RecursionError, OSError, TypeError):
        pass
    try:
        return Path(path).stem or str(path)
    except TypeError:
        return str(path)


# The most parts of one dotted run (a dotted key or table header, "a.b.c") in a scene file: one
# of k parts costs tomllib time and memory growing as k^2 (review: a 40 KB file of one
# 20,000-part key took 12 s and 1.6 GB, 40,000 parts 54 s and 6.3 GB); a scene's keys have at
# most 4. Numbers ("0.5") are runs of two; dots elsewhere in a line (a row of 300 link points)
# do not count (review of the first version, which counted every dot of a line).
MAX_DOTTED_PARTS = 512
_DOTTED_RUN = re.compile(r"[^\s.,=\[\]{}#]+(?:[ \t]*\.[ \t]*[^\s.,=\[\]{}#]+)+")


def _check_toml_text(text: str, path: Path) -> None:
    """SceneError for text tomllib would take more than linear time over (MAX_DOTTED_PARTS)."""
    if text.count(".") < MAX_DOTTED_PARTS:
        return  # the usual file: no run can be that long
    for number, line in enumerate(text.splitlines(), 1):
        if line.count(".") < MAX_DOTTED_PARTS:
            continue
        for run in _DOTTED_RUN.finditer(line):
            if run.group().count(".") >= MAX_DOTTED_PARTS:
                raise SceneError(
                    f"{path}: line {number} holds a dotted key or table header of more than "
                    f"{MAX_DOTTED_PARTS} parts, refused (parsing it grows with its square; "
                    "scene keys have at most 4 parts)"
                )


def load_scene(path: str | os.PathLike[str]) -> Scene:
    """Read and validate a TOML scene file. Any problem raises a one-line ``SceneError``."""
    try:
        path = Path(path)
    except TypeError:
        raise SceneError(f"scene: expected a path, got {type(path).__name__}") from None
    raw = _read_regular_file(path)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise SceneError(f"{path}: not UTF-8 text: {e}") from None
    _check_toml_text(text, path)
    try:
        d = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        msg = " ".join(str(e).split())
        raise SceneError(f"{path}: invalid TOML: {msg}") from None
    except RecursionError:
        raise SceneError(f"{path}: invalid TOML: arrays or tables nested too deeply") from None
    except ValueError as e:  # an integer of more digits than Python converts (4300)
        msg = " ".join(str(e).split())
        if "integer string conversion" in msg:
            msg = "an integer of more than 4300 digits"
        raise SceneError(f"{path}: invalid TOML: {msg}") from None
    return scene_from_dict(d, order=_declaration_order(text, d), default_name=path.stem)


def scene_from_dict(
    d: Mapping[str, Any], *, order: Sequence[str] | None = None, default_name: str = "scene"
) -> Scene:
    """Validate a scene given as a dict (the structure ``tomllib`` returns).

    ``order`` is the file order of the flexure and link tables as a sequence of "flexure" and
    "link" (``load_scene`` passes it). A dict keeps flexures and links in separate lists, so
    without ``order`` a default parent is only inferred where it does not depend on how they
    interleave (the first flexure's, and every flexure's when there are no links).

    Values may carry units (``"20 mm"``): they are converted first, into the scene's ``units``
    choice (SI by default), by ``flexgen.units.normalise``; docs/scene.md, "Units".
    """
    if order is not None and (
        isinstance(order, str | bytes)
        or not isinstance(order, Sequence)
        or any(k not in ("flexure", "link") for k in order)
    ):  # review: order=5 was "'int' object is not iterable"
        raise TypeError(
            f"scene_from_dict: order must be a sequence of 'flexure' and 'link', got {order!r:.80}"
        )
    try:
        plain, units = normalise(d, MAX_MAGNITUDE, wrap=_Written)
    except UnitsError as e:
        raise SceneError(str(e)) from None
    from .scenepath import freeze

    scene = _Parser(plain, order, default_name).scene
    # the source as given (units and all): with_value re-reads it through this function
    return replace(scene, units=units, source=freeze(d))


# -- validation helpers ----------------------------------------------------------------------


class _Written(float):
    """A number converted from a unit string (``"-20 mm"``), only while a scene is validated:
    a message shows it as written and as converted (``'-20 mm' (-0.02 m)``). Every value the
    Scene keeps goes through ``float()``, so none of these outlives the validation."""

    text: str
    unit: str

    def __new__(cls, value: float, text: str, unit: str) -> _Written:
        obj = super().__new__(cls, value)
        obj.text, obj.unit = text, unit
        return obj

    def __repr__(self) -> str:
        text = repr(self.text)
        text = text if len(text) <= 40 else text[:37] + "..."
        return f"{text} ({float(self):.15g} {self.unit})"


_MISSING = object()
_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxstring, _REPR.maxother, _REPR.maxlong = 3, 60, 60, 40


def _fmt(v: Any) -> str:
    """A short one-line repr of any value (bounded in length and depth, whatever ``v`` is)."""
    if isinstance(v, int) and not isinstance(v, bool) and v.bit_length() > 128:
        digits = int(v.bit_length() * math.log10(2)) + 1
        s = f"{'-' if v < 0 else ''}an integer of about {digits} digits"
    else:
        try:
            s = _REPR.repr(v)
        except Exception:  # a repr that fails (an object's own __repr__)
            s = f"<{type(v).__name__}>"
    return _cut(" ".join(s.split()) if "\n" in s else s)


def _cut(text: str) -> str:
    """``text`` as a message shows it: at most 80 characters (docs/scene.md, Errors)."""
    return text if len(text) <= 80 else text[:77] + "..."


def _names(names: Any, limit: int = 12) -> str:
    """A comma-separated list of at most ``limit`` names (then how many more)."""
    names = list(names)
    shown = ", ".join(_cut(repr(n)[1:-1] if isinstance(n, str) else str(n)) for n in names[:limit])
    return shown + (f", ... ({len(names) - limit} more)" if len(names) > limit else "")


def _key(k: Any) -> str:
    """A key as it appears in a message: itself if printable and short, else its repr."""
    text = k if isinstance(k, str) else _fmt(k)
    return text if text.isprintable() and len(text) <= 80 else _fmt(text)


def _fail(key: str, msg: str, value: Any = _MISSING) -> SceneError:
    text = f"{key}: {msg}" if value is _MISSING else f"{key}: {msg}, got {_fmt(value)}"
    return SceneError(" ".join(text.split()))


def _is_number(v: Any) -> bool:
    # any real number, a NumPy scalar of a dict built by a script too (review: np.int64 was
    # "must be a finite number"); a bool is no number
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def _number(v: Any, key: str, sign: str = "") -> float:
    """sign: "" any finite, "+" positive, "0+" non-negative; the magnitude at most
    MAX_MAGNITUDE, and at least MIN_POSITIVE for "+"."""
    desc = {
        "": f"a finite number of magnitude <= {MAX_MAGNITUDE:g}",
        "+": f"a positive number in [{MIN_POSITIVE:g}, {MAX_MAGNITUDE:g}]",
        "0+": f"zero or a positive number <= {MAX_MAGNITUDE:g}",
    }[sign]
    if not _is_number(v):
        raise _fail(key, f"must be {desc}", v)
    try:
        x = float(v)
    except OverflowError:  # an int too large for a float
        raise _fail(key, f"must be {desc}", v) from None
    if not (math.isfinite(x) and abs(x) <= MAX_MAGNITUDE):
        raise _fail(key, f"must be {desc}", v)
    if (sign == "+" and x < MIN_POSITIVE) or (sign == "0+" and x < 0):
        raise _fail(key, f"must be {desc}", v)
    return x


def _integer(v: Any, key: str, minimum: int, maximum: int) -> int:
    if (
        not isinstance(v, numbers.Integral)
        or isinstance(v, bool)
        or not minimum <= int(v) <= maximum
    ):
        raise _fail(key, f"must be an integer in [{minimum}, {maximum}]", v)
    return int(v)


def _tolerance(v: Any, key: str) -> float:
    """A relative tolerance: a number in (0, 1), as ``flexgen solve --tol``."""
    if not _is_number(v) or not (0 < _clamped(v) < 1):
        raise _fail(key, "must be a number in (0, 1) (a relative error)", v)
    return float(v)


def _clamped(v: int | float) -> float:
    try:
        return float(v)
    except OverflowError:
        return math.inf if v > 0 else -math.inf


def _string(v: Any, key: str) -> str:
    if not isinstance(v, str):
        raise _fail(key, "must be a string", v)
    return v


def _table(v: Any, key: str) -> Mapping[str, Any]:
    if not isinstance(v, Mapping):
        raise _fail(key, "must be a table", v)
    return v


def _vector(v: Any, key: str, n: int) -> tuple[float, ...]:
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise _fail(key, f"must be a list of {n} numbers", v)
    return tuple(_number(x, f"{key}[{i}]") for i, x in enumerate(v))


def _vector2(v: Any, key: str) -> tuple[float, float]:
    x, y = _vector(v, key, 2)  # _vector checked the length
    return (x, y)


def _vector3(v: Any, key: str) -> tuple[float, float, float]:
    x, y, z = _vector(v, key, 3)  # _vector checked the length
    return (x, y, z)


def _identifier(v: Any, key: str, what: str) -> str:
    v = _string(v, key)
    if not v or "." in v or v != v.strip():
        raise _fail(key, f"{what} must be non-empty, without '.' or surrounding spaces", v)
    return v


def _check_keys(tbl: Mapping[str, Any], prefix: str, allowed: Sequence[str]) -> None:
    for k in tbl:
        if k not in allowed:
            key = f"{prefix}.{_key(k)}" if prefix else _key(k)
            close = difflib.get_close_matches(str(k), allowed, n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            where = "top-level key" if not prefix else "key"
            raise _fail(key, f"unknown {where} ({hint}allowed: {', '.join(allowed)})")


def _array_of_tables(d: Mapping[str, Any], key: str) -> list[Mapping[str, Any]]:
    v = d.get(key, [])
    if not isinstance(v, list):
        raise _fail(key, f"must be an array of tables ([[{key}]])", v)
    for i, item in enumerate(v):
        _table(item, f"{key}[{i}]")
    return v


def _points(v: Any, key: str) -> Mapping[str, tuple[float, float]]:
    tbl = _table(v, key)
    out: dict[str, tuple[float, float]] = {}
    for name, xy in tbl.items():
        _identifier(name, f"{key}", "a point name")
        out[name] = _vector2(xy, f"{key}.{_key(name)}")
    return MappingProxyType(out)


def _model_fields(tbl: Mapping[str, Any], prefix: str) -> dict[str, Any]:
    """Validated ModelSpec fields among MODEL_KEYS present in ``tbl``."""
    out: dict[str, Any] = {}
    if "kind" in tbl:
        v = tbl["kind"]
        if v not in MODEL_KINDS or not isinstance(v, str):
            raise _fail(f"{prefix}kind", f"must be one of {', '.join(MODEL_KINDS)}", v)
        out["kind"] = v
    if "modes" in tbl:
        out["modes"] = _integer(tbl["modes"], f"{prefix}modes", 1, MAX_MODES)
    if "elements" in tbl:
        out["elements"] = _integer(tbl["elements"], f"{prefix}elements", 1, MAX_ELEMENTS)
    if "kernel" in tbl:
        v = tbl["kernel"]
        if v not in KERNELS or not isinstance(v, str):
            raise _fail(f"{prefix}kernel", f"must be one of {', '.join(KERNELS)}", v)
        out["kernel"] = v
    if "tolerance" in tbl:
        out["tolerance"] = _tolerance(tbl["tolerance"], f"{prefix}tolerance")
    return out


def _strengths(tbl: Mapping[str, Any], prefix: str) -> dict[str, float]:
    """Validated strengths among STRENGTH_KEYS present in ``tbl`` (positive numbers)."""
    return {k: _number(tbl[k], f"{prefix}{k}", "+") for k in STRENGTH_KEYS if k in tbl}


class _Parser:
    def __init__(self, d: Any, order: Sequence[str] | None, default_name: str):
        if not isinstance(d, Mapping):
            raise _fail("scene", "must be a table", d)
        _check_keys(d, "", TOP_KEYS)
        name = _string(d.get("name", default_name), "name")

        model_tbl = _table(d.get("model", {}), "model")
        _check_keys(model_tbl, "model", MODEL_KEYS + STRENGTH_KEYS)
        self.model = ModelSpec(**_model_fields(model_tbl, "model."))
        self.strengths = _strengths(model_tbl, "model.")
        self.kind_key = "model.kind" if "kind" in model_tbl else None
        # (path, value) of every modes and tolerance given: a tolerance chooses the modes
        self.modes_given: list[tuple[str, Any]] = []
        self.tolerances: list[tuple[str, Any]] = []
        for key, seen in (("modes", self.modes_given), ("tolerance", self.tolerances)):
            if key in model_tbl:
                seen.append((f"model.{key}", model_tbl[key]))

        base_tbl = _table(d.get("base", {}), "base")
        _check_keys(base_tbl, "base", BASE_KEYS)
        base_points = _points(base_tbl.get("points", {}), "base.points")

        flex_tbls = _array_of_tables(d, "flexure")
        link_tbls = _array_of_tables(d, "link")
        load_tbls = _array_of_tables(d, "load")
        tendon_tbls = _array_of_tables(d, "tendon")
        if not flex_tbls:
            raise _fail("flexure", "the scene has no [[flexure]]; at least one is required")
        if len(flex_tbls) + len(link_tbls) > MAX_BODIES:
            raise _fail(
                "flexure",
                f"too many bodies: {len(flex_tbls)} flexures and {len(link_tbls)} links "
                f"(at most {MAX_BODIES} together; docs/scene.md, Limits)",
            )
        if len(load_tbls) > MAX_ENTRIES:
            raise _fail("load", f"too many loads: {len(load_tbls)} (at most {MAX_ENTRIES})")
        if len(tendon_tbls) > MAX_ENTRIES:
            raise _fail("tendon", f"too many tendons: {len(tendon_tbls)} (at most {MAX_ENTRIES})")
        self.n_points = len(base_points)
        self.n_route = 0
        self.order = self._check_order(order, len(flex_tbls), len(link_tbls))

        # names first, so that parents may refer to bodies declared later
        self.owner: dict[str, str] = {BASE: "the ground"}
        flex_names = [self._name(t, f"flexure[{i}]") for i, t in enumerate(flex_tbls)]
        link_names = [self._name(t, f"link[{i}]") for i, t in enumerate(link_tbls)]
        self.kinds = {
            BASE: "base",
            **{n: "flexure" for n in flex_names},
            **{n: "link" for n in link_names},
        }

        declared: list[tuple[str, int]] = []  # (kind, index) in file order, if known
        # (kind, index) -> (the body declared just before it, the flexure declared last before it)
        self.previous: dict[tuple[str, int], tuple[str | None, str | None]] = {}
        if self.order is not None:
            counters = {"flexure": 0, "link": 0}
            names = {"flexure": flex_names, "link": link_names}
            last_body: str | None = None
            last_flexure: str | None = None
            for kind in self.order:
                i = counters[kind]
                declared.append((kind, i))
                self.previous[(kind, i)] = (last_body, last_flexure)
                last_body = names[kind][i]
                if kind == "flexure":
                    last_flexure = last_body
                counters[kind] += 1

        flexures = tuple(self._flexure(t, i, flex_names) for i, t in enumerate(flex_tbls))
        self._check_tolerance()
        links = tuple(self._link(t, i, flex_names, link_names) for i, t in enumerate(link_tbls))
        parents = {f.name: f.parent for f in flexures} | {lk.name: lk.parent for lk in links}
        keys = {f.name: f"flexure[{i}]" for i, f in enumerate(flexures)}
        keys |= {lk.name: f"link[{i}]" for i, lk in enumerate(links)}
        self._check_cycles(parents, keys)

        self.points: dict[str, Mapping[str, tuple[float, float]]] = {BASE: base_points}
        self.points |= {f.name: {TIP: (0.0, 0.0)} for f in flexures}
        self.points |= {lk.name: lk.points for lk in links}
        n_points = sum(len(pts) for pts in self.points.values()) - len(flexures)
        if n_points > MAX_ENTRIES:
            # the key holding the most named points (review: 1001 base points blamed 'link')
            flexure_names = {f.name for f in flexures}
            most = max(self.points.items(), key=lambda kv: len(kv[1]) - (kv[0] in flexure_names))
            where = "base.points" if most[0] == BASE else f"{keys.get(most[0], most[0])}.points"
            raise _fail(where, f"too many named points: {n_points} in all (at most {MAX_ENTRIES})")

        loads = tuple(self._load(t, f"load[{i}]") for i, t in enumerate(load_tbls))
        tendons = tuple(self._tendon(t, f"tendon[{i}]") for i, t in enumerate(tendon_tbls))
        outputs = self._outputs(d.get("output", {}), loads)

        if self.order is not None:
            decl = tuple((flex_names if k == "flexure" else link_names)[i] for k, i in declared)
        else:
            decl = tuple(flex_names) + tuple(link_names)
        self.scene = Scene(
            name=name,
            model=self.model,
            base_points=base_points,
            flexures=flexures,
            links=links,
            loads=loads,
            tendons=tendons,
            outputs=outputs,
            declaration_order=decl,
        )
        check_limits(self.scene)

    # -- pieces --

    @staticmethod
    def _check_order(order, n_flex: int, n_link: int) -> tuple[str, ...] | None:
        if order is None:
            return (("flexure",) * n_flex) if n_link == 0 else None
        order = tuple(order)
        if (
            any(k not in ("flexure", "link") for k in order)
            or order.count("flexure") != n_flex
            or order.count("link") != n_link
        ):
            raise SceneError(
                f"order: must list 'flexure' {n_flex} times and 'link' {n_link} "
                f"times, got {_fmt(list(order))}"
            )
        return order

    def _name(self, tbl: Mapping[str, Any], prefix: str) -> str:
        if "name" not in tbl:
            raise _fail(f"{prefix}.name", "missing required key")
        name = _identifier(tbl["name"], f"{prefix}.name", "a name")
        if name in self.owner:
            raise _fail(
                f"{prefix}.name", f"duplicate name {name!r} (already used by {self.owner[name]})"
            )
        self.owner[name] = prefix
        return name

    def _previous(self, kind: str, index: int, want_flexure: bool) -> str | None:
        """The body (or flexure) declared just before item (kind, index) in file order."""
        body, flexure = self.previous[(kind, index)]
        return flexure if want_flexure else body

    def _flexure(self, tbl: Mapping[str, Any], i: int, flex_names: list[str]) -> Flexure:
        prefix = f"flexure[{i}]"
        if "points" in tbl:
            raise _fail(
                f"{prefix}.points",
                "a flexure has only the point 'tip'; put named points on a [[link]] attached to it",
                tbl["points"],
            )
        _check_keys(tbl, prefix, FLEXURE_KEYS)
        name = flex_names[i]

        if "parent" in tbl:
            parent = _string(tbl["parent"], f"{prefix}.parent")
            if parent not in self.kinds:
                raise _fail(
                    f"{prefix}.parent", f"unknown body {parent!r} (known: {_names(self.kinds)})"
                )
        elif i == 0:
            parent = BASE
        elif self.order is None:
            raise _fail(
                f"{prefix}.parent",
                "missing, and the declaration order of flexures "
                "and links is unknown (set parent, or pass order= to scene_from_dict)",
            )
        else:
            parent = self._previous("flexure", i, want_flexure=False) or BASE

        at = _vector3(tbl["at"], f"{prefix}.at") if "at" in tbl else (0.0, 0.0, 0.0)
        if "length" not in tbl:
            raise _fail(f"{prefix}.length", "missing required key")
        length = _number(tbl["length"], f"{prefix}.length", "+")
        EI, section = self._stiffness(tbl, prefix)

        fields = _model_fields(tbl, f"{prefix}.")
        strengths = self.strengths | _strengths(tbl, f"{prefix}.")
        # where each model key of this flexure is given: key -> (path, value as written)
        given = {k: (f"{prefix}.{k}", tbl[k]) for k in MODEL_KEYS if k in tbl}
        if "model" in tbl:
            sub = _table(tbl["model"], f"{prefix}.model")
            _check_keys(sub, f"{prefix}.model", MODEL_KEYS + STRENGTH_KEYS)
            for k in sub:
                if k in tbl:
                    raise _fail(
                        f"{prefix}.model.{k}", f"also given as {prefix}.{k}; give it once", sub[k]
                    )
            fields |= _model_fields(sub, f"{prefix}.model.")
            strengths |= _strengths(sub, f"{prefix}.model.")
            given |= {k: (f"{prefix}.model.{k}", sub[k]) for k in MODEL_KEYS if k in sub}
        model = replace(self.model, **fields)
        self._check_counts(model, given)
        for key, seen in (("modes", self.modes_given), ("tolerance", self.tolerances)):
            if key in given:
                seen.append(given[key])
        return Flexure(
            name=name,
            parent=parent,
            at=at,
            length=length,
            EI=EI,
            model=model,
            **section,
            **strengths,
        )

    def _check_counts(self, model: ModelSpec, given: Mapping[str, tuple[str, Any]]) -> None:
        """A count given on a flexure that its kind does not read is an error, as ``--model cc
        --modes 3`` is (it would be dropped silently: cc is scm with one mode). A count in
        [model] is only the default of the flexures whose kind reads it."""
        for count, reader in (("modes", "scm"), ("elements", "fem")):
            if count in given and model.kind != reader:
                path, value = given[count]
                source = given["kind"][0] if "kind" in given else (self.kind_key or "the default")
                why = (
                    "cc is scm with one mode"
                    if count == "modes" and model.kind == "cc"
                    else f"only {reader} has {count}"
                )
                raise _fail(
                    path, f"not used by this flexure's kind {model.kind!r} ({source}; {why})", value
                )

    def _check_tolerance(self) -> None:
        """A tolerance chooses every flexure's modes (docs/selection.md): a ``modes`` given
        anywhere beside one would be dropped silently, so the two are an error together."""
        if self.tolerances and self.modes_given:
            path, value = self.modes_given[0]
            raise _fail(
                path,
                f"a tolerance ({self.tolerances[0][0]}) chooses every flexure's modes; give "
                "modes or a tolerance, not both",
                value,
            )

    @staticmethod
    def _stiffness(tbl: Mapping[str, Any], prefix: str) -> tuple[float, dict[str, float]]:
        """EI and the section values as given (the Flexure fields E, I, width, thickness)."""
        given = {k: _number(tbl[k], f"{prefix}.{k}", "+") for k in STIFFNESS_KEYS if k in tbl}
        section = {k: v for k, v in given.items() if k != "EI"}
        how = "give EI, or E and I, or E, width and thickness"
        if "EI" in given:
            # thickness may come with EI: it only places the outer fibre (strain, not stress)
            for k in ("E", "I", "width"):
                if k in given:
                    raise _fail(f"{prefix}.{k}", f"conflicts with EI ({how})", tbl[k])
            return given["EI"], section
        if "E" not in given:
            raise _fail(f"{prefix}.EI", f"missing required key ({how})")
        if "I" in given:
            # thickness may come with I: it only places the outer fibre, EI stays E I
            if "width" in given:
                raise _fail(f"{prefix}.width", f"conflicts with I ({how})", tbl["width"])
            EI = given["E"] * given["I"]
        else:
            for k in ("width", "thickness"):
                if k not in given:
                    missing = "I" if not ({"width", "thickness"} & given.keys()) else k
                    raise _fail(f"{prefix}.{missing}", f"missing required key ({how})")
            EI = given["E"] * given["width"] * given["thickness"] ** 3 / 12.0
        if not (math.isfinite(EI) and MIN_POSITIVE <= EI <= MAX_MAGNITUDE):
            raise _fail(
                f"{prefix}.EI",
                f"computed bending stiffness must be in [{MIN_POSITIVE:g}, {MAX_MAGNITUDE:g}]",
                EI,
            )
        return EI, section

    def _link(
        self, tbl: Mapping[str, Any], i: int, flex_names: list[str], link_names: list[str]
    ) -> Link:
        prefix = f"link[{i}]"
        _check_keys(tbl, prefix, LINK_KEYS)
        if "parent" in tbl:
            parent = _string(tbl["parent"], f"{prefix}.parent")
            kind = self.kinds.get(parent)
            if kind is None:
                raise _fail(
                    f"{prefix}.parent",
                    f"unknown body {parent!r} (known flexures: {_names(flex_names)})",
                )
            if kind != "flexure":
                raise _fail(
                    f"{prefix}.parent",
                    f"must be a flexure, but {parent!r} is "
                    f"{'the base' if kind == 'base' else 'a link'} (known flexures: "
                    f"{_names(flex_names)})",
                )
        elif self.order is None:
            raise _fail(
                f"{prefix}.parent",
                "missing, and the declaration order of flexures "
                "and links is unknown (set parent, or pass order= to scene_from_dict)",
            )
        else:
            previous = self._previous("link", i, want_flexure=True)
            if previous is None:
                raise _fail(
                    f"{prefix}.parent", "missing, and no flexure is declared before this link"
                )
            parent = previous
        points = _points(tbl.get("points", {}), f"{prefix}.points")
        return Link(name=link_names[i], parent=parent, points=points)

    @staticmethod
    def _check_cycles(parents: dict[str, str], keys: dict[str, str]) -> None:
        done = {BASE}
        for start in parents:
            path: list[str] = []
            on_path: set[str] = set()
            node = start
            while node not in done:
                if node in on_path:
                    cycle = path[path.index(node) :] + [node]
                    if len(cycle) > 12:
                        cycle = cycle[:6] + ["..."] + cycle[-6:]
                    raise _fail(
                        f"{keys[node]}.parent",
                        f"parents form a cycle ({' -> '.join(cycle)})",
                        parents[node],
                    )
                path.append(node)
                on_path.add(node)
                node = parents[node]
            done.update(path)

    def _ref(self, v: Any, key: str) -> str:
        v = _string(v, key)
        if v.count(".") != 1:
            raise _fail(key, "must be a point reference '<body>.<point>'", v)
        body, point = v.split(".")
        if body not in self.points:
            raise _fail(
                key,
                f"unknown body {body!r} in point {v!r} (known bodies: {_names(self.points)})",
            )
        if point not in self.points[body]:
            known = _names(f"{body}.{p}" for p in self.points[body]) or "none"
            raise _fail(key, f"unknown point {v!r} (known: {known})")
        return v

    def _load(self, tbl: Mapping[str, Any], prefix: str) -> Load:
        _check_keys(tbl, prefix, LOAD_KEYS)
        for k in ("point", "force"):
            if k not in tbl:
                raise _fail(f"{prefix}.{k}", "missing required key")
        point = self._ref(tbl["point"], f"{prefix}.point")
        force = _vector2(tbl["force"], f"{prefix}.force")
        moment = _number(tbl.get("moment", 0.0), f"{prefix}.moment")
        return Load(point=point, force=force, moment=moment)

    def _tendon(self, tbl: Mapping[str, Any], prefix: str) -> Tendon:
        _check_keys(tbl, prefix, TENDON_KEYS)
        for k in ("tension", "route"):
            if k not in tbl:
                raise _fail(f"{prefix}.{k}", "missing required key")
        tension = _number(tbl["tension"], f"{prefix}.tension", "0+")
        route = tbl["route"]
        if not isinstance(route, list):
            raise _fail(f"{prefix}.route", "must be a list of point references", route)
        if len(route) < 2:
            raise _fail(f"{prefix}.route", "needs at least two points", route)
        self.n_route += len(route)
        if self.n_route > MAX_ENTRIES:
            raise _fail(
                f"{prefix}.route",
                f"too many route points: {self.n_route} in all tendons so far "
                f"(at most {MAX_ENTRIES})",
            )
        refs = tuple(self._ref(r, f"{prefix}.route[{j}]") for j, r in enumerate(route))
        for j in range(1, len(refs)):
            if refs[j] == refs[j - 1]:
                raise _fail(
                    f"{prefix}.route[{j}]",
                    "repeats the previous route point (a segment needs two distinct points)",
                    refs[j],
                )
        return Tendon(tension=tension, route=refs)

    def _outputs(self, v: Any, loads: tuple[Load, ...]) -> tuple[str, ...]:
        tbl = _table(v, "output")
        _check_keys(tbl, "output", OUTPUT_KEYS)
        if "points" in tbl:
            pts = tbl["points"]
            if not isinstance(pts, list):
                raise _fail("output.points", "must be a list of point references", pts)
            if len(pts) > MAX_ENTRIES:
                raise _fail(
                    "output.points", f"too many output points: {len(pts)} (at most {MAX_ENTRIES})"
                )
            if not pts:
                raise _fail(
                    "output.points",
                    "must name at least one point (leave the key out for the default points)",
                    pts,
                )
            refs = [self._ref(r, f"output.points[{j}]") for j, r in enumerate(pts)]
        else:
            refs = [ld.point for ld in loads]
        return tuple(dict.fromkeys(refs))


def with_loads(scene: Scene, loads: Sequence[Sequence[float]], tensions: Sequence[float]) -> Scene:
    """``scene`` with its loads' (fx, fy, moment) and its tendons' tensions replaced, in scene
    order (what a Solver was given instead of the scene's own)."""
    return replace(
        scene,
        loads=tuple(
            replace(ld, force=(fx, fy), moment=m) for ld, (fx, fy, m) in zip(scene.loads, loads)
        ),
        tendons=tuple(replace(t, tension=x) for t, x in zip(scene.tendons, tensions)),
    )


def load_levels(
    flexures: Sequence[Flexure], loads: Sequence[Sequence[float]], tensions: Sequence[float]
) -> dict[str, float]:
    """``Scene.load_levels`` of these flexures under loads (fx, fy, moment rows) and tendon
    tensions: also what a solve given other loads is checked at (``validity.loads_scene``)."""
    forces = sum(math.hypot(fx, fy) for fx, fy, _ in loads)
    forces += 2.0 * sum(tensions)
    moments = sum(abs(m) for _, _, m in loads)
    return {f.name: f.length * (f.length * forces + moments) / f.EI for f in flexures}


def coordinates(spec: ModelSpec, choosing_modes: bool = False) -> int:
    """The generalized coordinates of one flexure with this model (exact: its 3 root loads);
    ``choosing_modes``: as if it had a tolerance."""
    if spec.kind == "fem":
        return spec.elements
    if spec.kind == "scm":
        # a tolerance may choose any modes up to MAX_MODES
        return MAX_MODES if spec.tolerance is not None or choosing_modes else spec.modes
    return 3 if spec.kind == "exact" else 1


def check_limits(scene: Scene, choosing_modes: bool = False) -> None:
    """SceneError if the scene's models ask for more than the limits (docs/scene.md, Limits):
    the modes and elements of every flexure and the coordinates of the whole scene. Run on every
    scene parsed and again after command-line or API overrides of the models; with
    ``choosing_modes`` (a tolerance given to the selection, not by the scene), every scm
    flexure counts the MAX_MODES the tolerance may choose."""
    total = 0
    for i, f in enumerate(scene.flexures):
        m = f.model
        if not (isinstance(m.modes, int) and 1 <= m.modes <= MAX_MODES):
            raise _fail(f"flexure[{i}].modes", f"must be an integer in [1, {MAX_MODES}]", m.modes)
        if not (isinstance(m.elements, int) and 1 <= m.elements <= MAX_ELEMENTS):
            raise _fail(
                f"flexure[{i}].elements",
                f"must be an integer in [1, {MAX_ELEMENTS}]",
                m.elements,
            )
        total += coordinates(m, choosing_modes)
    if total > MAX_COORDINATES:
        raise _fail(
            "model",
            f"the scene's models have {total} coordinates in all (at most {MAX_COORDINATES}: "
            "fewer modes or elements, or fewer flexures; docs/scene.md, Limits)",
        )


def as_scene(scene: Scene | Mapping[str, Any] | str | os.PathLike) -> Scene:
    """A validated Scene from a Scene, a dict or a TOML path (SceneError on bad input)."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, Mapping):
        return scene_from_dict(scene)
    if isinstance(scene, str) and "\n" in scene:  # a file's text, not its name
        raise SceneError(
            "scene: got a string of several lines, which is no file name (TOML text? pass "
            "tomllib.loads(text) as a dict, or the file's path)"
        )
    if isinstance(scene, (str, os.PathLike)):
        return load_scene(scene)
    raise SceneError(f"scene: expected a Scene, a dict or a path, got {type(scene).__name__}")
