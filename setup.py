"""setuptools entry point for what pyproject.toml cannot say: the cffi extension flexgen._core
(the chain solver and the shipped C kernels, compiled at install time; see
flexgen/compiled/_build_core.py)."""

from setuptools import setup

setup(cffi_modules=["flexgen/compiled/_build_core.py:ffibuilder"])
