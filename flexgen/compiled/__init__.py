"""The solver core's C sources: ``chain_solver.c`` and ``chain_solver.h`` (C99, no heap, no
globals), built with the shipped kernels into the extension module ``flexgen._core`` at install
time by ``_build_core.py`` (see ``flexgen.core``)."""
