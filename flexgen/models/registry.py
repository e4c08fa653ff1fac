"""Build a FlexureModel for a scene's flexure from its ModelSpec.

The model modules are imported lazily, so a scene that uses only one kind of model needs only that
module (and the runtime never imports SymPy).

    scm -> flexgen.models.scm.SCMModel(length, EI, modes, kernel, name)
    cc  -> flexgen.models.scm.SCMModel(length, EI, 1, kernel, name)     (constant curvature)
    prb -> flexgen.models.prb.PRBModel(length, EI)
    fem -> flexgen.models.fem.FEMModel(length, EI, elements)
"""
from __future__ import annotations

import importlib
from typing import Callable, Mapping

from ..scene import Flexure, Scene
from .base import FlexureModel


class ModelError(ValueError):
    """A flexure model that cannot be built; the message names the flexure."""


def _load(module: str, cls: str, flexure: Flexure):
    try:
        mod = importlib.import_module(module)
    except ImportError as exc:
        raise ModelError(
            f"flexure {flexure.name!r}: model kind {flexure.model.kind!r} is not available "
            f"({module} cannot be imported: {exc})") from exc
    try:
        return getattr(mod, cls)
    except AttributeError as exc:
        raise ModelError(f"flexure {flexure.name!r}: {module} has no {cls}") from exc


def build_model(flexure: Flexure) -> FlexureModel:
    """The FlexureModel that ``flexure.model`` asks for, in the flexure's physical units."""
    spec = flexure.model
    kind = spec.kind
    length, EI = float(flexure.length), float(flexure.EI)
    if kind in ("scm", "cc"):
        SCMModel = _load("flexgen.models.scm", "SCMModel", flexure)
        modes = 1 if kind == "cc" else int(spec.modes)
        return SCMModel(length, EI, modes, spec.kernel, name=flexure.name)
    if kind == "prb":
        PRBModel = _load("flexgen.models.prb", "PRBModel", flexure)
        return PRBModel(length, EI)
    if kind == "fem":
        FEMModel = _load("flexgen.models.fem", "FEMModel", flexure)
        return FEMModel(length, EI, int(spec.elements))
    if kind == "exact":
        raise ModelError(
            f"flexure {flexure.name!r}: model kind 'exact' is a reference elastica solver, "
            "not a chain model; use flexgen.models.exact directly")
    raise ModelError(f"flexure {flexure.name!r}: unknown model kind {kind!r}")


def build_models(scene: Scene, overrides: Mapping[str, FlexureModel] | None = None,
                 factory: Callable[[Flexure], FlexureModel] | None = None) -> dict[str, FlexureModel]:
    """A model for every flexure of ``scene``: ``overrides[name]`` where given, else ``factory``
    (default ``build_model``) applied to the flexure."""
    overrides = dict(overrides or {})
    names = {f.name for f in scene.flexures}
    unknown = [name for name in overrides if name not in names]
    if unknown:
        raise ModelError(f"a model is given for unknown flexure {unknown[0]!r}")
    factory = factory or build_model
    return {f.name: overrides[f.name] if f.name in overrides else factory(f)
            for f in scene.flexures}
