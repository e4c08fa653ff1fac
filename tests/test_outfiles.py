"""flexgen/outfiles.py: every output file is written whole or not at all, with open()'s mode."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from flexgen.codegen.render import write_files
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
    """`flexgen generate` writes a controller's files through write_files: one that fails is a
    WriteFailed naming it, and the files already there keep their old text."""
    (tmp_path / "a.h").write_text("old header")
    real_open = open

    def failing_open(path, *args, **kwargs):
        if Path(path).name.startswith(".b.c."):
            raise OSError(28, "No space left on device")
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr("builtins.open", failing_open)
    with pytest.raises(WriteFailed, match=r"No space left on device"):
        write_files({"a.h": "new header", "b.c": "code"}, tmp_path)
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h"]
    assert (tmp_path / "a.h").read_text() == "old header"


def test_a_target_that_is_a_folder_fails_before_anything_is_written(tmp_path):
    """A rename onto a folder would fail after the targets before it were replaced: the targets
    are checked first, so the existing a.h keeps its old text."""
    (tmp_path / "a.h").write_text("old header")
    (tmp_path / "b.mk").mkdir()
    with pytest.raises(WriteFailed) as caught:
        write_texts({tmp_path / "a.h": "new header", tmp_path / "b.mk": "rules"})
    assert caught.value.path == tmp_path / "b.mk" and caught.value.why == "is a folder"
    assert (tmp_path / "a.h").read_text() == "old header"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h", "b.mk"]


def test_a_replaced_file_keeps_its_mode_and_a_target_twice_is_refused(tmp_path):
    private = tmp_path / "private.h"
    private.write_text("old")
    private.chmod(0o600)
    write_texts({private: "new"})
    assert private.read_text() == "new" and stat.S_IMODE(private.stat().st_mode) == 0o600
    with pytest.raises(ValueError, match="twice"):
        write_all([(private, _full_disk), (private, _full_disk)])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["private.h"]


def test_a_failed_write_is_exit_1_naming_the_file(tmp_path, monkeypatch, capsys):
    """Not bad input (exit 2): the system's reason on one line, as plot and sweep say it."""
    from flexgen.cli import main

    real_open = open

    def failing_open(path, *args, **kwargs):
        if Path(path).name.startswith(".finger.c."):
            raise OSError(27, "File too large")
        return real_open(path, *args, **kwargs)

    scene = Path(__file__).resolve().parents[1] / "examples" / "two_link_finger.toml"
    monkeypatch.setattr("builtins.open", failing_open)
    code = main(["generate", "--scene", str(scene), "--prefix", "finger", "--out", str(tmp_path)])
    monkeypatch.undo()
    err = capsys.readouterr().err
    assert code == 1
    assert err == f"flexgen: cannot write {tmp_path / 'finger.c'}: File too large\n"
    assert list(tmp_path.iterdir()) == []


def test_a_folder_that_fails_deep_leaves_none_of_the_folders_made_before(tmp_path):
    """mkdir of a/b/<a name too long> fails after a and a/b were made: both are removed."""
    target = tmp_path / "a" / "b" / ("L" * 300) / "t.txt"
    with pytest.raises(WriteFailed):
        write_texts({target: "x"})
    assert list(tmp_path.iterdir()) == []


def test_an_output_folder_that_is_a_dangling_link_is_refused_up_front(tmp_path):
    """mkdir would meet the link only after the work ("File exists"): folder_problem says it
    first, as it says a name too long for the system."""
    from flexgen.outfiles import folder_problem

    (tmp_path / "dang").symlink_to(tmp_path / "nowhere" / "zz")
    assert (
        folder_problem(tmp_path / "dang" / "sub")
        == f"{tmp_path / 'dang'} is a symbolic link to nothing"
    )
    assert folder_problem(tmp_path / ("L" * 300)) == "File name too long"
    assert folder_problem(tmp_path / "fresh" / "sub") is None
