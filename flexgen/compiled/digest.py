"""The digest of the C sources the core is built from (``_build_core`` compiles it into the
core; ``flexgen.core.check_fresh`` compares it with a checkout's sources). Standard library only:
the build recipe loads this file by path, before flexgen can be imported."""

from __future__ import annotations

import hashlib
from pathlib import Path


def sources_digest(solver: Path, kernels: Path) -> str:
    """SHA-256 over chain_solver.{c,h} in ``solver`` and the kernels scm*.{c,h} in ``kernels``."""
    digest = hashlib.sha256()
    for path in sorted(solver.glob("chain_solver.[ch]")) + sorted(kernels.glob("scm*.[ch]")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()
