"""Dotted paths into a scene: read or replace one value by its names and indices.

A path walks the scene's TOML structure, one segment per table key or array index::

    name                          the scene's name
    model.modes                   a [model] key (kind, modes, elements, kernel, tolerance)
    base.points.r0.1              the y of the base point r0
    flexure.proximal.thickness    a [[flexure]] key, the flexure by name ...
    flexure.0.length              ... or by its index among the [[flexure]] tables
    flexure.proximal.at.2         one entry of a list
    link.middle.points.pad.0      a link's point (links by name or index)
    load.0.force.1                a [[load]] key (loads and tendons by index)
    tendon.0.tension

``with_value(scene, path, value)`` re-validates the scene's source mapping (``Scene.source``,
kept by ``scene_from_dict``) with the one value replaced, so derived values (EI from E, width and
thickness), defaults and every check stay in flexgen/scene.py: a bad value is the scene's own
one-line SceneError, prefixed with the path. A key a table may have but does not (``model.modes``
when [model] gives none) is added; a key it may not have, or a name or index that does not
exist, is a SceneError naming the path and listing what exists.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from .scene import (
    BASE_KEYS,
    FLEXURE_KEYS,
    LINK_KEYS,
    LOAD_KEYS,
    MODEL_KEYS,
    OUTPUT_KEYS,
    TENDON_KEYS,
    TOP_KEYS,
    SceneError,
    _fmt,
    _names,
    scene_from_dict,
)

if TYPE_CHECKING:
    from .scene import Scene

# the keys each kind of table may hold (a key absent from the source may be added)
TABLE_KEYS = {
    "": TOP_KEYS,
    "model": MODEL_KEYS,
    "base": BASE_KEYS,
    "flexure": FLEXURE_KEYS,
    "flexure.model": MODEL_KEYS,
    "link": LINK_KEYS,
    "load": LOAD_KEYS,
    "tendon": TENDON_KEYS,
    "output": OUTPUT_KEYS,
}
ARRAYS = ("flexure", "link", "load", "tendon")  # [[...]] arrays of tables
NAMED = ("flexure", "link")  # arrays whose tables are also found by their name
INTEGER_KEYS = ("modes", "elements")  # a sweep's 3.0 means 3 here


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


def _fail(path: str, msg: str) -> SceneError:
    return SceneError(f"{path}: {msg}")


def _kind_order(scene: Scene) -> list[str] | None:
    """The ``order=`` argument of scene_from_dict ("flexure"/"link" in file order) from the
    scene's declaration order of names."""
    kinds = {f.name: "flexure" for f in scene.flexures} | {lk.name: "link" for lk in scene.links}
    order = [kinds[n] for n in scene.declaration_order if n in kinds]
    return order if len(order) == len(kinds) else None


def source_of(scene: Scene) -> Mapping[str, Any]:
    """The scene's source mapping; SceneError when it has none or no longer matches the scene
    (a Scene changed with dataclasses.replace after it was read)."""
    if scene.source is None:
        raise SceneError(
            "with_value: this Scene was built without its source; read it with "
            "flexgen.load_scene or flexgen.scene_from_dict"
        )
    current = scene.__dict__.get("_source_matches")
    if current is None:  # checked once per Scene object (the Scene is immutable)
        current = _reparse(scene, thaw(scene.source)) == scene
        object.__setattr__(scene, "_source_matches", current)
    if not current:
        raise SceneError(
            "with_value: this Scene was changed after it was read (dataclasses.replace or a "
            "model override), so its source no longer describes it; change the source instead"
        )
    return scene.source


def _reparse(scene: Scene, d: dict[str, Any]) -> Scene:
    return scene_from_dict(d, order=_kind_order(scene), default_name=scene.name)


def _segments(path: Any) -> list[str]:
    if not isinstance(path, str) or not path or any(not s for s in path.split(".")):
        raise SceneError(f"scene path must be keys joined by dots, got {_fmt(path)}")
    return path.split(".")


