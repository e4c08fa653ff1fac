"""The compiled chain solver: ``chain_solver.c`` behind ctypes.

``flexgen.equilibrium.solve(..., backend="c")`` flattens the scene and its models into the C
structs of ``chain_solver.h`` (``plan.py``), links the generated C kernels it needs by function
pointer (``library.py`` compiles and caches one shared library per source) and solves in one
call (``solver.py``). The C solver takes the full load in one Newton solve and accepts it only
under the checks of ``equilibrium._direct_solve``; every other case (buckling, snap-through, a
kernel switch, a model it does not know) goes back to the Python solver, so both backends give
the same answers, and the Python one remains the reference.
"""
