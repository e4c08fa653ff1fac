"""What the subcommands share: the one-line usage error, argument types."""

from __future__ import annotations

import argparse
import importlib.util
import math
from pathlib import Path


class ExamplesFormatter(argparse.HelpFormatter):
    """argparse's help, with an epilog of examples ("examples:" first) printed as written: the
    description and the options' help are wrapped to the terminal as usual (RawDescription-
    HelpFormatter left a description of one long line)."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if not text.startswith("examples:"):
            return super()._fill_text(text, width, indent)
        examples, _, rest = text.partition("\n\n")  # prose after the examples is wrapped
        shown = "".join(indent + line for line in examples.splitlines(keepends=True))
        paragraphs = [
            super(ExamplesFormatter, self)._fill_text(p, width, indent)
            for p in rest.split("\n\n")
            if p.strip()
        ]
        return "\n\n".join([shown, *paragraphs])


class UsageError(Exception):
    """Bad command-line input: one line on stderr, exit code 2."""


class MissingExtra(Exception):
    """An optional dependency the command needs is not installed: one line naming the extra
    to install, exit code 1 (the input may be right: as flexgen plot without matplotlib)."""


def require_extra(module: str, message: str) -> None:
    """MissingExtra(message) unless ``module`` is installed (found, not imported: asked
    before any work, so that nothing is solved for an output that cannot be made)."""
    if importlib.util.find_spec(module) is None:
        raise MissingExtra(message)


def output_path(text: str) -> Path:
    """An --out folder: an empty one is refused (Path("") is the current folder, which nobody
    means by it)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path (give a folder name)")
    return Path(text)


def output_file(text: str) -> Path:
    """An -o / --out / --plot file: an empty name is refused (it would read as the current
    folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path (give a file name)")
    return Path(text)


def integer(minimum: int | None = None, maximum: int | None = None):
    """argparse type: an integer (in [minimum, maximum] where given), with a one-line message
    otherwise."""

    def parse(text: str) -> int:
        try:
            value = int(text) if len(text) <= 100 else None
        except ValueError:
            value = None
        if (
            value is None
            or (minimum is not None and value < minimum)
            or (maximum is not None and value > maximum)
        ):
            if maximum is not None:
                bound = f" in [{minimum}, {maximum}]"
            else:
                bound = f" >= {minimum}" if minimum is not None else ""
            raise argparse.ArgumentTypeError(f"must be an integer{bound}, got {_short(text)}")
        return value

    return parse


def tolerance(text: str) -> float:
    """argparse type: a relative tolerance in (0, 1)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"must be a number in (0, 1), got {_short(text)}")
    return value


def _short(text: str) -> str:
    s = repr(text)
    return s if len(s) <= 60 else s[:57] + "..."


def printable(text: str) -> str:
    """``text`` with every control character but newlines and tabs escaped (``\\x1b``, ...),
    so that names from a scene cannot move the cursor or recolour a terminal."""
    if text.isprintable():
        return text
    return "".join(
        c if c.isprintable() or c in "\n\t" else repr(c)[1:-1] if c != "\\" else c for c in text
    )
