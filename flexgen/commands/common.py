"""What the subcommands share: the repository root and the one-line usage error."""
from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


class UsageError(Exception):
    """Bad command-line input: one line on stderr, exit code 2."""
