"""Render: the Jinja2 environment over templates/, and deterministic writing and checking."""

from __future__ import annotations

from pathlib import Path

import jinja2

from flexgen.outfiles import OutputError, UnusableTarget, write_texts

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
        try:
            same = path.is_file() and path.read_text() == text
        except OSError:  # unreadable, or a name too long: not the file expected
            same = False
        if not same:
            stale.append(rel)
    return stale


def write_files(files: dict[str, str], out_dir: Path) -> list[str]:
    """Write every file (relative path -> text) under out_dir, all or nothing
    (flexgen/outfiles.py); returns the paths written. All texts are rendered before this is
    called; a target that is a folder or another non-file is an OutputError (bad --out, found
    before anything is written), a file that cannot be written a WriteFailed naming it (an
    OSError: a full disk is not bad input), and nothing is left half-written."""
    paths = {out_dir / rel: text for rel, text in sorted(files.items())}
    try:
        write_texts(paths)
    except UnusableTarget as exc:
        raise OutputError(f"--out: cannot write {exc.path}: {exc.why}") from None
    return [str(path) for path in paths]
