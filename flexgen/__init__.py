"""flexgen: the smooth curvature model of planar flexures, as generated NumPy and C99 kernels."""
