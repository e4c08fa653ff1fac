"""`make demo` leaves a fresh clone clean: its drawings go to an untracked folder, and only
`make drawings` (examples/demo.py --drawings) rewrites the ones the docs show."""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _demo():
    spec = importlib.util.spec_from_file_location("flexgen_demo", ROOT / "examples" / "demo.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.skipif(
    shutil.which("git") is None or not (ROOT / ".git").exists(), reason="not a git checkout"
)
def test_the_demo_draws_into_an_ignored_folder_and_the_drawings_target_into_docs():
    demo = _demo()
    drawing = (demo.DEMO_OUT / "finger.png").relative_to(ROOT)
    ignored = subprocess.run(
        ["git", "check-ignore", "-q", str(drawing)], cwd=ROOT, check=False
    ).returncode
    assert ignored == 0, f"{drawing} is not ignored by git: the demo would dirty a fresh clone"
    assert demo.DOCS == ROOT / "docs"
    shown = subprocess.run(
        ["git", "ls-files", "docs/finger.png"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.strip()
    assert shown == "docs/finger.png"  # what --drawings rewrites is what the docs show


def test_the_demo_drawings_are_the_five_the_docs_name(tmp_path):
    pytest.importorskip("matplotlib")
    demo = _demo()
    demo.plots(tmp_path)
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == [
        "arc_moment.png",
        "cantilever_tip_load.png",
        "finger.png",
        "finger_slack.png",
        "rectangular_elastica.png",
    ]
    assert all((ROOT / "docs" / name).exists() for name in written)
