"""flexgen/outfiles.py: every output file is written whole or not at all, with open()'s mode."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from flexgen.codegen.render import OutputError, write_files
from flexgen.outfiles import WriteFailed, write_all, write_texts


def _full_disk(tmp: Path) -> None:
    tmp.write_bytes(b"partial")
    raise OSError(28, "No space left on device")


def test_a_failed_target_leaves_every_target_as_it_was(tmp_path):
    """The second of three targets fails half way: the first (an existing file) keeps its old
    content although its new one was complete, the third is never written, and neither
    temporaries nor the folders the call made are left."""
    old = tmp_path / "old.txt"
    old.write_text("old")
    targets = [
        (old, lambda tmp: tmp.write_text("new")),
        (tmp_path / "new" / "deep" / "b.txt", _full_disk),
        (tmp_path / "c.txt", lambda tmp: tmp.write_text("c")),
    ]
    with pytest.raises(WriteFailed) as caught:
        write_all(targets)
    assert caught.value.path == tmp_path / "new" / "deep" / "b.txt"
    assert caught.value.why == "No space left on device"
    assert old.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.txt"]


def test_every_target_is_written_with_the_mode_open_gives(tmp_path):
    old_mask = os.umask(0o027)
    try:
        write_texts({tmp_path / "a.h": "x\n", tmp_path / "sub" / "b.c": "y\n"})
        (tmp_path / "reference").write_text("")
    finally:
        os.umask(old_mask)
    modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in [*tmp_path.rglob("*")] if p.is_file()}
    assert modes == {"a.h": 0o640, "b.c": 0o640, "reference": 0o640}
    assert (tmp_path / "sub" / "b.c").read_bytes() == b"y\n"


def test_generated_files_are_all_or_nothing(tmp_path, monkeypatch):
    """`flexgen generate` writes a controller's files through write_files: one that fails is an
    OutputError naming it, and the files already there keep their old text."""
    (tmp_path / "a.h").write_text("old header")
    real_open = open

    def failing_open(path, *args, **kwargs):
        if Path(path).name.startswith(".b.c."):
            raise OSError(28, "No space left on device")
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr("builtins.open", failing_open)
    with pytest.raises(OutputError, match=r"cannot write .*b\.c: No space left on device"):
        write_files({"a.h": "new header", "b.c": "code"}, tmp_path)
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h"]
    assert (tmp_path / "a.h").read_text() == "old header"
