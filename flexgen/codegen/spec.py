"""What to generate: one KernelSpec per kernel, one small config dataclass per backend."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

FAMILIES = ("poly", "gauss", "local")
MAX_MODES = 8  # the most modes generated, and shipped (scm1 .. scm8): scenes, selection, CLI
MAX_NODES = 200  # the most Gauss nodes a kernel may have (given or searched for)
MAX_DEGREE = 60  # the highest polynomial interpolation degree (given or searched for)
DEFAULT_RANGE_DEG = {"poly": 90.0, "gauss": 180.0, "local": 270.0}
DEFAULT_TOL = 1e-10


class SpecError(ValueError):
    """A kernel request that cannot be generated; the message names the bad argument."""


@dataclass(frozen=True)
class KernelSpec:
    """One flexure kernel.

    modes     N Legendre curvature modes (1 = constant curvature).
    family    "poly": cos/sin replaced by a Chebyshev interpolant on [-range, range], the pose a
              closed-form polynomial in q; "gauss": Gauss-Legendre quadrature of cos/sin;
              "local": Gauss-Legendre quadrature with few nodes, its error bound certified at
              each q (``in_range(q)``; flexgen.symbolic.certificate) instead of on a range.
    range_deg The angle range: poly kernels are valid only while |phi| <= range along the whole
              flexure; for gauss kernels it is the range on which their error bound is certified;
              for local kernels the bend of the constant-curvature arc their nodes must certify.
    degree    poly: interpolation degree (None: the smallest meeting tol).
    nodes     gauss, local: number of nodes (None: the fewest meeting tol on the range, or
              certifying the arc of the range).
    tol       requested bound on the cos/sin error and on the pose error with rounding (poly)
              or on the pose error (gauss, local; a local kernel certifies J to 10 tol and H to
              100 tol), units of L; a gauss kernel given nodes ignores it (the CLI refuses both).
    """

    modes: int
    family: str = "poly"
    range_deg: float | None = None
    degree: int | None = None
    nodes: int | None = None
    tol: float = DEFAULT_TOL

    def __post_init__(self):
        # NumPy numbers as the Python numbers they are, a bool as no number (review: modes=True
        # generated scmTrue.c, which did not compile; np.int64(3) was "must be an integer ...,
        # got 3")
        for name in ("modes", "degree", "nodes"):
            value = getattr(self, name)
            if isinstance(value, numbers.Integral) and not isinstance(value, bool):
                object.__setattr__(self, name, int(value))
        for name in ("range_deg", "tol"):
            value = getattr(self, name)
            if isinstance(value, numbers.Real) and not isinstance(value, bool):
                try:
                    object.__setattr__(self, name, float(value))
                except OverflowError:  # 10**400: no float, refused below
                    pass
        if (
            isinstance(self.modes, bool)
            or not isinstance(self.modes, int)
            or not 1 <= self.modes <= MAX_MODES
        ):
            raise SpecError(f"--modes: must be an integer from 1 to {MAX_MODES}, got {self.modes}")
        if self.family not in FAMILIES:
            raise SpecError(f"--kernel: must be one of {', '.join(FAMILIES)}, got {self.family!r}")
        if self.range_deg is None:
            object.__setattr__(self, "range_deg", DEFAULT_RANGE_DEG[self.family])
        r = self.range_deg
        if not (isinstance(r, float) and math.isfinite(r) and r > 0):
            raise SpecError(f"--range: must be a positive number of degrees, got {r!r:.40}")
        if self.family == "poly" and r >= 180:
            raise SpecError(
                f"--range: the polynomial kernel needs a range below 180 degrees, got {r:g}"
            )
        if self.family != "poly" and r > 720:
            raise SpecError(
                f"--range: {self.family} kernels certify ranges up to 720 degrees, got {r:g}"
            )
        if not (isinstance(self.tol, float) and math.isfinite(self.tol) and 0 < self.tol < 1):
            raise SpecError(f"--tol: must be in (0, 1), got {self.tol!r:.40}")
        if self.degree is not None and not (
            isinstance(self.degree, int)
            and not isinstance(self.degree, bool)
            and 1 <= self.degree <= MAX_DEGREE
        ):
            raise SpecError(
                f"--degree: must be an integer from 1 to {MAX_DEGREE}, got {self.degree}"
            )
        if self.nodes is not None and not (
            isinstance(self.nodes, int)
            and not isinstance(self.nodes, bool)
            and 1 <= self.nodes <= MAX_NODES
        ):
            raise SpecError(f"--nodes: must be an integer from 1 to {MAX_NODES}, got {self.nodes}")
        if self.family == "poly" and self.nodes is not None:
            raise SpecError("--nodes: only for --kernel gauss or local")
        if self.family != "poly" and self.degree is not None:
            raise SpecError("--degree: only for --kernel poly")

    @property
    def range_rad(self) -> float:
        assert self.range_deg is not None  # __post_init__ replaces None by the family default
        return math.radians(self.range_deg)


@dataclass(frozen=True)
class NumPyConfig:
    """NumPy backend: one module per kernel, imports numpy only."""

    folder: str = "numpy"  # under the output folder
    template: str = "numpy/kernel.py.jinja"


@dataclass(frozen=True)
class CConfig:
    """C99 backend: a header and a source per kernel, with double and float entry points."""

    folder: str = "c"
    header_template: str = "c/kernel.h.jinja"
    source_template: str = "c/kernel.c.jinja"


# the languages `flexgen generate --lang` offers: each one's config here, its printer in
# printers.py and its emitter in generate.py's EMITTERS
BACKENDS: dict[str, NumPyConfig | CConfig] = {"numpy": NumPyConfig(), "c": CConfig()}
