"""Render: the Jinja2 environment over templates/, and deterministic writing and checking."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import jinja2

_PACKAGE = Path(__file__).resolve().parents[1]
# installed: the package's own copy (flexgen/templates); a source checkout: the top-level folder
TEMPLATES = (
    _PACKAGE / "templates" if (_PACKAGE / "templates").is_dir() else _PACKAGE.parent / "templates"
)


def environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TEMPLATES)),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        autoescape=False,
    )


def render(template: str, context: dict) -> str:
    text = environment().get_template(template).render(**context)
    # one trailing newline, no trailing spaces: byte-stable output
    return "\n".join(line.rstrip() for line in text.splitlines()) + "\n"


def stale_files(files: dict[str, str], out_dir: Path) -> list[str]:
    """Relative paths whose file in out_dir is missing or differs from the rendered text."""
    stale = []
    for rel, text in sorted(files.items()):
        path = out_dir / rel
        if not path.is_file() or path.read_text() != text:
            stale.append(rel)
    return stale


class OutputError(OSError):
    """An output folder that cannot be written: one line naming it (nothing was written)."""


def check_writable(out_dir: Path) -> None:
    """OutputError unless out_dir is, or can be created as, a folder this user may write (so
    that a bad --out fails before any work)."""
    probe = Path(out_dir)
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"--out: cannot write {out_dir}: {probe} is not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"--out: cannot write {out_dir}: {probe} is not writable")


def write_files(files: dict[str, str], out_dir: Path) -> list[str]:
    """Write every file atomically (temp file + rename); returns the paths written.

    All texts are rendered before this is called, and a folder or file that cannot be written
    is an OutputError after the files this call created are removed again, so a failure leaves
    nothing half-written.
    """
    written: list[str] = []
    created: list[Path] = []
    try:
        for rel, text in sorted(files.items()):
            path = out_dir / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            existed = path.exists()
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
            try:
                with os.fdopen(fd, "w", newline="\n") as handle:
                    handle.write(text)
                os.chmod(tmp, 0o644)
                os.replace(tmp, path)
            except BaseException:  # a full disk: no half-written temporary file stays behind
                Path(tmp).unlink(missing_ok=True)
                raise
            if not existed:
                created.append(path)
            written.append(str(path))
    except OSError as exc:
        for path in created:
            path.unlink(missing_ok=True)
        where = exc.filename or out_dir
        raise OutputError(f"--out: cannot write {where}: {exc.strerror or exc}") from None
    return written
