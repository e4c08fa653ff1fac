"""Output files written whole or not at all: the one writer of every file flexgen makes
(`generate`, `bench` and `stability` pages, `plot`, `sweep --out/--plot`).

Every target is checked first (one that exists must be a regular file: a rename onto a folder
would fail after the targets before it were replaced), then written to a hidden temporary file
in its own folder (so that the rename onto it is atomic), and only when every one is complete
are they renamed onto their targets. If anything fails, the temporary files, the targets this
call created and the folders it created are removed, and WriteFailed names the target: a full
disk never leaves a half-written or 0-byte file behind, and a set of files (a controller's
five) is replaced together or not at all (but for a rename failing between two others, which
the checks leave to the system's own faults).
A new file gets the mode a file created with open() gets, 0666 less the umask (mkstemp's 0600
would hide a generated header from the rest of a build team; a private umask keeps it private);
a file replaced keeps its mode.
"""

from __future__ import annotations

import errno
import os
import secrets
import stat
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

Writer = Callable[[Path], None]  # writes a target's content into the file at the path given


class OutputError(OSError):
    """An output folder that cannot be written: one line naming it (nothing was written).
    Here, not in codegen.render, so that the CLI names it without importing Jinja2."""


class WriteFailed(OSError):
    """A target that could not be written: ``path`` names it, ``why`` is the system's reason
    (also OSError's ``filename`` and ``strerror``, so handlers of OSError word it too)."""

    def __init__(self, path: Path, error: OSError):
        self.why = error.strerror or str(error)
        super().__init__(error.errno, self.why, str(path))
        self.path = path


class UnusableTarget(WriteFailed):
    """A target that exists and is no regular file (a folder, a symbolic link, a FIFO): found
    before anything is written, so it is the caller's bad output path, not a failed write."""


def folder_problem(folder: Path) -> str | None:
    """Why files cannot be written into ``folder`` (created with its parents if missing), or
    None: the nearest existing ancestor must be a folder this user may write."""
    probe = Path(folder)
    try:
        while not probe.exists() and probe != probe.parent:
            if probe.is_symlink():  # mkdir would meet it: "File exists" after all the work
                return f"{probe} is a symbolic link to nothing"
            probe = probe.parent
    except OSError as exc:  # a name too long for the system, a loop of links
        return f"{exc.strerror or exc}"
    if not probe.is_dir():
        return f"{probe} is not a folder"
    if not os.access(probe, os.W_OK | os.X_OK):
        return f"{probe} is not writable"
    # permission bits do not tell everything (root passes them; /sys refuses root's mkdir):
    # a folder made and removed at once says whether the writes will be refused (found by
    # review: --out /sys/foo failed only at its first file, exit 1 where bad input is 2)
    try:
        os.rmdir(tempfile.mkdtemp(dir=probe, prefix=".flexgen-probe-"))
    except OSError as exc:
        return f"{probe} refuses new files ({exc.strerror or exc})"
    return None


def check_writable(out_dir: Path, names: Sequence[str] = ()) -> None:
    """OutputError unless out_dir is, or can be created as, a folder this user may write, and
    UnusableTarget if one of the files ``names`` in it exists as no regular file (so that a bad
    --out fails before any work: generate, bench, stability; review: a folder named like a page
    failed after minutes of solving)."""
    problem = folder_problem(out_dir)
    if problem is not None:
        raise OutputError(f"--out: cannot write {out_dir}: {problem}")
    for name in names:
        _replaceable(Path(out_dir) / name)


def write_all(targets: Sequence[tuple[Path, Writer]]) -> None:
    """Each ``(target, writer)``: ``writer(temporary)`` fills a temporary file beside the target
    (hidden, with the target's suffix: writers that pick a format by it see the right one),
    then every temporary is renamed onto its target. All or nothing (the module's docstring);
    WriteFailed on failure. A target that exists and is not a regular file (a folder, a
    symbolic link, a FIFO) fails before anything is written (UnusableTarget): a rename onto it
    would fail after the targets before it were replaced. A file that exists keeps its mode, as
    open() keeps it."""
    paths = [target for target, _ in targets]
    if len(set(paths)) != len(paths):
        raise ValueError(f"write_all: a target given twice: {paths}")
    modes = {target: _replaceable(target) for target in paths}  # None: a new file
    made: list[Path] = []
    temps: dict[Path, Path] = {}  # target -> its temporary file
    renamed: list[Path] = []
    try:
        for target, write in targets:
            with _naming(target):
                _make_folders(target.parent, made)
                temps[target] = _reserve(target)
                write(temps[target])
                mode = modes[target]
                if mode is not None:
                    os.chmod(temps[target], mode)
        for target, tmp in temps.items():
            with _naming(target):
                os.replace(tmp, target)
            renamed.append(target)
    except BaseException:
        for tmp in temps.values():
            tmp.unlink(missing_ok=True)
        for target in renamed:
            if modes[target] is None:
                target.unlink(missing_ok=True)
        _remove_folders(made)
        raise


def write_texts(files: dict[Path, str]) -> None:
    """Text files (``\\n`` line ends on every platform: byte-stable generated code), all or
    nothing as ``write_all``."""

    def writer(text: str) -> Writer:
        def write(tmp: Path) -> None:
            with open(tmp, "w", newline="\n") as handle:
                handle.write(text)

        return write

    write_all([(path, writer(text)) for path, text in files.items()])


@contextmanager
def _naming(target: Path) -> Iterator[None]:
    """An OSError inside it as WriteFailed naming ``target``: a write's error names no file,
    or the temporary one."""
    try:
        yield
    except OSError as exc:  # a nested write's WriteFailed too: this call's target is the one
        raise WriteFailed(target, exc) from None


def _replaceable(target: Path) -> int | None:
    """The mode of ``target`` if it is a regular file (kept by the new one), None if it does not
    exist; WriteFailed if it is something a file cannot replace."""
    try:
        info = os.lstat(target)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise WriteFailed(target, exc) from None
    if stat.S_ISDIR(info.st_mode):
        raise UnusableTarget(target, IsADirectoryError(errno.EISDIR, "is a folder"))
    if not stat.S_ISREG(info.st_mode):
        raise UnusableTarget(target, OSError(errno.EEXIST, "is not a regular file"))
    return stat.S_IMODE(info.st_mode)


def _make_folders(folder: Path, made: list[Path]) -> None:
    """Create ``folder`` and its missing parents, outermost first, each added to ``made`` as it
    is made (so that a later one failing leaves the earlier ones to be removed)."""
    missing = []
    while not folder.exists() and folder != folder.parent:
        missing.append(folder)
        folder = folder.parent
    for f in reversed(missing):
        f.mkdir()
        made.append(f)


def _remove_folders(made: list[Path]) -> None:
    """Remove the folders a failed run created, innermost first (each only if empty)."""
    for folder in reversed(made):
        try:
            folder.rmdir()
        except OSError:
            pass


def _reserve(target: Path) -> Path:
    """A new temporary file beside ``target`` (hidden, with its suffix), created with mode 0666
    so that the system applies the umask: what open() gives a new file, without reading the
    umask (which only setting it can do: a race with other threads)."""
    for _ in range(100):
        tmp = target.parent / f".{target.name}.{secrets.token_hex(4)}{target.suffix}"
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except FileExistsError:
            continue
        return tmp
    raise FileExistsError(errno.EEXIST, "no free temporary name", str(target.parent))
