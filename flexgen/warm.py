"""When a solve may start from an earlier answer (a warm start): one rule for every caller.

A warm start is Newton at the full load from an earlier answer. Where a scene has more than one
stable equilibrium (a post-buckled column bends either way; a bistable mechanism), Newton from a
neighbour can land on the neighbour's branch while the load path from the unloaded state, what
``flexgen.solve`` follows, takes the other. A warm start is therefore taken only where that
cannot happen by a small step:

- the inputs changed little: per group (every load's fx, every fy, every moment, every tendon
  tension) the largest absolute change is at most ``WARM_CHANGE`` times the group's largest
  absolute value (a lateral force turning from +0.01 to -0.01 is a change of 200 %);
- the earlier answer's load path crossed no critical load (a bifurcation or a snap-through):
  past one, the side it took is a fact of that path, not of the neighbour's.

Neither rule sees a load path that jumps between two close inputs (a branch the neighbour's
answer still holds, while the load path from the unloaded state reaches another): the core's
``settings.warm_on_path`` accepts a warm answer only on that load path (the direct solve's path
samples), which the library's solves keep on and the controller turns off (it follows its
mechanism's history on purpose).

Studies (flexgen/sweep_chunk.py) apply both, and the first also to each varied design value (a
thickness, a length: a tenfold stiffer flexure moves the equilibrium as a tenfold load does);
the emitted C controller applies the first to its inputs (``NAME_WARM_CHANGE``,
``NAME_inputs_close``), with the same constant.
"""

from __future__ import annotations

from collections.abc import Sequence

WARM_CHANGE = 0.25  # largest relative change of an input group for a warm start


def group_close(a: Sequence[float], b: Sequence[float], first: int, step: int) -> bool:
    """Whether the entries ``first, first + step, ...`` of ``a`` and ``b`` differ by at most
    ``WARM_CHANGE`` times their largest magnitude (a group of zeros in both is close)."""
    # plain comparisons, no slices or max(): a study calls this four times a case (~1 us)
    change = size = 0.0
    for k in range(first, len(a), step):
        x, y = abs(a[k]), abs(b[k])
        d = abs(a[k] - b[k])
        if d > change:
            change = d
        if x > size:
            size = x
        if y > size:
            size = y
    return change <= WARM_CHANGE * size


def inputs_close(
    loads_a: Sequence[float],
    tensions_a: Sequence[float],
    loads_b: Sequence[float],
    tensions_b: Sequence[float],
) -> bool:
    """Whether inputs b are close enough to inputs a for a warm start from a's answer. Loads
    flat, (fx, fy, moment) per load in scene order; tensions one per tendon."""
    return (
        group_close(loads_a, loads_b, 0, 3)
        and group_close(loads_a, loads_b, 1, 3)
        and group_close(loads_a, loads_b, 2, 3)
        and group_close(tensions_a, tensions_b, 0, 1)
    )


def values_close(a: Sequence[float], b: Sequence[float]) -> bool:
    """Whether every value of ``b`` is within ``WARM_CHANGE`` of the same value of ``a``, each a
    group of its own (a study's varied design values)."""
    return all(abs(x - y) <= WARM_CHANGE * max(abs(x), abs(y)) for x, y in zip(a, b))
