"""Time and memory of a solve at the scene limits (docs/scene.md, "Limits").

    python benchmarks/limits.py          # about 4 minutes on this project's machine

Each scene is a chain of flexures (2 mm long, EI = 1e-3) under a small tip force, solved by
`flexgen solve SCENE --json` in a child process; printed: the wall time and the child's peak
resident memory (getrusage). The scenes sit at the limits docs/scene.md states:

- fem: 256 flexures of 8 elements, 2048 generalized coordinates (the coordinate limit);
- fem: 4 flexures of 512 elements (the element limit), 2048 coordinates;
- scm3: 512 flexures (the flexure limit), 1536 coordinates;
- scm with a tolerance (the modes chosen per flexure): 64 and 128 flexures (at most 8 modes
  each: 512 and 1024 coordinates; 256 flexures, the coordinate limit's, take minutes).

The exact solver at these sizes is not timed: it takes minutes (512 flexures: still running
after 250 s in a review), which docs/scene.md says.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

SCENES = {
    "fem, 256 flexures x 8 elements (2048 coordinates)": (
        256,
        '[model]\nkind = "fem"\nelements = 8\n',
    ),
    "fem, 4 flexures x 512 elements (2048 coordinates)": (
        4,
        '[model]\nkind = "fem"\nelements = 512\n',
    ),
    "scm3, 512 flexures (1536 coordinates)": (512, ""),
    # a tolerance chooses the modes flexure by flexure, each choice a solve of the whole
    # chain: its time grows about as the square of the flexures (docs/scene.md, Limits)
    "scm, tolerance 1e-3, 64 flexures": (64, "[model]\ntolerance = 1e-3\n"),
    "scm, tolerance 1e-3, 128 flexures": (128, "[model]\ntolerance = 1e-3\n"),
}


def chain(flexures: int, model: str) -> str:
    parts = [f'[[flexure]]\nname = "f{i}"\nlength = 0.002\nEI = 1e-3\n' for i in range(flexures)]
    tip = f'[[load]]\npoint = "f{flexures - 1}.tip"\nforce = [0.0, -0.0001]\n'
    return "".join(parts) + model + tip


_CHILD = """
import resource, sys
from flexgen.cli import main
code = main(["solve", sys.argv[1], "--json"])
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, code, file=sys.stderr)
"""


def measure(path: Path) -> tuple[float, float, int]:
    """(seconds, peak resident MB, exit code) of one `flexgen solve --json`, in a process of
    its own (its peak is its own)."""
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", _CHILD, str(path)], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    kb, code = done.stderr.split()[-2:]  # ru_maxrss: KB on Linux
    return seconds, int(kb) / 1024.0, int(code)


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        for label, (flexures, model) in SCENES.items():
            path = Path(tmp) / "scene.toml"
            path.write_text(chain(flexures, model))
            seconds, mb, code = measure(path)
            print(f"{label}: {seconds:.1f} s, peak {mb:.0f} MB, exit {code}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
