"""Import the scripts under benchmarks/ by path, for their tests (they are not a package)."""

import importlib.util
import sys
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"


def load_benchmark(name: str):
    """benchmarks/<name>.py as a module (registered in sys.modules: dataclasses look it up)."""
    spec = importlib.util.spec_from_file_location(
        f"flexgen_benchmarks_{name}", BENCHMARKS / f"{name}.py"
    )
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod
