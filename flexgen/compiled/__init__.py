"""The compiled chain solver: ``chain_solver.c`` behind ctypes.

``flexgen.equilibrium.solve(..., backend="c")`` flattens the scene and its models into the C
structs of ``chain_solver.h`` (``plan.py``), links the generated C kernels it needs by function
pointer (``library.py`` compiles and caches one shared library per source) and solves in one
call (``solver.py``). The C solver runs the Python solver's algorithm step for step (the direct
full-load attempt, the load continuation with its bifurcations and snap-throughs, the warm start)
with its kernel switches, and hands the scene back wherever the Python solver would do more (a
failed warm start, no equilibrium found, a model it does not know), so both backends give the
same answers and the Python one remains the reference.
See docs/compiled-solver.md.
"""
