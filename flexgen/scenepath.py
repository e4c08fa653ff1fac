"""Dotted paths into a scene's source mapping: find or replace one value by names and indices.

A path walks the scene's TOML structure, one segment per table key or array index::

    name                          the scene's name
    model.modes                   a [model] key (kind, modes, elements, kernel, tolerance)
    base.points.r0.1              the y of the base point r0
    flexure.proximal.thickness    a [[flexure]] key, the flexure by name ...
    flexure.0.length              ... or by its index among the [[flexure]] tables
    flexure[0].length             the same: an index in brackets (as messages write keys) is
                                  always an index; digits that name another flexure are an error
    flexure.proximal.at.2         one entry of a list
    link.middle.points.pad.0      a link's point (links by name or index)
    load.0.force.1                a [[load]] key (loads and tendons by index)
    tendon.0.tension

This module knows the structure only (plain mappings and lists; which keys each kind of table may
have is passed in by flexgen/scene.py, whose ``Scene.with_value`` re-validates the changed
mapping): it sits below the scene and imports nothing of flexgen. A key a table may have but
does not give is added (``model.modes`` when [model] gives none); a key it may not have, or a
name or index that does not exist, is a ``PathError`` naming the path and listing what exists.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

ARRAYS = ("flexure", "link", "load", "tendon")  # [[...]] arrays of tables
NAMED = ("flexure", "link")  # arrays whose tables are also found by their name
INTEGER_KEYS = ("modes", "elements")  # a sweep's 3.0 means 3 here
MODEL_KEY_TABLE = "flexure.model"  # a flexure's own `model = {...}` sub-table


class PathError(ValueError):
    """A path that names no value of the scene; one line naming the path."""


def freeze(d: Any) -> Any:
    """A deep, read-only copy of a TOML-like structure (mappings and lists); what a Scene keeps
    as its ``source``, so that nobody changes it behind the Scene's back."""
    if isinstance(d, Mapping):
        return MappingProxyType({k: freeze(v) for k, v in d.items()})
    if isinstance(d, (list, tuple)):
        return tuple(freeze(v) for v in d)
    return d


def thaw(d: Any) -> Any:
    """The mutable copy of a frozen source that ``scene_from_dict`` reads (dicts and lists)."""
    if isinstance(d, Mapping):
        return {k: thaw(v) for k, v in d.items()}
    if isinstance(d, tuple):
        return [thaw(v) for v in d]
    return d


def _names(names: Sequence[Any], limit: int = 20) -> str:
    shown = ", ".join(str(n) for n in names[:limit])
    more = f", ... ({len(names) - limit} more)" if len(names) > limit else ""
    return (shown + more) or "none"


def _hint(seg: str, names: Sequence[Any]) -> str:
    """ "did you mean 'x'? " for a name close to ``seg`` (a typo), else "" (as scene keys)."""
    close = difflib.get_close_matches(seg, [str(n) for n in names if n is not None], n=1)
    return f"did you mean {close[0]!r}? " if close else ""


def _short(v: Any) -> str:
    s = repr(v)
    return s if len(s) <= 60 else s[:57] + "..."


# an index in brackets, as flexgen's messages write keys (flexure[1].length): always an index
_BRACKET = re.compile(r"\[(\d+)\]")


def _segments(path: Any) -> list[str]:
    """The path's segments; ``a[1]`` is the segments ``a`` and ``[1]`` (``_position``)."""
    if isinstance(path, str):
        dotted = _BRACKET.sub(lambda m: ".[" + m.group(1) + "]", path)
        if path and not dotted.startswith(".") and all(dotted.split(".")):
            return dotted.split(".")
    raise PathError(f"scene path must be keys joined by dots, got {_short(path)}")


def _position(seg: str) -> int | None:
    """The index a segment gives: ``3`` or ``[3]``; None for a name."""
    if seg.isdigit():
        return int(seg)
    if seg.startswith("[") and seg.endswith("]") and seg[1:-1].isdigit():
        return int(seg[1:-1])
    return None


def _index(seg: str, items: Sequence[Any], path: str, what: str) -> int:
    """The index of ``seg`` (a decimal index, ``[i]``, or a table's name where allowed) in
    ``items``. Digits that are also another table's name are ambiguous: an error that names
    both (review: flexure.1 changed the flexure at index 1 of a scene whose flexures are named
    "1" and "2")."""
    names = [t.get("name") if isinstance(t, Mapping) else None for t in items]
    i = _position(seg)
    if i is not None:
        if i >= len(items):
            raise PathError(f"{path}: no {what} {i} (the scene has {len(items)})")
        if seg.isdigit() and what in NAMED and seg in names and names.index(seg) != i:
            j = names.index(seg)
            raise PathError(
                f"{path}: {seg!r} is both the name of {what}[{j}] and the index of {what}[{i}] "
                f"(named {names[i]!r}): write {what}[{j}] or {what}[{i}]"
            )
        return i
    if what in NAMED:
        if seg in names:
            return names.index(seg)
        raise PathError(
            f"{path}: unknown {what} {seg!r} ({_hint(seg, names)}known: {_names(names)})"
        )
    raise PathError(f"{path}: a {what} is given by its index (0 to {len(items) - 1}), got {seg!r}")