def _index(seg: str, items: Sequence[Any], path: str, what: str, by_name: bool) -> int:
    """The index of ``seg`` (a decimal index, or a table's name where allowed) in ``items``."""
    if seg.isdigit():
        i = int(seg)
        if i < len(items):
            return i
        raise _fail(path, f"no {what} {i} (the scene has {len(items)})")
    if by_name:
        names = [t.get("name") if isinstance(t, Mapping) else None for t in items]
        if seg in names:
            return names.index(seg)
        raise _fail(path, f"unknown {what} {seg!r} (known: {_names(names) or 'none'})")
    raise _fail(path, f"{what} is given by index (0 to {len(items) - 1}), got {seg!r}")


def _walk(root: dict[str, Any], path: str) -> tuple[Any, Any]:
    """(container, key or index) of the value ``path`` names in the mutable source ``root``;
    missing tables on the way are created (an absent [model] for ``model.modes``)."""
    segs = _segments(path)
    node: Any = root
    kind: str | None = ""  # the kind of table `node` is ("" top level; None: points, vectors)
    i = 0
    while True:
        seg, where = segs[i], ".".join(segs[:i]) or "the scene"
        if isinstance(node, list):
            if not seg.isdigit() or int(seg) >= len(node):
                raise _fail(path, f"{where} has no index {seg!r} (it has {len(node)} entries)")
            key: Any = int(seg)
        elif isinstance(node, dict):
            allowed = TABLE_KEYS.get(kind) if kind is not None else None
            if seg not in node and (allowed is None or seg not in allowed):
                known = allowed if allowed is not None else tuple(node)
                raise _fail(path, f"{where} has no key {seg!r} (known: {_names(known) or 'none'})")
            key = seg
        else:
            raise _fail(path, f"{where} is a value ({_fmt(node)}), not a table or a list")
        if i == len(segs) - 1:
            return node, key
        if kind == "" and seg in ARRAYS:  # [[flexure]] etc.: the next segment picks one table
            items = node.get(seg)
            items = items if isinstance(items, list) else []
            node = items[_index(segs[i + 1], items, path, seg, seg in NAMED)]
            kind, i = seg, i + 2
            if i == len(segs):
                raise _fail(path, f"names a whole [[{seg}]] table; give one of its keys")
            continue
        child = node[key] if isinstance(node, list) else node.get(key)
        if child is None:
            child = node[key] = {}
        if kind == "" and seg in TABLE_KEYS:
            kind = seg
        elif kind == "flexure" and seg == "model":
            kind = "flexure.model"
        else:
            kind = None
        node, i = child, i + 1


def _plain(value: Any, key: Any) -> Any:
    """A NumPy scalar as the Python number TOML would give; an integral float as an int for the
    integer keys (a linspace of modes gives 3.0)."""
    if hasattr(value, "item") and not isinstance(value, (list, tuple, dict)):
        value = value.item()
    if key in INTEGER_KEYS and isinstance(value, float) and value.is_integer():
        value = int(value)
    return value


def set_value(root: dict[str, Any], path: str, value: Any) -> None:
    """Replace (or add) the value at ``path`` in the mutable source ``root``."""
    container, key = _walk(root, path)
    # a model key of a flexure given in its own `model = {...}` sub-table is changed there
    if isinstance(container, dict) and key in MODEL_KEYS and key not in container:
        sub = container.get("model")
        if isinstance(sub, dict) and key in sub and "name" in container:
            container = sub
    container[key] = _plain(value, key)


def get_value(scene: Scene, path: str) -> Any:
    """The value at ``path`` in the scene's source (None when the table may have the key but
    does not give it: a default or a derived value)."""
    root = thaw(source_of(scene))
    container, key = _walk(root, path)
    if isinstance(container, list):
        return container[key]
    return container.get(key)


def with_value(scene: Scene, path: str, value: Any) -> Scene:
    """``scene`` with the value at ``path`` replaced, validated as a scene file is."""
    return with_values(scene, {path: value})


def with_values(scene: Scene, values: Mapping[str, Any]) -> Scene:
    """``scene`` with several values replaced at once (one validation)."""
    root = thaw(source_of(scene))
    for path, value in values.items():
        set_value(root, path, value)
    try:
        return _reparse(scene, root)
    except SceneError as exc:
        where = ", ".join(values)
        raise SceneError(f"{where}: {exc}") from None


def check_path(scene: Scene, path: str) -> None:
    """SceneError naming ``path`` if it does not name a value of this scene."""
    _walk(thaw(source_of(scene)), path)
