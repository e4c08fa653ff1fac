"""The Python API behind ``flexgen.solve``: scene or path in, Result out, with model overrides.

``solve(scene, model=None, modes=None, elements=None, **options)``:

- ``scene``: a ``Scene``, a dict (``scene_from_dict``) or a path to a TOML file (``load_scene``);
- ``model`` / ``modes`` / ``elements``: override every flexure's ``kind`` / ``modes`` /
  ``elements`` (they beat the scene's ``[model]`` and per-flexure keys; ``modes`` also clears a
  ``tolerance``, since the modes are then given);
- ``options``: passed to ``flexgen.equilibrium.solve`` (``tol``, ``max_steps``, ...); ignored by the
  exact solver.

Kind ``"exact"`` must apply to every flexure (the elastica solver solves the whole scene at once);
it runs ``models.exact.solve_exact`` and converts its answer (``flexgen.exact_result``).

Every converged chain-model answer is checked against what its models may claim
(``flexgen.validity``): the validity warnings are appended to ``Result.warnings`` and the
indicative error class is ``Result.error_class`` (Python API only).
"""
from __future__ import annotations

import os
from dataclasses import replace
from typing import Any, Mapping

from .result import Result
from .scene import MODEL_KINDS, Scene, SceneError, load_scene, scene_from_dict


def as_scene(scene: Scene | Mapping[str, Any] | str | os.PathLike) -> Scene:
    """A validated Scene from a Scene, a dict or a TOML path (SceneError on bad input)."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, Mapping):
        return scene_from_dict(scene)
    if isinstance(scene, (str, os.PathLike)):
        return load_scene(scene)
    raise SceneError(f"scene: expected a Scene, a dict or a path, got {type(scene).__name__}")


def _count(value, key: str) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise SceneError(f"{key}: must be an integer >= 1, got {value!r}")
    return value


def override(scene: Scene, model: str | None = None, modes: int | None = None,
             elements: int | None = None) -> Scene:
    """``scene`` with every flexure's model kind, modes and elements replaced where given."""
    if model is not None and model not in MODEL_KINDS:
        raise SceneError(f"model: unknown kind {model!r} (choose from {', '.join(MODEL_KINDS)})")
    modes, elements = _count(modes, "modes"), _count(elements, "elements")
    changes: dict[str, Any] = {}
    if model is not None:
        changes["kind"] = model
    if modes is not None:
        changes.update(modes=modes, tolerance=None)
    if elements is not None:
        changes["elements"] = elements
    if not changes:
        return scene
    flexures = tuple(replace(f, model=replace(f.model, **changes)) for f in scene.flexures)
    return replace(scene, model=replace(scene.model, **changes), flexures=flexures)


def uses_exact(scene: Scene) -> bool:
    """True if the scene asks for the exact solver (every flexure kind "exact"); SceneError if
    only some flexures do."""
    exact = [f.model.kind == "exact" for f in scene.flexures]
    if any(exact) and not all(exact):
        i = exact.index(True)
        raise SceneError(f"flexure[{i}].kind: 'exact' solves the whole scene; give it to every "
                         f"flexure ([model].kind = \"exact\" or --model exact), got it for "
                         f"{scene.flexures[i].name!r} only")
    return bool(exact) and all(exact)


def solve_scene(scene: Scene, **options):
    """``(Result, exact SceneSolution or None)`` for an already overridden scene.

    A converged chain-model result also carries the validity warnings of its models
    (``flexgen.validity.check``: appended to ``warnings``) and, for the Python API,
    ``error_class`` = {"pose", "compliance"}, the indicative error class (None when a tolerance
    chose the models: ``error_estimate`` is then the claim; not part of the JSON contract)."""
    if uses_exact(scene):
        from . import exact_result
        return exact_result.solve(scene)
    from .equilibrium import solve as chain_solve
    from .validity import check
    result = chain_solve(scene, **options)
    check(scene, result, options.get("models"), options.get("model_factory"))
    return result, None


def solve(scene, model: str | None = None, modes: int | None = None,
          elements: int | None = None, **options) -> Result:
    """Solve a scene (Scene, dict or TOML path); see the module docstring."""
    sc = override(as_scene(scene), model, modes, elements)
    return solve_scene(sc, **options)[0]
