"""The model registry: what each model kind of a scene is, in one table.

``KINDS`` maps a scene's ``kind`` to a ``ModelKind``: how to build the flexure's model from its
ModelSpec, how the solver core evaluates it (``FG_MODEL_*`` and the fields of its
``fg_flexure``), and what the Result says of it. The few other places that tell models apart
by kind are listed in docs/architecture.md ("How to add a model kind"). The model modules are imported lazily, so a scene that uses one kind needs only that
module (and the runtime never imports SymPy).

    scm   -> SCMModel(length, EI, modes, kernel)   the generated kernels (core: FG_MODEL_KERNEL)
    cc    -> SCMModel(length, EI, 1, kernel)       constant curvature: scm with one mode
    prb   -> PRBModel(length, EI)                  pseudo-rigid-body 1R (core: FG_MODEL_PRB)
    fem   -> FEMModel(length, EI, elements)        n rigid segments (core: FG_MODEL_FEM)
    exact -> no chain model: the elastica reference solves the whole scene (flexgen.models.exact)

To add a model: write its class (``flexgen.models.base.FlexureModel``), its C evaluation in the
core's ``flexure_tip`` (chain_solver.c) under a new ``FG_MODEL_*``, and a row here.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .base import FlexureModel

if TYPE_CHECKING:
    from ..scene import Flexure, Scene


class ModelError(ValueError):
    """A flexure model that cannot be built; the message names the flexure."""


def _scm(flexure: Flexure, cls: Any) -> FlexureModel:
    spec = flexure.model
    modes = 1 if spec.kind == "cc" else int(spec.modes)
    return cls(float(flexure.length), float(flexure.EI), modes, spec.kernel, name=flexure.name)


def _prb(flexure: Flexure, cls: Any) -> FlexureModel:
    return cls(float(flexure.length), float(flexure.EI))


def _fem(flexure: Flexure, cls: Any) -> FlexureModel:
    return cls(float(flexure.length), float(flexure.EI), int(flexure.model.elements))


@dataclass(frozen=True)
class ModelKind:
    name: str
    module: str | None  # where its class lives (None: not a chain model)
    cls: str | None
    build: Callable[[Flexure, Any], FlexureModel] | None
    chain: bool  # a chain model: the core solves it (its class fills its fg_flexure)
    info: Callable[[Any], dict[str, Any]]  # the Result's "model" entry of a flexure
    # its name from that entry: "cc", "scm3", "fem16", "prb", "exact" (``label``)
    label: Callable[[Mapping[str, Any]], str]


def _scm_label(info: Mapping[str, Any]) -> str:
    return "cc" if info["modes"] == 1 else f"scm{info['modes']}"


KINDS: dict[str, ModelKind] = {
    "scm": ModelKind(
        "scm",
        "flexgen.models.scm",
        "SCMModel",
        _scm,
        True,
        lambda m: {"kind": "scm", "modes": int(m.n_dof)},
        _scm_label,
    ),
    "cc": ModelKind(
        "cc",
        "flexgen.models.scm",
        "SCMModel",
        _scm,
        True,
        lambda m: {"kind": "scm", "modes": int(m.n_dof)},
        _scm_label,
    ),
    "prb": ModelKind(
        "prb",
        "flexgen.models.prb",
        "PRBModel",
        _prb,
        True,
        lambda m: {"kind": "prb"},
        lambda info: "prb",
    ),
    "fem": ModelKind(
        "fem",
        "flexgen.models.fem",
        "FEMModel",
        _fem,
        True,
        lambda m: {"kind": "fem", "elements": int(m.n_dof)},
        lambda info: f"fem{info['elements']}",
    ),
    "exact": ModelKind(
        "exact", None, None, None, False, lambda m: {"kind": "exact"}, lambda info: "exact"
    ),
}
MODEL_KINDS = tuple(KINDS)


def _class(kind: ModelKind, flexure: Flexure) -> Any:
    assert kind.module is not None and kind.cls is not None
    try:
        return getattr(importlib.import_module(kind.module), kind.cls)
    except ImportError as exc:
        raise ModelError(
            f"flexure {flexure.name!r}: model kind {kind.name!r} is not available "
            f"({kind.module} cannot be imported: {exc})"
        ) from exc


def build_model(flexure: Flexure) -> FlexureModel:
    """The FlexureModel that ``flexure.model`` asks for, in the flexure's physical units."""
    kind = KINDS.get(flexure.model.kind)
    if kind is None:
        raise ModelError(f"flexure {flexure.name!r}: unknown model kind {flexure.model.kind!r}")
    if kind.build is None:
        raise ModelError(
            f"flexure {flexure.name!r}: model kind {kind.name!r} is a reference "
            f"elastica solver, not a chain model; use flexgen.models.exact directly"
        )
    return kind.build(flexure, _class(kind, flexure))


# the keys of a Result's model entry (``model_info`` and the kernel) that name a flexure's model
REPORTED_KEYS = ("kind", "modes", "elements", "kernel")


def as_reported(spec: Any, info: Mapping[str, Any]) -> Any:
    """The ModelSpec ``spec`` changed to the model a Result reports for its flexure (``info``:
    ``Result.model[name]``), its tolerance dropped (the modes it chose are in ``info``): the
    model that rebuilds the Result's shapes and checks. ``spec`` itself where nothing differs."""
    from dataclasses import replace

    changes = {k: info[k] for k in REPORTED_KEYS if k in info}
    if all(getattr(spec, k) == v for k, v in changes.items()) and spec.tolerance is None:
        return spec
    return replace(spec, **changes, tolerance=None)


def kind_of(model: Any) -> ModelKind:
    """The registry row of a built model (by its ``kind`` attribute)."""
    kind = KINDS.get(getattr(model, "kind", None))  # type: ignore[arg-type]
    if kind is None or not kind.chain:
        raise ModelError(
            f"model {model!r} is not one of the chain model kinds "
            f"({', '.join(k for k, v in KINDS.items() if v.chain)})"
        )
    return kind


def core_description(model: Any, flexure_struct: Any) -> np.ndarray:
    """Fill the core's ``fg_flexure`` for ``model`` (its ``core_flexure``: each model class
    describes itself to the core); the diagonal of its energy Hessian."""
    kind_of(model)  # a chain model kind, else ModelError
    return np.asarray(model.core_flexure(flexure_struct), dtype=float)


def model_info(model: Any) -> dict[str, Any]:
    """The Result's description of a flexure's model ({"kind": ..., "modes"/"elements": ...})."""
    return kind_of(model).info(model)


def label(info: Mapping[str, Any]) -> str:
    """A flexure model's name from its Result entry (``Result.model[flexure]``, ``model_info``):
    "cc" (smooth curvature with one mode), "scm3", "prb", "fem16", "exact"."""
    return KINDS[info["kind"]].label(info)


def build_models(
    scene: Scene,
    overrides: Mapping[str, FlexureModel] | None = None,
    factory: Callable[[Flexure], FlexureModel] | None = None,
) -> dict[str, FlexureModel]:
    """A model for every flexure of ``scene``: ``overrides[name]`` where given, else ``factory``
    (default ``build_model``) applied to the flexure."""
    overrides = dict(overrides or {})
    names = {f.name for f in scene.flexures}
    unknown = [name for name in overrides if name not in names]
    if unknown:
        raise ModelError(f"a model is given for unknown flexure {unknown[0]!r}")
    factory = factory or build_model
    return {
        f.name: overrides[f.name] if f.name in overrides else factory(f) for f in scene.flexures
    }
