"""Command output that the docs quote verbatim is the commands' output now (review: the select
example's per-flexure estimates and a quoted safety-factor warning had drifted from it)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import flexgen

ROOT = Path(__file__).resolve().parents[1]


def _squeeze(text: str) -> str:
    """Whitespace runs as one space: a quote wrapped over lines of a page reads as one line."""
    return re.sub(r"\s+", " ", text)


def test_the_select_example_on_selection_md_is_the_commands_output():
    page = (ROOT / "docs" / "selection.md").read_text()
    run = subprocess.run(
        [sys.executable, "-m", "flexgen", "select", "examples/two_link_finger.toml"]
        + ["--tol", "1e-6", "--repeat", "0"],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert run.returncode == 0, run.stderr
    # every line but the timings (cost, selection), which move with the machine
    lines = [
        line
        for line in run.stdout.splitlines()
        if line.strip() and not line.lstrip().startswith(("cost:", "selection:"))
    ]
    assert len(lines) >= 5  # scene, header, the two flexures, the whole answer's estimate
    for line in lines:
        assert line in page, f"docs/selection.md does not show {line!r}"


def test_the_quoted_safety_factor_warning_on_solve_md_is_the_answers():
    page = _squeeze((ROOT / "docs" / "solve.md").read_text())
    result = flexgen.solve(ROOT / "examples" / "steel_finger.toml", model="cc")
    quoted = [w for w in result.warnings if w.startswith("flexure 'middle': safety factor")]
    assert len(quoted) == 1
    assert f"`{quoted[0]}`" in page
