"""What the subcommands share: the repository root, the one-line usage error, argument types."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


class UsageError(Exception):
    """Bad command-line input: one line on stderr, exit code 2."""


def integer(minimum: int | None = None):
    """argparse type: an integer (at least ``minimum``), with a one-line message otherwise."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or (minimum is not None and value < minimum):
            bound = f" >= {minimum}" if minimum is not None else ""
            raise argparse.ArgumentTypeError(f"must be an integer{bound}, got {text!r}")
        return value

    return parse


def tolerance(text: str) -> float:
    """argparse type: a relative tolerance in (0, 1)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"must be a number in (0, 1), got {text!r}")
    return value