def walk(
    root: dict[str, Any], path: str, tables: Mapping[str, Sequence[str]]
) -> tuple[dict[str, Any] | list[Any], str | int]:
    """(container, key or index) of the value ``path`` names in the mutable source ``root``;
    ``tables`` gives the keys each kind of table may have ("" the top level, "model",
    "flexure", "flexure.model", ...). Missing tables on the way are created (an absent [model]
    for ``model.modes``)."""
    container, key, _ = _walk(root, path, tables)
    return container, key


def _walk(
    root: dict[str, Any], path: str, tables: Mapping[str, Sequence[str]]
) -> tuple[dict[str, Any] | list[Any], str | int, list[str]]:
    """``walk``, and the path's segments as ``canonical`` gives them (an index for every name
    or index of a table, a list index in its plain decimal form)."""
    segs = _segments(path)
    node: Any = root
    key: Any
    kind: str | None = ""  # the kind of table `node` is ("" top level; None: points, vectors)
    canon: list[str] = []
    i = 0
    while True:
        seg, where = segs[i], ".".join(segs[:i]) or "the scene"
        if isinstance(node, list):
            at = _position(seg)
            if at is None or at >= len(node):
                raise PathError(
                    f"{path}: {where} has no index {seg!r} (it has {len(node)} entries)"
                )
            key = at
        elif isinstance(node, dict):
            allowed = tables.get(kind) if kind is not None else None
            if seg not in node and (allowed is None or seg not in allowed):
                known = list(allowed if allowed is not None else node)
                raise PathError(
                    f"{path}: {where} has no key {seg!r} ({_hint(seg, known)}known: "
                    f"{_names(known)})"
                )
            key = seg
        else:
            raise PathError(f"{path}: {where} is a value ({_short(node)}), not a table or a list")
        canon.append(str(key))
        if i == len(segs) - 1:
            return node, key, canon
        if kind == "" and seg in ARRAYS:  # [[flexure]] etc.: the next segment picks one table
            items = node.get(seg)
            items = items if isinstance(items, list) else []
            picked = _index(segs[i + 1], items, path, seg)
            node = items[picked]
            canon.append(str(picked))
            kind, i = seg, i + 2
            if i == len(segs):
                raise PathError(f"{path}: names a whole [[{seg}]] table; give one of its keys")
            continue
        child = node[key] if isinstance(node, list) else node.get(key)
        if child is None:  # only a mapping's key may be missing
            # an entry of a list the scene lacks (review: "has no key '2' (known: none)")
            if _position(segs[i + 1]) is not None:
                raise PathError(
                    f"{path}: {'.'.join(segs[: i + 1])} is not in the scene, so it has no "
                    f"entry {segs[i + 1]!r}: give it whole in the scene to vary one entry"
                )
            child = node[key] = {}
        if kind == "" and seg in tables:
            kind = seg
        elif kind == "flexure" and seg == "model":
            kind = MODEL_KEY_TABLE
        else:
            kind = None
        node, i = child, i + 1


def resolve(
    root: dict[str, Any], path: str, tables: Mapping[str, Sequence[str]]
) -> tuple[dict[str, Any] | list[Any], str | int, str]:
    """(container, key or index, canonical path) of the value ``path`` names, where
    ``set_value`` writes it: a model key of a flexure given in its own ``model = {...}``
    sub-table is found there. Paths that name the same value have the same canonical path
    (``flexure.0.thickness`` for ``flexure.proximal.thickness``, ``load.0.force.1`` for
    ``load.0.force.01``)."""
    container, key, canon = _walk(root, path, tables)
    model_keys = tables.get(MODEL_KEY_TABLE, ())
    if isinstance(container, dict) and key in model_keys:
        sub = container.get("model")
        if key not in container and isinstance(sub, dict) and key in sub:
            container = sub
    # a flexure's model key is one value however it is spelled, and wherever it is given
    # (flexure.0.modes, flexure.0.model.modes): one canonical path, the sub-table's
    if len(canon) == 3 and canon[0] == "flexure" and canon[2] in model_keys:
        canon.insert(-1, "model")
    return container, key, ".".join(canon)


def canonical(root: dict[str, Any], path: str, tables: Mapping[str, Sequence[str]]) -> str:
    """The one spelling of the value ``path`` names (see ``resolve``); PathError as ``walk``."""
    return resolve(root, path, tables)[2]


def plain(value: Any, key: Any) -> Any:
    """A NumPy scalar as the Python number TOML would give, a NumPy array as the (nested) list
    (which the scene's checks then read and name: review, ``.item()`` of a vector raised NumPy's
    own message); an integral float as an int for the integer keys (a linspace of modes gives
    3.0)."""
    if hasattr(value, "tolist") and getattr(value, "ndim", 0) > 0:
        value = value.tolist()
    elif isinstance(value, (list, tuple)):  # a list of NumPy scalars too (review)
        value = [plain(v, None) for v in value]
    elif hasattr(value, "item") and not isinstance(value, dict):
        value = value.item()
    if key in INTEGER_KEYS and isinstance(value, float) and value.is_integer():
        value = int(value)
    return value


def set_value(
    root: dict[str, Any], path: str, value: Any, tables: Mapping[str, Sequence[str]]
) -> None:
    """Replace (or add) the value at ``path`` in the mutable source ``root``."""
    container, key, _ = resolve(root, path, tables)
    container[key] = plain(value, key)  # type: ignore[index]
