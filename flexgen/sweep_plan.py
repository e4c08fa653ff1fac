"""A study's cases: the varied keys, their values, the order they are solved in and the chunks.

``plan(scene, vary, samples, seed)`` checks every key (a path as ``Scene.with_value`` reads it;
two keys naming the same value and a tolerance are refused) and value before anything is
solved, and returns a ``Plan``:

- grid (``samples`` None): ``{key: (start, stop, count)}`` (``numpy.linspace``) or ``{key:
  [values]}``; the full factorial, rows in C order of the keys as given (the first key varies
  slowest, the last fastest);
- Monte-Carlo (``samples=N``): ``{key: ("normal", mean, sd)}`` or ``("uniform", low, high)``,
  drawn key by key in the order given from ``numpy.random.default_rng(seed)`` (the same seed
  gives the same cases).

A *load key* changes a load or tendon tension only (``load.I.force.J``, ``load.I.moment``,
``tendon.I.tension``): one prepared Solver serves every value. Any other key changes the
design, so the problem is prepared again. Cases are solved in an order that keeps each design's
cases together: the grid's design keys (in their given order) outside, its load keys inside;
each case's row in the table stays the C order above.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .scene import TABLE_KEYS, Scene, SceneError, _fmt
from .scenepath import INTEGER_KEYS, PathError, canonical

DISTRIBUTIONS = ("normal", "uniform")
CHUNK_SIZE = 500  # cases per chunk (a task): see docs/sweep.md, "Chunks"
MAX_CASES = 10_000_000  # a study's cases: a bound on memory (~100 floats per case)


@dataclass(frozen=True)
class Plan:
    keys: tuple[str, ...]  # as given
    # per key: ("load", i, j) a load component, ("tension", i, 0), or None (a design key)
    targets: tuple[tuple[str, int, int] | None, ...]
    values: np.ndarray  # cases x keys, in table (row) order
    order: np.ndarray  # the row of each case in solve order
    row_length: int  # cases in solve order between a row's start and the next row's
    monte_carlo: bool

    @property
    def cases(self) -> int:
        return int(self.values.shape[0])

    def chunks(self, size: int = CHUNK_SIZE) -> list[tuple[int, int]]:
        """(start, stop) in solve order: contiguous, fixed by the study alone (never by the
        number of workers), so every way of running it solves the same cases from the same
        warm starts."""
        return [(a, min(a + size, self.cases)) for a in range(0, self.cases, size)]


def load_target(path: str) -> tuple[str, int, int] | None:
    """("load", i, j) for a load's force component j (j = 2: its moment), ("tension", i, 0) for a
    tendon's tension; None for any other path (a design key). ``path`` canonical
    (``scenepath.canonical``: ``load.0.force.01`` is read as ``load.0.force.1``)."""
    segs = path.split(".")
    if len(segs) == 4 and segs[0] == "load" and segs[1].isdigit() and segs[2] == "force":
        if segs[3] in ("0", "1"):
            return ("load", int(segs[1]), int(segs[3]))
    if len(segs) == 3 and segs[1].isdigit():
        if segs[0] == "load" and segs[2] == "moment":
            return ("load", int(segs[1]), 2)
        if segs[0] == "tendon" and segs[2] == "tension":
            return ("tension", int(segs[1]), 0)
    return None


def _number(v: Any, key: str, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise SceneError(f"{key}: {what} must be a number, got {_fmt(v)}")
    try:
        x = float(v)
    except OverflowError:  # an int beyond a float's range (10**400)
        x = math.inf
    if not math.isfinite(x):
        raise SceneError(f"{key}: {what} must be finite, got {_fmt(v)}")
    return x


def grid_values(key: str, spec: Any) -> np.ndarray:
    """The values of one grid key: (start, stop, count) or a list of values."""
    if isinstance(spec, (str, bytes)) or not isinstance(spec, (Sequence, np.ndarray)):
        raise SceneError(
            f"{key}: expected (start, stop, count) or a list of values, got {_fmt(spec)}"
        )
    if len(spec) and isinstance(spec[0], str):
        if spec[0] in DISTRIBUTIONS:
            raise SceneError(f"{key}: a {spec[0]} distribution needs samples=N (Monte-Carlo)")
        raise SceneError(
            f"{key}: {spec[0]!r} is neither a number (values are numbers in the scene's units) "
            f"nor a distribution (normal or uniform, with samples=N)"
        )
    if isinstance(spec, tuple) and len(spec) != 3:
        # a tuple is (start, stop, count): (0, 1) is a count forgotten more often than a
        # choice of two values, which a list gives
        raise SceneError(
            f"{key}: a tuple is (start, stop, count), got {len(spec)} items "
            f"({_fmt(spec)}); give a list for the values themselves"
        )
    if isinstance(spec, tuple):
        start = _number(spec[0], key, "start")
        stop = _number(spec[1], key, "stop")
        count = spec[2]
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
            raise SceneError(f"{key}: count must be an integer >= 1, got {_fmt(count)}")
        # to 15 significant digits: linspace's 0.30000000000000004 (0.1 * 3) is 0.3 in the
        # table a user reads and keys on, and the solve loads the value the table shows
        with np.errstate(all="ignore"):  # (-1e308, 1e308): the step overflows, refused below
            grid = np.linspace(start, stop, int(count))
        if not np.all(np.isfinite(grid)):
            raise SceneError(
                f"{key}: (start, stop, count) = {_fmt(spec)} gives values beyond a float's range"
            )
        rounded = np.array([float(f"{v:.15g}") for v in grid])
        # where rounding would merge distinct grid points (steps near 1e-15 relative), the
        # points themselves: one key value per row (review)
        return rounded if len(set(rounded.tolist())) == len(set(grid.tolist())) else grid
    values = [_number(v, key, "every value") for v in spec]
    if not values:
        raise SceneError(f"{key}: no values")
    return np.array(values, dtype=float)


def _grid_size(spec: Any) -> int:
    """How many values ``grid_values`` makes of ``spec``, without making them (1 where it will
    refuse the spec: its own message says why)."""
    if isinstance(spec, tuple) and len(spec) == 3:
        count = spec[2]
        if isinstance(count, (int, np.integer)) and not isinstance(count, bool) and count >= 1:
            return int(count)
        return 1
    try:
        return max(len(spec), 1)
    except TypeError:
        return 1


def draw(key: str, spec: Any, samples: int, rng: np.random.Generator) -> np.ndarray:
    """``samples`` values of one Monte-Carlo key."""
    if not (isinstance(spec, (tuple, list)) and len(spec) == 3 and spec[0] in DISTRIBUTIONS):
        raise SceneError(
            f"{key}: with samples, expected ('normal', mean, sd) or ('uniform', low, high), "
            f"got {_fmt(spec)}"
        )
    kind = spec[0]
    a = _number(spec[1], key, "mean" if kind == "normal" else "low")
    b = _number(spec[2], key, "sd" if kind == "normal" else "high")
    if kind == "normal":
        if b < 0:
            raise SceneError(f"{key}: the standard deviation must be >= 0, got {b:g}")
        return rng.normal(a, b, samples)
    if b < a:
        raise SceneError(f"{key}: uniform needs low <= high, got {a:g} > {b:g}")
    if not np.isfinite(b - a):  # NumPy draws from low + (high - low) u
        raise SceneError(f"{key}: uniform's range high - low overflows, got {a:g} to {b:g}")
    return rng.uniform(a, b, samples)


def _check_values(scene: Scene, key: str, values: np.ndarray) -> None:
    """The scene's own SceneError for the first invalid value of ``key``. Every check of a
    number is an interval, so the smallest and largest values stand for all; an integer key
    (modes, elements) checks each distinct value."""
    last = key.rsplit(".", 1)[-1]
    distinct = np.unique(values)
    probe = distinct if last in INTEGER_KEYS else distinct[[0, -1]]
    for v in probe:
        scene.with_value(key, float(v))


def _paths(scene: Scene, keys: tuple[Any, ...]) -> list[str]:
    """The canonical path of each key (``scenepath.canonical``); SceneError for a key that is
    not a path of the scene, for two keys naming the same value (the table would show values
    one of them overrides) and for a tolerance (it chooses the modes per solve)."""
    root = scene.editable_source()
    seen: dict[str, str] = {}
    for key in keys:
        if not isinstance(key, str):
            raise SceneError(
                f"vary: a key must be a path such as 'tendon.0.tension', got {_fmt(key)}"
            )
        try:
            path = canonical(root, key, TABLE_KEYS)
        except PathError as exc:
            raise SceneError(str(exc)) from None
        if path in seen:
            raise SceneError(f"vary: {seen[path]} and {key} name the same value ({path})")
        if path.rsplit(".", 1)[-1] == "tolerance":
            raise SceneError(
                f"{key}: a study does not vary a tolerance, which chooses the modes per solve; "
                "give modes instead (flexgen select SCENE --tol T says which)"
            )
        seen[path] = key
    return list(seen)


def plan(
    scene: Scene,
    vary: Mapping[str, Any],
    samples: int | None = None,
    seed: int | None = None,
) -> Plan:
    """Check a study and lay out its cases (see the module docstring)."""
    if not isinstance(vary, Mapping) or not vary:
        raise SceneError(f"vary: expected {{key: values}} with at least one key, got {_fmt(vary)}")
    keys = tuple(vary)
    targets = tuple(load_target(p) for p in _paths(scene, keys))
    if samples is None:
        if seed is not None:
            raise SceneError("seed: only with samples=N (a grid draws nothing)")
        # the count before any axis is made: (-1, -2, 10**11) would ask linspace for 745 GiB
        total = math.prod(_grid_size(vary[k]) for k in keys)
        if total > MAX_CASES:
            raise SceneError(f"vary: {total} cases (at most {MAX_CASES})")
        axes = [grid_values(k, vary[k]) for k in keys]
        for k, a in zip(keys, axes):
            _check_values(scene, k, a)
        values = _product(axes)
        # solve order: the design keys outside, the load keys inside (each stable)
        perm = [i for i, t in enumerate(targets) if t is None]
        perm += [i for i, t in enumerate(targets) if t is not None]
        shape = [len(a) for a in axes]
        solve_idx = np.indices([shape[i] for i in perm]).reshape(len(perm), -1)
        idx = np.empty_like(solve_idx)
        idx[perm] = solve_idx
        order = np.asarray(np.ravel_multi_index(tuple(idx), shape))
        row_length = shape[perm[-1]]
        return Plan(keys, targets, values, order, row_length, monte_carlo=False)
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)):
        raise SceneError(f"samples: must be an integer >= 1, got {_fmt(samples)}")
    if not 1 <= samples <= MAX_CASES:
        raise SceneError(f"samples: must be in [1, {MAX_CASES}], got {samples}")
    if seed is not None and (
        isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0
    ):
        raise SceneError(f"seed: must be an integer >= 0, got {_fmt(seed)}")
    rng = np.random.default_rng(seed)
    columns = [draw(k, vary[k], int(samples), rng) for k in keys]
    for k, c in zip(keys, columns):
        _check_values(scene, k, c)
    values = np.column_stack(columns)
    # samples are solved in their order, each from the one before (no rows)
    return Plan(keys, targets, values, np.arange(samples), int(samples), monte_carlo=True)


def _product(axes: list[np.ndarray]) -> np.ndarray:
    """Every combination, C order (the first axis slowest): cases x axes."""
    grids = np.meshgrid(*axes, indexing="ij")
    return np.column_stack([g.ravel() for g in grids])
