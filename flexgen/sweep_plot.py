"""Plots of a study (``flexgen sweep --plot``): what a designer asks of it.

- one varied key: the last output point's compliance ellipse axes, tip pose and the largest
  flexure stress (when known) against the key; failed and unstable cases marked on the axis;
- two varied keys: a heatmap per output (the same three) over the grid, failed cases hatched
  grey, unstable cases crossed;
- Monte-Carlo: a histogram of each output with its 5-95 percentile band and median.

Matplotlib with the Agg backend, written as flexgen/drawing.py writes (a temporary file renamed).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .drawing import _save, _text, _with_unit
from .units import key_dimension

BAND = (5.0, 95.0)  # the percentile band of a Monte-Carlo histogram


def outputs(df: Any, units: Any = None) -> list[tuple[str, str]]:
    """(column, label) of the outputs drawn: the last output point's ellipse axes and pose, and
    the largest flexure stress ("max stress", added by ``draw_study``) when any is known.
    Labels carry the scene's units (``Scene.units``; none for plain numbers)."""

    def unit(name: str, quantity: str) -> str:
        return _with_unit(name, units.label(quantity) if units is not None else "")

    points = [c[: -len(".major")] for c in df.columns if c.endswith(".major")]
    out: list[tuple[str, str]] = []
    if points:
        p = points[-1]
        out += [
            (f"{p}.major", unit(f"{p} compliance major", "compliance")),
            (f"{p}.minor", unit(f"{p} compliance minor", "compliance")),
            (f"{p}.x", unit(f"{p} x", "length")),
            (f"{p}.y", unit(f"{p} y", "length")),
        ]
    if "max stress" in df.columns and df["max stress"].notna().any():
        out.append(("max stress", unit("largest flexure stress", "stress")))
    return out


def draw_study(
    df: Any, keys: list[str], monte_carlo: bool, path: str | Path, units: Any = None
) -> Path:
    """Draw the study ``df`` (flexgen.sweep's table; ``keys`` its varied keys) into ``path``
    (.png, .svg or .pdf); ``units``: the scene's (``Scene.units``) for the labels."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    stresses = [c for c in df.columns if c.endswith(".max_stress")]
    if stresses:
        df = df.assign(**{"max stress": df[stresses].max(axis=1)})
    shown = outputs(df, units)
    ncols = 2 if len(shown) == 4 else min(len(shown), 3)
    nrows = -(-len(shown) // ncols)
    fig = Figure(figsize=(5.0 * ncols, 4.0 * nrows), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[len(shown) :]:
        ax.set_visible(False)
    ok = df["converged"].to_numpy(bool)
    unstable = ok & ~df["stable"].to_numpy(bool)
    for ax, (col, label) in zip(axes, shown):
        y = df[col].to_numpy(float)
        if monte_carlo:
            _histogram(ax, y[ok], label)
        elif len(keys) == 1:
            x = df[keys[0]].to_numpy(float)
            ax.plot(x[ok], y[ok], "o-", ms=3, color="C0")
            ax.plot(x[unstable], y[unstable], "x", color="C3", label="unstable")
            for xf in x[~ok]:
                ax.axvline(xf, color="0.7", lw=0.8)
            if not ok.any() and np.isfinite(x).any():
                # axvline does not set the limits (review: every case failed, the key's values
                # of 1e-6 and 2e-6 were drawn on an axis of -0.055..0.055)
                lo, hi = float(np.nanmin(x)), float(np.nanmax(x))
                pad = 0.05 * (hi - lo) if hi > lo else 0.05 * abs(lo) or 0.05
                ax.set_xlim(lo - pad, hi + pad)
            ax.set_xlabel(_text(_key_label(keys[0], units)))
            ax.set_ylabel(_text(label))
        else:
            _heatmap(fig, ax, df, keys[:2], y, ok, unstable, label, units)
        ax.grid(alpha=0.3)
    title = f"{len(df)} cases, {int((~ok).sum())} without an equilibrium"
    if unstable.any():
        title += f", {int(unstable.sum())} unstable"
    if len(keys) > 2 and not monte_carlo:
        title += f" (heatmaps over {keys[0]} x {keys[1]}: every other key's first value)"
    fig.suptitle(_text(title))
    path = Path(path)
    _save(fig, path)
    return path


def _key_label(key: str, units: Any) -> str:
    """A varied key with its unit in the scene's units (none for plain numbers or a count)."""
    dimension = key_dimension(key)
    return _with_unit(key, units.label(dimension) if units is not None and dimension else "")


def _histogram(ax: Any, y: np.ndarray, label: str) -> None:
    y = y[np.isfinite(y)]
    ax.set_xlabel(_text(label))
    ax.set_ylabel("cases")
    if not y.size:
        return
    lo, hi = float(y.min()), float(y.max())
    span = None
    if not hi - lo > 1e-9 * max(abs(lo), abs(hi)):
        # values equal to rounding (a zero spread, or a key the output does not follow): one
        # bar over an explicit range; Matplotlib cannot cut 5 bins from a span of a few ulps
        # (review: 'Too many bins for data range', the whole study lost)
        half = 1e-6 * abs(lo) if lo != 0.0 else 1.0
        span = (lo - half, hi + half)
    bins = 1 if span is not None else min(50, max(5, y.size // 20))
    ax.hist(y, bins=bins, range=span, color="C0", alpha=0.8)
    if span is not None:
        ax.ticklabel_format(axis="x", useOffset=False)  # the value itself, not 1e-7 + offset
    lo, hi = np.percentile(y, BAND)
    ax.axvspan(lo, hi, color="C1", alpha=0.2, label=f"{BAND[0]:g}-{BAND[1]:g} %")
    ax.axvline(float(np.median(y)), color="C1", lw=1.5, label="median")
    ax.legend(fontsize=8)


def _heatmap(fig, ax, df, keys, y, ok, unstable, label, units) -> None:
    """``y`` over the first two keys (the other keys at their first value)."""
    first = np.ones(len(df), bool)
    for k in df.columns[: df.columns.get_loc("converged")]:
        if k not in keys:
            first &= df[k].to_numpy(float) == df[k].iloc[0]
    xs = np.unique(df[keys[1]].to_numpy(float)[first])
    ys = np.unique(df[keys[0]].to_numpy(float)[first])
    grid = np.full((ys.size, xs.size), np.nan)
    failed = np.zeros_like(grid, bool)
    cross = np.zeros_like(grid, bool)
    xi = np.searchsorted(xs, df[keys[1]].to_numpy(float)[first])
    yi = np.searchsorted(ys, df[keys[0]].to_numpy(float)[first])
    grid[yi, xi] = np.where(ok[first], y[first], np.nan)
    failed[yi, xi] = ~ok[first]
    cross[yi, xi] = unstable[first]
    mesh = ax.pcolormesh(_edges(xs), _edges(ys), grid, shading="flat", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=_text(label))
    xc, yc = np.meshgrid(xs, ys)
    ax.scatter(xc[failed], yc[failed], marker="s", s=30, color="0.6", label="no equilibrium")
    ax.scatter(xc[cross], yc[cross], marker="x", color="C3", label="unstable")
    if failed.any() or cross.any():
        ax.legend(fontsize=8)
    ax.set_xlabel(_text(_key_label(keys[1], units)))
    ax.set_ylabel(_text(_key_label(keys[0], units)))


def _edges(v: np.ndarray) -> np.ndarray:
    """Cell edges around the grid values (a single value gets a cell of its own size)."""
    if v.size == 1:
        w = abs(v[0]) * 0.05 or 0.5
        return np.array([v[0] - w, v[0] + w])
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])
